"""Links to the LEGO NXT robot that carry the telegrams of :mod:`sw_hps.telegram`
(thesis §8.5).

Runs on the board's ARM: Python 3 and numpy only, and :mod:`soc.hps_interface`
(shipped with it; the serial port is driven with ``termios``/``os``, no pyserial).

Links
-----
* :class:`SerialLink`: a Bluetooth serial adapter (RN-42 or any SPP link) on a
  tty, raw 8N1; reconnects with capped exponential back-off; never raises on send.
  :func:`configure_rn42` puts an RN-42 in master mode and connects it to the brick.
* :class:`UartLink`: the FPGA's UART, a slave on the same bridge as the FIFO.
* :class:`NullLink`: no robot; logs and records the telegrams.

The FPGA UART's registers (TXDATA, STATUS, RXDATA) are declared in
:data:`soc.hps_interface.UART_REGISTERS`.
"""
from __future__ import annotations

import logging
import os
import re
import select
import termios
import time
from collections import deque
from typing import Callable

try:  # Python 3.8+; on 3.7 the interface is only documented
    from typing import Protocol
except ImportError:
    Protocol = object

from soc.hps_interface import UART_STATUS, UART_STATUS_TX_READY, UART_TXDATA

from .telegram import hex_bytes

__all__ = ["Link", "NullLink", "SerialLink", "UartLink", "configure_rn42",
           "normalise_bt_address"]

log = logging.getLogger(__name__)


class Link(Protocol):
    """Byte transport to the robot: ``send`` never raises, it returns success."""

    def send(self, data: bytes) -> bool: ...

    def close(self) -> None: ...


class NullLink:
    """No robot: logs each telegram and keeps the last ``keep`` in :attr:`sent`."""

    def __init__(self, keep: int = 1000):
        self.sent: deque[bytes] = deque(maxlen=keep)

    def send(self, data: bytes) -> bool:
        data = bytes(data)
        log.info("robot none: telegram %s", hex_bytes(data))
        self.sent.append(data)
        return True

    def close(self) -> None:
        pass


def _baud_constant(baudrate) -> int:
    value = getattr(termios, f"B{baudrate}", None) if isinstance(baudrate, int) \
        and not isinstance(baudrate, bool) else None
    if value is None:
        raise ValueError(f"baudrate must be a standard termios rate (e.g. 9600, 115200), "
                         f"got {baudrate!r}")
    return value


