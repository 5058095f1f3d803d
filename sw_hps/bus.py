"""Register access to the FPGA slaves from the board's ARM (thesis §7.4.1).

Runs on the board's ARM: Python 3 and numpy only, nothing else from this project.

A *bus* is a window of 32-bit registers addressed by byte offset:

* :class:`DevMemBus` maps the lightweight HPS-to-FPGA bridge (physical base
  ``0xFF200000`` on the Cyclone V) through ``/dev/mem`` (needs root);
* :class:`UioBus` maps a UIO device (``/dev/uioN``) whose map 0 is the slave
  (its size taken from sysfs, :func:`read_uio_map`);
* :class:`SimBus` forwards to in-process models (tests, ``--bus sim``).

Every backend checks offsets the same way: an offset that is not a multiple of 4,
or whose word does not lie inside the span, raises ``ValueError``.
"""
from __future__ import annotations

import logging
import mmap
import os
from collections import namedtuple
try:  # Python 3.8+; on 3.7 the interface is only documented
    from typing import Protocol, runtime_checkable
except ImportError:
    Protocol = object

    def runtime_checkable(cls):
        return cls

from soc.hps_interface import LIGHTWEIGHT_BRIDGE_BASE

__all__ = ["Bus", "BusError", "DevMemBus", "UioBus", "UioMap", "read_uio_map", "UIO_SYSFS",
           "SimBus", "check_offset"]

log = logging.getLogger(__name__)

_WORD = 4


class BusError(OSError):
    """A bus cannot be opened or used (message names the device path)."""


@runtime_checkable
class Bus(Protocol):
    """32-bit register window addressed by byte offset."""

    def read32(self, offset: int) -> int: ...

    def write32(self, offset: int, value: int) -> None: ...

    def close(self) -> None: ...


def check_offset(offset, span: int) -> int:
    """Validate a register offset: an int, multiple of 4, word inside ``[0, span)``."""
    if isinstance(offset, bool) or not isinstance(offset, int):
        raise ValueError(f"offset must be an int, got {offset!r}")
    if offset % _WORD:
        raise ValueError(f"offset must be a multiple of 4, got {offset:#x}")
    if not 0 <= offset <= span - _WORD:
        raise ValueError(f"offset must be in [0, {span - _WORD:#x}], got {offset:#x}")
    return offset


def _check_value(value) -> int:
    if isinstance(value, bool) or not isinstance(value, int) or not 0 <= value <= 0xFFFFFFFF:
        raise ValueError(f"value must be an int in [0, 0xffffffff], got {value!r}")
    return value


def _check_span(span) -> int:
    if isinstance(span, bool) or not isinstance(span, int) or span < _WORD or span % _WORD:
        raise ValueError(f"span must be a positive multiple of 4, got {span!r}")
    return span


