"""``python -m sw_hps --check``: is there a stereogest core the application can
use, and if not, what to fix. Also the start-up preflight of a normal run.

Runs on the board's ARM: Python 3 and numpy only (numpy just for its version).

The check prints ``name: value`` lines (Python and numpy versions; for
``--bus devmem`` the FPGA manager's mode and MSEL setting and the lightweight
bridge's reset bit, :mod:`sw_hps.bridge`; for ``--bus uio`` the UIO device's
name and map from sysfs; then the core's ID, Version, Control and FIFO
lengths), one ``problem: ...; fix: ...`` line per problem found, and a last
``verdict:`` line. Exit status 0 when a stereogest core answers with
:data:`~soc.hps_interface.CORE_MAGIC` and the register-map revision this
application was written for, 1 otherwise.

The core's registers are read only when that is safe: with ``--bus devmem``
only when the FPGA is in user mode and the bridge out of reset (a read through
a bridge in reset stops the ARM with a bus error); with ``--bus uio`` likewise
when ``/dev/mem`` can be read (root), otherwise the UIO map is trusted. Only
registers without side effects are read (ID, Version, Control, Longitud_X/Y;
never Dato_X/Dato_Y, which pop the FIFOs), so the check can run beside a running
application. On the mapped buses they are read in a forked child: a bus error
(nothing decodes the address) ends the child, and the check reports it in one
line.
"""
from __future__ import annotations

import os
import platform
import signal
import struct
from typing import Optional

from soc.hps_interface import (CORE_MAGIC, CORE_REVISION, CTRL_FIFO_DATA, CTRL_FIFO_FULL,
                               CTRL_GO, CTRL_NO_GESTURE, CTRL_STREAM, LIGHTWEIGHT_BRIDGE_BASE,
                               REGISTER_SPAN, UART_SPAN)

from .bridge import read_bridge_state
from .bus import UIO_SYSFS, BusError, DevMemBus, SimBus, UioBus, read_uio_map
from .fifo import CoreIdentity, FifoPeripheral, FifoStatus

__all__ = ["DEV_MEM", "run_check", "preflight_bridge", "identity_problem", "magic_problem",
           "needed_span"]

#: The physical-memory device (root only).
DEV_MEM = "/dev/mem"

FIX_ROOT = "run it as root (sudo python3 -m sw_hps ...)"
FIX_NO_DEVMEM = "this kernel has no /dev/mem: use --bus uio (BRINGUP.md, 'The uio device')"
FIX_UIO = ("load uio_pdrv_genirq with of_id=generic-uio and give the core a generic-uio "
           "device-tree node (BRINGUP.md, 'The uio device'), or use --bus devmem as root")
FIX_REBUILD = ("build the bitstream and the board bundle from the same release "
               "(stereogest generate + quartus_build.sh, make hps-bundle) and load both")


def magic_problem(magic: int, where: str) -> str:
    """One line on an ID register that does not read :data:`CORE_MAGIC`: what
    the word suggests and the fix."""
    if magic == 0xFFFFFFFF:
        return (f"ID reads all ones at {where}: nothing decodes that address (bridge "
                f"disabled, no FPGA image, or a wrong --bridge-offset); fix: load "
                f"stereogest.rbf, enable the lightweight bridge (BRINGUP.md) and keep the "
                f"default --bridge-offset")
    if magic == 0:
        return (f"ID reads 0 at {where}: the core is held in reset, the FPGA holds a "
                f"bitstream without an ID register (older than register-map revision "
                f"{CORE_REVISION}) or another design; fix: release KEY[0] / reload "
                f"stereogest.rbf built from this release")
    return (f"no stereogest core at {where}: ID reads {magic:#010x}, expected "
            f"{CORE_MAGIC:#010x} ('{CORE_MAGIC.to_bytes(4, 'big').decode('ascii')}'); "
            f"fix: load stereogest.rbf built from this "
            f"release, or correct --bridge-offset")


def identity_problem(identity, where: str) -> Optional[str]:
    """None when ``identity`` (a :class:`~sw_hps.fifo.CoreIdentity`) is a core
    this application drives; else one ``problem; fix`` line."""
    if not identity.present:
        return magic_problem(identity.magic, where)
    if not identity.supported:
        return (f"stereogest core at {where} has register-map revision "
                f"{identity.revision}, this application needs revision {CORE_REVISION}; "
                f"fix: {FIX_REBUILD}")
    return None


def preflight_bridge(path: str = DEV_MEM, open_window=None) -> Optional[str]:
    """Before the first access to the lightweight bridge: None when it can be
    used, else one line naming the problem and its fix (the FPGA's first)."""
    try:
        state = read_bridge_state(path, open_window)
    except BusError as exc:
        return f"cannot read the HPS's reset and FPGA managers: {exc}"
    problems = state.problems()
    return f"lightweight bridge not usable: {problems[0]}" if problems else None