class SerialLink:
    """Serial port (Bluetooth SPP adapter such as the RN-42), raw 8N1.

    Parameters
    ----------
    device : str
        Path of the tty.
    baudrate : int
        A standard rate (``termios.B<rate>`` must exist).
    write_timeout : float
        Seconds a whole send may wait for the port to accept the bytes.
    initial_backoff, max_backoff : float
        Delay before the first reconnect attempt after a failure, doubled after
        each failed attempt up to ``max_backoff``.
    clock : callable
        Monotonic seconds for the back-off (injectable for tests); reads use
        real time.

    Notes
    -----
    The port is opened at construction; if that fails the link starts
    disconnected and the next :meth:`send` tries again (after the back-off).
    A send never raises: it logs and returns False.
    """

    def __init__(self, device: str, baudrate: int = 115200, *, write_timeout: float = 1.0,
                 initial_backoff: float = 0.5, max_backoff: float = 30.0,
                 clock: Callable[[], float] = time.monotonic):
        self.device = str(device)
        self.baudrate = baudrate
        self._speed = _baud_constant(baudrate)
        if not initial_backoff > 0 or not max_backoff >= initial_backoff:
            raise ValueError("initial_backoff must be > 0 and max_backoff >= initial_backoff, "
                             f"got {initial_backoff!r}, {max_backoff!r}")
        self.write_timeout = float(write_timeout)
        self.initial_backoff = float(initial_backoff)
        self.max_backoff = float(max_backoff)
        self._clock = clock
        self._fd: int | None = None
        #: Delay that the next failure will wait before retrying.
        self.backoff = self.initial_backoff
        #: Clock time before which no reconnect is tried.
        self.retry_at = float("-inf")
        #: Open attempts made so far (including the first one).
        self.open_attempts = 0
        self._open()

    @property
    def connected(self) -> bool:
        return self._fd is not None

    def _configure(self, fd: int) -> None:
        iflag, oflag, cflag, lflag, _, _, cc = termios.tcgetattr(fd)
        iflag &= ~(termios.IGNBRK | termios.BRKINT | termios.PARMRK | termios.ISTRIP
                   | termios.INLCR | termios.IGNCR | termios.ICRNL | termios.IXON
                   | termios.IXOFF | termios.IXANY)
        oflag &= ~termios.OPOST
        lflag &= ~(termios.ECHO | termios.ECHONL | termios.ICANON | termios.ISIG
                   | termios.IEXTEN)
        cflag &= ~(termios.CSIZE | termios.PARENB | termios.CSTOPB
                   | getattr(termios, "CRTSCTS", 0))
        cflag |= termios.CS8 | termios.CREAD | termios.CLOCAL
        cc = list(cc)
        cc[termios.VMIN] = 0
        cc[termios.VTIME] = 0
        termios.tcsetattr(fd, termios.TCSANOW,
                          [iflag, oflag, cflag, lflag, self._speed, self._speed, cc])

    def _open(self) -> bool:
        self.open_attempts += 1
        try:
            fd = os.open(self.device, os.O_RDWR | os.O_NOCTTY | os.O_NONBLOCK)
        except OSError as exc:
            self._failed(f"cannot open {self.device}: {exc.strerror}")
            return False
        try:
            self._configure(fd)
        except (OSError, termios.error) as exc:
            os.close(fd)
            self._failed(f"cannot configure {self.device} as a raw 8N1 port: {exc}")
            return False
        self._fd = fd
        self.backoff = self.initial_backoff
        self.retry_at = float("-inf")
        log.info("serial link open: %s at %d baud", self.device, self.baudrate)
        return True

    def _failed(self, reason: str) -> None:
        self._drop()
        delay = self.backoff
        self.retry_at = self._clock() + delay
        self.backoff = min(self.backoff * 2, self.max_backoff)
        log.warning("%s; retrying in %.1f s", reason, delay)

    def _drop(self) -> None:
        if self._fd is not None:
            try:
                os.close(self._fd)
            except OSError:
                pass
            self._fd = None

    def _ensure_open(self) -> bool:
        if self._fd is not None:
            return True
        if self._clock() < self.retry_at:
            log.debug("serial link %s down; next attempt in %.2f s", self.device,
                      self.retry_at - self._clock())
            return False
        return self._open()

    def send(self, data: bytes) -> bool:
        """Write all of ``data``; False (logged) if the port is down or the write fails."""
        data = bytes(data)
        if not self._ensure_open():
            log.warning("serial link %s down: %d bytes not sent", self.device, len(data))
            return False
        deadline = time.monotonic() + self.write_timeout
        view = memoryview(data)
        try:
            while view:
                remaining = deadline - time.monotonic()
                if remaining <= 0:
                    self._failed(f"write to {self.device} timed out")
                    return False
                _, writable, _ = select.select([], [self._fd], [], remaining)
                if not writable:
                    continue
                try:
                    written = os.write(self._fd, view)
                except BlockingIOError:
                    continue
                view = view[written:]
        except (OSError, ValueError) as exc:
            self._failed(f"write to {self.device} failed: {getattr(exc, 'strerror', exc)}")
            return False
        return True

    def read_available(self) -> bytes:
        """Bytes already received (possibly empty); empty if the port is down."""
        if self._fd is None:
            return b""
        chunks = []
        try:
            while True:
                chunk = os.read(self._fd, 4096)
                if not chunk:
                    break
                chunks.append(chunk)
        except BlockingIOError:
            pass
        except OSError as exc:
            self._failed(f"read from {self.device} failed: {exc.strerror}")
        return b"".join(chunks)

    def read_until(self, expected: bytes, timeout: float) -> bytes | None:
        """Read until ``expected`` has arrived; return everything read, or None if
        it did not arrive within ``timeout`` seconds (or the port is down)."""
        if not self._ensure_open():
            return None
        received = bytearray()
        deadline = time.monotonic() + timeout
        while expected not in received:
            remaining = deadline - time.monotonic()
            if remaining <= 0 or self._fd is None:
                log.debug("read_until %r: got %r", expected, bytes(received))
                return None
            try:
                readable, _, _ = select.select([self._fd], [], [], remaining)
            except (OSError, ValueError) as exc:
                self._failed(f"read from {self.device} failed: {exc}")
                return None
            if readable:
                received += self.read_available()
        return bytes(received)

    def close(self) -> None:
        self._drop()