class _MmapBus:
    """Common part of the memory-mapped backends: map ``span`` bytes of ``path``
    starting at byte ``address`` (need not be page aligned)."""

    def __init__(self, path: str, address: int, span: int):
        self.path = str(path)
        self.span = _check_span(span)
        if isinstance(address, bool) or not isinstance(address, int) or address < 0 \
                or address % _WORD:
            raise ValueError(f"address must be a non-negative multiple of 4, got {address!r}")
        page = mmap.ALLOCATIONGRANULARITY
        page_base = address - address % page
        self._delta = address - page_base
        self._map = None
        self._words = None
        try:
            fd = os.open(self.path, os.O_RDWR | os.O_SYNC)
        except PermissionError:
            raise BusError(f"cannot open {self.path}: permission denied "
                           "(run as root or grant access to the device)") from None
        except FileNotFoundError:
            raise BusError(f"cannot open {self.path}: no such device") from None
        except OSError as exc:
            raise BusError(f"cannot open {self.path}: {exc.strerror}") from None
        try:
            self._map = mmap.mmap(fd, self._delta + self.span, mmap.MAP_SHARED,
                                  mmap.PROT_READ | mmap.PROT_WRITE, offset=page_base)
        except (OSError, ValueError, OverflowError) as exc:
            reason = getattr(exc, "strerror", None) or str(exc)
            raise BusError(f"cannot map {self.path} at {address:#x} "
                           f"(span {self.span:#x}): {reason}") from None
        finally:
            os.close(fd)
        # One aligned 32-bit load/store per access through a word view.
        self._words = memoryview(self._map).cast("B")[self._delta:self._delta + self.span] \
            .cast("I")

    def read32(self, offset: int) -> int:
        check_offset(offset, self.span)
        if self._words is None:
            raise BusError(f"{self.path}: bus is closed")
        return int(self._words[offset // _WORD])

    def write32(self, offset: int, value: int) -> None:
        check_offset(offset, self.span)
        _check_value(value)
        if self._words is None:
            raise BusError(f"{self.path}: bus is closed")
        self._words[offset // _WORD] = value

    def close(self) -> None:
        if self._words is not None:
            self._words.release()
            self._words = None
        if self._map is not None:
            self._map.close()
            self._map = None

    def __enter__(self):
        return self

    def __exit__(self, *exc):
        self.close()


class DevMemBus(_MmapBus):
    """The lightweight HPS-to-FPGA bridge through ``/dev/mem`` (thesis §7.4.1).

    Parameters
    ----------
    base : int
        Physical address of the bridge (``0xFF200000`` on the Cyclone V HPS).
    offset : int
        Byte offset of the window inside the bridge (where Qsys placed the slaves).
    span : int
        Bytes mapped from ``base + offset``; offsets given to ``read32``/``write32``
        are relative to ``base + offset``.
    path : str
        The memory device; injectable so tests map a plain file.

    Raises
    ------
    BusError
        If the device cannot be opened (the message names ``path``) or mapped.
    ValueError
        Bad ``base``, ``offset`` or ``span``.
    """

    def __init__(self, base: int = LIGHTWEIGHT_BRIDGE_BASE, offset: int = 0, span: int = 0x1000,
                 path: str = "/dev/mem"):
        for name, value in (("base", base), ("offset", offset)):
            if isinstance(value, bool) or not isinstance(value, int) or value < 0 or value % 4:
                raise ValueError(f"{name} must be a non-negative multiple of 4, got {value!r}")
        self.base = base
        self.offset = offset
        super().__init__(path, base + offset, span)


#: Where the kernel describes each UIO device (``uioN/name``, ``uioN/maps/map0/...``).
UIO_SYSFS = "/sys/class/uio"

#: Map 0 of a UIO device as sysfs describes it: ``device`` (``uioN``), ``name``
#: (the device-tree node's name), ``addr`` (physical address), ``size`` (bytes)
#: and ``offset`` (of the registers inside the first mapped page); a value sysfs
#: does not give is None.
UioMap = namedtuple("UioMap", "device name addr size offset")


def _read_sysfs(path):
    try:
        with open(path) as handle:
            return handle.read().strip()
    except OSError:
        return None


def _sysfs_int(path):
    text = _read_sysfs(path)
    try:
        return None if text is None else int(text, 0)
    except ValueError:
        return None


def read_uio_map(path: str, sysfs: str = UIO_SYSFS):
    """Map 0 of the UIO device node ``path`` (a udev symlink to it works too),
    from ``sysfs``; None if sysfs has no entry for it (not a UIO device).

    Returns
    -------
    UioMap or None
    """
    device = os.path.basename(os.path.realpath(str(path)))
    root = os.path.join(str(sysfs), device)
    if not os.path.isdir(root):
        return None
    maps = os.path.join(root, "maps", "map0")
    return UioMap(device=device, name=_read_sysfs(os.path.join(root, "name")),
                  addr=_sysfs_int(os.path.join(maps, "addr")),
                  size=_sysfs_int(os.path.join(maps, "size")),
                  offset=_sysfs_int(os.path.join(maps, "offset")))


def _uio_reg(uio_map, need: int) -> str:
    """The device-tree ``reg`` that gives ``need`` bytes in whole pages."""
    page = mmap.PAGESIZE
    size = max(page, -(-need // page) * page)
    addr = "<base>" if uio_map.addr is None else f"{uio_map.addr:#x}"
    return f"reg = <{addr} {size:#x}>"


class UioBus(_MmapBus):
    """A slave exposed by a UIO driver (``/dev/uioN``, map 0).

    The map's size is read from ``<sysfs>/uioN/maps/map0/size`` and at most that
    many bytes are mapped: newer kernels refuse an mmap longer than the map (in
    whole pages), which the device-tree node's ``reg`` sets.

    Parameters
    ----------
    path : str
        The UIO device node (or a symlink to it; a plain file in tests, which
        sysfs does not describe: then ``span`` is mapped as asked).
    span : int
        Bytes wanted (mapped: the smaller of this and the map's size).
    need : int, optional
        Bytes the caller will use (registers up to this offset); a smaller map
        raises :class:`BusError` naming its size and the ``reg`` that fixes it.
    sysfs : str
        The UIO class directory; injectable for tests.

    Raises
    ------
    BusError
        The device cannot be opened or mapped, or its map is too small.
    """

    def __init__(self, path: str = "/dev/uio0", span: int = 0x1000, need=None,
                 sysfs: str = UIO_SYSFS):
        _check_span(span)
        if need is not None and (isinstance(need, bool) or not isinstance(need, int)
                                 or need < 0):
            raise ValueError(f"need must be a non-negative int, got {need!r}")
        self.uio_map = uio_map = read_uio_map(path, sysfs)
        offset = 0
        if uio_map is not None:
            size_file = os.path.join(str(sysfs), uio_map.device, "maps", "map0", "size")
            if uio_map.size is None:
                raise BusError(f"{path}: {size_file} missing: the UIO device has no memory "
                               f"map; give its device-tree node "
                               f"{_uio_reg(uio_map, need or span)}")
            usable = uio_map.size - uio_map.size % _WORD
            if need is not None and usable < need:
                raise BusError(f"{path}: UIO map 0 of '{uio_map.name}' is {uio_map.size:#x} "
                               f"bytes ({size_file}), the application needs {need:#x}: "
                               f"set {_uio_reg(uio_map, need)} in its device-tree node")
            span = min(span, usable)
            offset = uio_map.offset or 0
        try:
            super().__init__(path, offset, span)
        except BusError as exc:
            if uio_map is None or uio_map.size >= mmap.PAGESIZE:
                raise
            # The kernel maps whole pages: a map smaller than a page cannot be mapped.
            raise BusError(f"{exc}; UIO map 0 is {uio_map.size:#x} bytes, less than a page: "
                           f"set {_uio_reg(uio_map, need or span)} in its device-tree "
                           f"node") from None


class SimBus:
    """A bus whose registers are in-process models (tests, ``--bus sim``).

    Parameters
    ----------
    peripheral : object with ``read32(offset)`` / ``write32(offset, value)``, optional
        Attached at offset 0 (e.g. :class:`sw_hps.simulated.SimulatedFifoPeripheral`).
    span : int
        Size of the window. Offsets inside the span but not decoded by any
        attached device read 0 and ignore writes.

    Further devices are attached with :meth:`attach` (e.g. a simulated UART at
    0x100). Each device declares its decoded size in a ``span`` attribute
    (16 bytes if it has none) and receives offsets relative to its own base.
    """

    def __init__(self, peripheral=None, span: int = 0x1000):
        self.span = _check_span(span)
        self._devices: list[tuple[int, int, object]] = []
        self.closed = False
        if peripheral is not None:
            self.attach(0, peripheral)

    def attach(self, base: int, device) -> None:
        """Decode ``[base, base + device.span)`` to ``device``."""
        size = int(getattr(device, "span", 16))
        check_offset(base, self.span)
        if base + size > self.span:
            raise ValueError(f"device at {base:#x} (span {size:#x}) does not fit the bus "
                             f"span {self.span:#x}")
        for other_base, other_size, _ in self._devices:
            if base < other_base + other_size and other_base < base + size:
                raise ValueError(f"device at {base:#x} overlaps the one at {other_base:#x}")
        self._devices.append((base, size, device))

    def _find(self, offset: int):
        for base, size, device in self._devices:
            if base <= offset < base + size:
                return device, offset - base
        return None, 0

    def read32(self, offset: int) -> int:
        check_offset(offset, self.span)
        if self.closed:
            raise BusError("simulated bus is closed")
        device, local = self._find(offset)
        return 0 if device is None else int(device.read32(local)) & 0xFFFFFFFF

    def write32(self, offset: int, value: int) -> None:
        check_offset(offset, self.span)
        _check_value(value)
        if self.closed:
            raise BusError("simulated bus is closed")
        device, local = self._find(offset)
        if device is not None:
            device.write32(local, value)

    def close(self) -> None:
        self.closed = True