def _control_text(control: int) -> str:
    bits = (("GO", CTRL_GO), ("FIFO data", CTRL_FIFO_DATA), ("no gesture", CTRL_NO_GESTURE),
            ("FIFO-FULL", CTRL_FIFO_FULL), ("STREAM", CTRL_STREAM))
    return f"{control:#010x} (" + ", ".join(f"{name} {int(bool(control & mask))}"
                                            for name, mask in bits) + ")"


class _Report:
    """The lines of one check: values, problems (each with its fix), verdict."""

    def __init__(self, out):
        self.out = out
        self.problems = []

    def value(self, name: str, text) -> None:
        print(f"{name}: {text}", file=self.out)

    def problem(self, text: str) -> None:
        self.problems.append(text)
        print(f"problem: {text}", file=self.out)


def _open_fix(exc, kind: str) -> str:
    """The fix for a ``kind`` ("devmem" or "uio") device that cannot be opened or
    mapped, from the BusError's message."""
    text = str(exc)
    if "permission denied" in text:
        return FIX_ROOT if kind == "devmem" else \
            "run it as root or give your user the device (BRINGUP.md, the udev rule)"
    if "no such device" in text:
        return FIX_NO_DEVMEM if kind == "devmem" else FIX_UIO
    return "see BRINGUP.md ('Check it')"


def _numpy_version() -> str:
    try:
        import numpy
    except ImportError:
        return "not installed"
    return numpy.__version__


def needed_span(robot_kind, uart_offset: int) -> int:
    """Bytes of the bus window the application uses from the FIFO's base: its
    registers, and the UART's with ``--robot uart``."""
    if robot_kind == "uart":
        return max(REGISTER_SPAN, uart_offset + UART_SPAN)
    return REGISTER_SPAN


def _bridge(report: _Report, path: str, open_window, required: bool) -> bool:
    """Report the FPGA manager and the bridge; whether the bridge may be read
    (``required``: an unreadable /dev/mem is a problem, else a note)."""
    try:
        state = read_bridge_state(path, open_window)
    except BusError as exc:
        if required:
            report.problem(f"cannot read the HPS's reset and FPGA managers: {exc}; "
                           f"fix: {_open_fix(exc, 'devmem')}")
            return False
        report.value("HPS registers", f"not read ({exc}); the bridge's state is unknown")
        return True
    report.value("FPGA manager", f"{state.fpga_mode_name}, {state.describe_msel()} "
                                 f"(stat {state.fpga_stat:#x})")
    report.value("lightweight bridge", ("held in reset" if state.lw_bridge_in_reset
                                        else "out of reset")
                 + f" (brgmodrst {state.brgmodrst:#x})")
    for line in state.problems():
        report.problem(line)
    if not state.safe:
        report.value("core registers", "not read (a read through a bridge in reset or into "
                                       "an unconfigured FPGA stops the ARM with a bus error)")
    return state.safe


#: The register words the check reads: ID, Version, Control, Longitud_X, Longitud_Y.
_WORDS = struct.Struct("<5I")


def _read_words(bus) -> tuple:
    fifo = FifoPeripheral(bus)
    identity = fifo.identify()
    status = fifo.status()
    return (identity.magic, identity.version_word, status.control, status.length_x,
            status.length_y)


def _quiet_fault() -> None:
    """In the reading child: a bus error ends it silently (no faulthandler dump,
    no core file); the parent reports it."""
    import faulthandler
    faulthandler.disable()
    try:
        import resource
        resource.setrlimit(resource.RLIMIT_CORE, (0, 0))
    except (ImportError, OSError, ValueError):
        pass


def _read_isolated(bus, where: str):
    """The check's register words, read in a forked child: an access nothing
    decodes (a bridge disabled after the check of its reset bit, no slave at that
    offset) is a bus error, which kills the child, not the check. Returns
    (words, None) or (None, problem line)."""
    read_end, write_end = os.pipe()
    pid = os.fork()
    if pid == 0:   # the child: read, report, leave without running any cleanup
        status = 3
        try:
            os.close(read_end)
            _quiet_fault()
            os.write(write_end, _WORDS.pack(*_read_words(bus)))
            status = 0
        finally:
            os._exit(status)
    os.close(write_end)
    data = b""
    try:
        while True:
            chunk = os.read(read_end, _WORDS.size)
            if not chunk:
                break
            data += chunk
    finally:
        os.close(read_end)
    _, status = os.waitpid(pid, 0)
    if os.WIFSIGNALED(status):
        number = os.WTERMSIG(status)
        try:
            name = signal.Signals(number).name
        except ValueError:
            name = f"signal {number}"
        return None, (f"reading the core's registers at {where} ended in {name} (a bus "
                      f"error: nothing answers at that address); fix: load stereogest.rbf, "
                      f"enable the lightweight bridge (BRINGUP.md) and keep the default "
                      f"--bridge-offset")
    if os.WEXITSTATUS(status) != 0 or len(data) != _WORDS.size:
        return None, f"reading the core's registers at {where} failed; fix: see BRINGUP.md"
    return _WORDS.unpack(data), None