_BT_PLAIN = re.compile(r"[0-9A-Fa-f]{12}")
_BT_COLONS = re.compile(r"([0-9A-Fa-f]{2}:){5}[0-9A-Fa-f]{2}")


def normalise_bt_address(address) -> str:
    """Bluetooth address as the 12 upper-case hex digits the RN-42 wants.

    Accepts ``"0016530A0B0C"`` or ``"00:16:53:0A:0B:0C"``; ``ValueError`` naming
    ``address`` otherwise.
    """
    if isinstance(address, str) and (_BT_PLAIN.fullmatch(address)
                                     or _BT_COLONS.fullmatch(address)):
        return address.replace(":", "").upper()
    raise ValueError(f"address must be 12 hex digits (e.g. 00165301A2B3 or "
                     f"00:16:53:01:A2:B3), got {address!r}")


def configure_rn42(link: SerialLink, address, timeout: float = 2.0) -> bool:
    """Make an RN-42 Bluetooth module connect to the NXT brick as master.

    Command mode (``$$$`` -> ``CMD``), master mode (``SM,1`` -> ``AOK``), then
    connect (``C,<address>``). The RN-42 only accepts ``$$$`` within its
    configuration window after power-up.

    Parameters
    ----------
    link : SerialLink
        The port the RN-42 is on.
    address : str
        The brick's Bluetooth address (12 hex digits, colons allowed).
    timeout : float
        Seconds to wait for each reply.

    Returns
    -------
    bool
        True once the connect command was sent; False (reason logged) if a
        reply did not come or the port is down.

    Raises
    ------
    ValueError
        Malformed ``address``.
    """
    address = normalise_bt_address(address)
    link.read_available()  # stale bytes would satisfy the first expectation
    for command, reply in ((b"$$$", b"CMD"), (b"SM,1\r", b"AOK")):
        if not link.send(command):
            log.warning("RN-42: could not send %r (link down)", command)
            return False
        if link.read_until(reply, timeout) is None:
            log.warning("RN-42: no %r reply to %r within %.1f s", reply.decode(),
                        command.decode().strip(), timeout)
            return False
    if not link.send(f"C,{address}\r".encode("ascii")):
        log.warning("RN-42: could not send the connect command (link down)")
        return False
    log.info("RN-42: master mode, connecting to %s", address)
    return True


class UartLink:
    """The FPGA's UART (register map in the module docstring) on a bus.

    Parameters
    ----------
    bus : Bus
        Register access.
    offset : int
        Byte offset of the UART slave in the bus window.
    spin_limit : int
        STATUS reads to wait for TX ready per byte before giving up.
    """

    def __init__(self, bus, offset: int = 0x100, spin_limit: int = 100_000):
        if isinstance(offset, bool) or not isinstance(offset, int) or offset < 0 or offset % 4:
            raise ValueError(f"offset must be a non-negative multiple of 4, got {offset!r}")
        if isinstance(spin_limit, bool) or not isinstance(spin_limit, int) or spin_limit < 1:
            raise ValueError(f"spin_limit must be an int >= 1, got {spin_limit!r}")
        self.bus = bus
        self.offset = offset
        self.spin_limit = spin_limit

    def send(self, data: bytes) -> bool:
        """Write each byte once TX ready; False (logged) on a stuck UART or bus error."""
        try:
            for position, byte in enumerate(bytes(data)):
                for _ in range(self.spin_limit):
                    if self.bus.read32(self.offset + UART_STATUS) & UART_STATUS_TX_READY:
                        break
                else:
                    log.warning("UART at %#x: TX not ready after %d polls; %d of %d bytes sent",
                                self.offset, self.spin_limit, position, len(data))
                    return False
                self.bus.write32(self.offset + UART_TXDATA, byte)
        except (OSError, ValueError) as exc:
            log.warning("UART at %#x: bus error: %s", self.offset, exc)
            return False
        return True

    def close(self) -> None:
        pass