def _registers(report: _Report, bus, where: str, args, isolate: bool):
    if isolate and hasattr(os, "fork"):
        words, problem = _read_isolated(bus, where)
        if problem is not None:
            report.problem(problem)
            return None
    else:
        words = _read_words(bus)
    magic, version, control, length_x, length_y = words
    identity = CoreIdentity.decode(magic, version)
    report.value("ID", f"{identity.magic:#010x}")
    report.value("Version", f"{identity.version_word:#010x}")
    if identity.present:   # otherwise the problem line says what the ID suggests
        report.value("core", identity.describe())
    status = FifoStatus.decode(control, length_x, length_y)
    report.value("Control", _control_text(status.control))
    report.value("Longitud_X", status.length_x)
    report.value("Longitud_Y", status.length_y)
    problem = identity_problem(identity, where)
    if problem is not None:
        report.problem(problem)
    elif getattr(args, "spotting", "thesis") == "continuous" and not identity.streaming:
        report.problem(f"--spotting continuous needs the streaming mode, which this core "
                       f"lacks; fix: {FIX_REBUILD}, or use --spotting thesis")
    return identity


def _model(report: _Report, args) -> None:
    from .app import check_models
    from .hmm import load_models
    try:
        models = check_models(load_models(args.model))
    except (OSError, ValueError) as exc:
        report.problem(f"model file: {exc}; fix: copy a model file built by "
                       f"'stereogest train' (make hps-bundle ships one)")
        return
    report.value("model", f"{args.model}: {len(models.class_names)} classes "
                          f"{list(models.class_names)}")


def run_check(args, out, *, window_span: int, mem_path: str = DEV_MEM,
              sysfs: str = UIO_SYSFS, open_window=None) -> int:
    """Run the check for the parsed command line ``args``; print to ``out``.

    Parameters
    ----------
    args : argparse.Namespace
        ``bus``, ``bridge_offset``, ``uio``, ``uart_offset``, ``robot_kind``,
        ``model`` (None: not checked), ``spotting``.
    out : file
        Where the lines go.
    window_span : int
        Bytes the application maps from the FIFO's base (as in a normal run).
    mem_path, sysfs, open_window
        The physical-memory device, the UIO sysfs directory and the opener of
        the HPS register windows (:func:`sw_hps.bridge.read_bridge_state`);
        injectable for tests.

    Returns
    -------
    int
        0 if a supported stereogest core answers (and the model file, if given,
        is valid), 1 otherwise.
    """
    report = _Report(out)
    report.value("python", platform.python_version())
    report.value("numpy", _numpy_version())
    if getattr(args, "model", None) is not None:
        _model(report, args)
    identity = None
    bus = None
    try:
        if args.bus == "devmem":
            where = f"{LIGHTWEIGHT_BRIDGE_BASE + args.bridge_offset:#x}"
            report.value("bus", f"devmem: {mem_path} at {where}")
            if _bridge(report, mem_path, open_window, required=True):
                bus = DevMemBus(LIGHTWEIGHT_BRIDGE_BASE, args.bridge_offset, window_span,
                                path=mem_path)
        elif args.bus == "uio":
            where = args.uio
            uio_map = read_uio_map(args.uio, sysfs)
            if uio_map is None:
                report.value("bus", f"uio: {args.uio}")
                report.problem(f"{args.uio} is not a UIO device (no entry under {sysfs}); "
                               f"fix: {FIX_UIO}")
            else:
                def show(value):
                    return "?" if value is None else f"{value:#x}"
                report.value("bus", f"uio: {args.uio} = {uio_map.device} "
                                    f"'{uio_map.name}', map 0 at {show(uio_map.addr)}, "
                                    f"{show(uio_map.size)} bytes")
                if uio_map.addr is not None:
                    where = f"{uio_map.addr + (uio_map.offset or 0):#x} ({args.uio})"
                if _bridge(report, mem_path, open_window, required=False):
                    need = needed_span(getattr(args, "robot_kind", None), args.uart_offset)
                    bus = UioBus(args.uio, window_span, need=need, sysfs=sysfs)
        else:
            from .simulated import SimulatedFifoPeripheral
            where = "the simulated bus"
            report.value("bus", "sim: the simulated core (sw_hps.simulated)")
            bus = SimBus(SimulatedFifoPeripheral(), span=window_span)
        if bus is not None:
            identity = _registers(report, bus, where, args, isolate=args.bus != "sim")
    except BusError as exc:
        if "device-tree node" in str(exc):   # UioBus's message names the reg to set
            report.problem(str(exc))
        else:
            report.problem(f"{exc}; fix: {_open_fix(exc, args.bus)}")
    except Exception as exc:  # the check never dies with a traceback
        report.problem(f"unexpected {type(exc).__name__}: {exc}; fix: report it with the "
                       f"lines above")
    finally:
        if bus is not None:
            bus.close()
    if report.problems:
        count = len(report.problems)
        report.value("verdict", f"FAIL ({count} problem{'s' if count > 1 else ''} above)")
        return 1
    report.value("verdict", f"OK: stereogest core, register-map revision "
                            f"{identity.revision}, answers at {where}")
    return 0
