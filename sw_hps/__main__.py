"""Command line of the board application: ``python -m sw_hps`` (thesis §8.5).

Runs on the board's ARM: Python 3 and numpy only, nothing else from this project.

::

    python -m sw_hps --model MODEL.json --bus devmem|uio|sim
                     --robot serial:/dev/ttyUSB0|uart|none
                     [--bridge-offset 0x0] [--uio /dev/uio0] [--uart-offset 0x100]
                     [--baudrate 115200] [--rn42-address ADDR] [--poll-ms 5]
                     [--min-symbols 5] [--max-points 300] [--gesture-timeout 2]
                     [--heartbeat 60] [--sim-trajectory FILE.csv] [--log-level info]
                     [--spotting thesis|continuous]

The FIFO slave sits at ``--bridge-offset`` inside the lightweight bridge
(``/dev/mem`` at ``0xFF200000``) or at offset 0 of the UIO map; the UART (``--robot
uart``) at ``--uart-offset`` from the FIFO's base, in the same window. ``--bus sim``
runs against :class:`~sw_hps.simulated.SimulatedFifoPeripheral` (and a simulated UART
for ``--robot uart``), playing ``--sim-trajectory`` (``frame,x,y,flag`` in pixels, as
``stereogest pipeline`` writes it), one video frame per poll, then prints one JSON
line ``{"gestures": [...]}`` and exits; without a trajectory it idles until stopped.

``--spotting thesis`` (the default) is the thesis' rest-gesture-rest protocol:
the FPGA's spotting flag marks each gesture, the HMMs name it. ``--spotting
continuous`` runs the FIFO in streaming mode and :mod:`sw_hps.streaming` finds
the gestures in the stream itself (one after another, no rest needed, idle
motion refused); it needs a model file with a ``spotting`` entry
(``stereogest train --continuous``); ``--min-symbols``, ``--max-points``,
``--gesture-timeout`` and ``--heartbeat`` are the thesis mode's.

``--gesture-timeout`` drops a gesture whose gesture bit stays at "gesture in progress"
with no pair for that many seconds (a stuck bit); ``--heartbeat`` logs an "alive" line
with the counters every that many seconds while idle (0 turns it off). The faults and
their recovery are described in :mod:`sw_hps.app`.

Exit status: 0 after SIGINT/SIGTERM or the end of a simulated trajectory, 2 for a bad
argument or model file (one line on stderr), 1 if the bus cannot be opened.
"""
from __future__ import annotations

import argparse
import json
import logging
import signal
import sys
import termios
import time

from .app import (DEFAULT_GESTURE_TIMEOUT, DEFAULT_HEARTBEAT, DEFAULT_MAX_POINTS,
                  DEFAULT_MIN_SYMBOLS, GestureApp, check_models)
from .bus import BusError, DevMemBus, SimBus, UioBus
from soc.hps_interface import FIFO_BASE, UART_BASE, UART_SPAN

from .fifo import LIGHTWEIGHT_BRIDGE_BASE, REGISTER_SPAN, FifoPeripheral
from .hmm import load_models
from .robot import NullLink, SerialLink, UartLink, configure_rn42, normalise_bt_address
from .simulated import (SimulatedFifoPeripheral, SimulatedUart, read_trajectory_csv,
                        run_stream, simulate_stream, simulate_trajectory)
from .streaming import StreamingApp, check_streaming_models

PROG = "python -m sw_hps"
#: Bytes mapped from the FIFO's base (FIFO and UART must fit).
WINDOW_SPAN = 0x1000
#: Size of the lightweight HPS-to-FPGA bridge.
BRIDGE_SIZE = 0x200000
LOG_LEVELS = ("debug", "info", "warning", "error")
#: Allowed --gesture-timeout (s): a few frames up to ten minutes.
GESTURE_TIMEOUT_RANGE = (0.1, 600.0)
#: Allowed non-zero --heartbeat (s): one second up to a day.
HEARTBEAT_RANGE = (1.0, 86400.0)

log = logging.getLogger("sw_hps")


class UsageError(Exception):
    """A bad argument; printed as one line, exit status 2."""


class _Parser(argparse.ArgumentParser):
    def error(self, message):
        raise UsageError(message)


def _int(text: str) -> int:
    try:
        return int(text, 0)
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected an integer (decimal or 0x hex), "
                                         f"got {text!r}") from None


def build_parser() -> argparse.ArgumentParser:
    parser = _Parser(prog=PROG, description="Gesture recogniser on the DE1-SoC's ARM: reads "
                     "the centroid FIFO, classifies with HMMs, commands the NXT robot.")
    parser.add_argument("--model", required=True, help="HMM model file (JSON)")
    parser.add_argument("--bus", required=True, choices=("devmem", "uio", "sim"),
                        help="register access: /dev/mem, a UIO device, or a simulation")
    parser.add_argument("--robot", required=True,
                        help="serial:DEVICE (Bluetooth serial adapter), uart (FPGA UART) "
                        "or none")
    parser.add_argument("--bridge-offset", type=_int, default=FIFO_BASE,
                        help=f"FIFO slave offset in the lightweight bridge (devmem; default "
                             f"{FIFO_BASE:#x})")
    parser.add_argument("--uio", default="/dev/uio0", help="UIO device (default /dev/uio0)")
    parser.add_argument("--uart-offset", type=_int, default=UART_BASE - FIFO_BASE,
                        help=f"UART slave offset from the FIFO's base (default "
                             f"{UART_BASE - FIFO_BASE:#x})")
    parser.add_argument("--baudrate", type=int, default=115200,
                        help="serial rate (default 115200)")
    parser.add_argument("--rn42-address",
                        help="configure an RN-42 on the serial port to connect to this "
                        "Bluetooth address first")
    parser.add_argument("--poll-ms", type=float, default=5.0,
                        help="sleep between idle polls in ms (default 5)")
    parser.add_argument("--min-symbols", type=int, default=DEFAULT_MIN_SYMBOLS,
                        help=f"reject shorter gestures (default {DEFAULT_MIN_SYMBOLS})")
    parser.add_argument("--max-points", type=int, default=DEFAULT_MAX_POINTS,
                        help=f"drop longer gestures (default {DEFAULT_MAX_POINTS})")
    parser.add_argument("--gesture-timeout", type=float, default=DEFAULT_GESTURE_TIMEOUT,
                        help="seconds with the gesture bit at 'gesture in progress' but no "
                        "pair before the gesture is dropped as stuck (default "
                        f"{DEFAULT_GESTURE_TIMEOUT:g})")
    parser.add_argument("--heartbeat", type=float, default=DEFAULT_HEARTBEAT,
                        help="seconds between 'alive' log lines while idle, 0 = off "
                        f"(default {DEFAULT_HEARTBEAT:g})")
    parser.add_argument("--sim-trajectory",
                        help="with --bus sim: trajectory.csv to play (frame,x,y,flag)")
    parser.add_argument("--spotting", default="thesis", choices=("thesis", "continuous"),
                        help="thesis: the FPGA's flag marks each gesture (default); "
                        "continuous: every frame streamed, gestures found one after another "
                        "(a model file from 'stereogest train --continuous')")
    parser.add_argument("--log-level", default="info", choices=LOG_LEVELS,
                        help="logging level (default info)")
    return parser


def parse_args(argv):
    """Parse and validate; ``UsageError`` with a one-line message on any problem."""
    args = build_parser().parse_args(argv)
    robot = args.robot
    if robot in ("uart", "none"):
        args.robot_kind, args.serial_device = robot, None
    elif robot.startswith("serial:") and len(robot) > len("serial:"):
        args.robot_kind, args.serial_device = "serial", robot[len("serial:"):]
    else:
        raise UsageError(f"argument --robot: expected serial:DEVICE, uart or none, got {robot!r}")
    if not (0 <= args.bridge_offset <= BRIDGE_SIZE - WINDOW_SPAN and args.bridge_offset % 4 == 0):
        raise UsageError(f"argument --bridge-offset: must be a multiple of 4 in "
                         f"[0, {BRIDGE_SIZE - WINDOW_SPAN:#x}], got {args.bridge_offset:#x}")
    if not (REGISTER_SPAN <= args.uart_offset <= WINDOW_SPAN - UART_SPAN
            and args.uart_offset % 4 == 0):
        raise UsageError(f"argument --uart-offset: must be a multiple of 4 in "
                         f"[{REGISTER_SPAN:#x}, {WINDOW_SPAN - UART_SPAN:#x}] (after the FIFO "
                         f"registers), got {args.uart_offset:#x}")
    if not 0 < args.poll_ms <= 1000:
        raise UsageError(f"argument --poll-ms: must be in (0, 1000], got {args.poll_ms}")
    if args.min_symbols < 1:
        raise UsageError(f"argument --min-symbols: must be >= 1, got {args.min_symbols}")
    if args.max_points < 2:
        raise UsageError(f"argument --max-points: must be >= 2, got {args.max_points}")
    low, high = GESTURE_TIMEOUT_RANGE
    if not low <= args.gesture_timeout <= high:  # also refuses nan
        raise UsageError(f"argument --gesture-timeout: must be in [{low:g}, {high:g}] "
                         f"seconds, got {args.gesture_timeout:g}")
    low, high = HEARTBEAT_RANGE
    if not (args.heartbeat == 0 or low <= args.heartbeat <= high):
        raise UsageError(f"argument --heartbeat: must be 0 (off) or in [{low:g}, {high:g}] "
                         f"seconds, got {args.heartbeat:g}")
    if args.sim_trajectory is not None and args.bus != "sim":
        raise UsageError("argument --sim-trajectory: only with --bus sim")
    if args.rn42_address is not None:
        if args.robot_kind != "serial":
            raise UsageError("argument --rn42-address: only with --robot serial:DEVICE")
        try:
            args.rn42_address = normalise_bt_address(args.rn42_address)
        except ValueError as exc:
            raise UsageError(f"argument --rn42-address: {exc}") from None
    if getattr(termios, f"B{args.baudrate}", None) is None or args.baudrate <= 0:
        raise UsageError(f"argument --baudrate: not a standard serial rate: {args.baudrate}")
    return args


def _make_link(args, bus):
    if args.robot_kind == "none":
        return NullLink()
    if args.robot_kind == "uart":
        return UartLink(bus, args.uart_offset)
    link = SerialLink(args.serial_device, args.baudrate)
    if args.rn42_address is not None and not configure_rn42(link, args.rn42_address):
        log.warning("RN-42 set-up failed; sending anyway (the module may already be connected)")
    return link


def _run_streaming(args, models, bus, link, started) -> int:
    """--spotting continuous: the streaming loop on the bus (a simulated FIFO
    playing --sim-trajectory with --bus sim)."""
    if args.bus == "sim" and args.sim_trajectory is not None:
        x, y, _flag = read_trajectory_csv(args.sim_trajectory)
        app = simulate_stream(models, x, y, pixels=True, link=link, bus=bus,
                              sleep=time.sleep, poll_interval=args.poll_ms / 1000.0)
        started(app)
        run_stream(app)
        print(json.dumps({"gestures": [r.to_dict() for r in app.results]}))
        app.shutdown()
        return 0
    if args.bus == "sim":
        bus.attach(0, SimulatedFifoPeripheral(reads_per_frame=1))
    app = StreamingApp(models, FifoPeripheral(bus), link, poll_interval=args.poll_ms / 1000.0)
    started(app)
    log.info("running (continuous spotting): bus %s, robot %s, %d classes %s", args.bus,
             args.robot, len(models.class_names), list(models.class_names))
    app.run()
    app.shutdown()
    return 0


def main(argv=None) -> int:
    """Entry point; returns the exit status (never raises)."""
    try:
        args = parse_args(sys.argv[1:] if argv is None else argv)
        models = check_models(load_models(args.model))
        if args.spotting == "continuous":
            try:
                check_streaming_models(models)
            except ValueError as exc:
                raise UsageError(f"argument --spotting: {exc}") from None
        trajectory = read_trajectory_csv(args.sim_trajectory) \
            if args.sim_trajectory is not None else None
    except (UsageError, ValueError) as exc:
        print(f"{PROG}: error: {exc}", file=sys.stderr)
        return 2
    except SystemExit as exc:  # --help
        return exc.code if isinstance(exc.code, int) else 0
    logging.basicConfig(level=args.log_level.upper(), stream=sys.stderr,
                        format="%(asctime)s %(levelname)s %(name)s: %(message)s")

    try:
        if args.bus == "devmem":
            bus = DevMemBus(LIGHTWEIGHT_BRIDGE_BASE, args.bridge_offset, WINDOW_SPAN)
        elif args.bus == "uio":
            bus = UioBus(args.uio, WINDOW_SPAN)
        else:
            bus = SimBus(span=WINDOW_SPAN)
    except BusError as exc:
        print(f"{PROG}: error: {exc}", file=sys.stderr)
        return 1

    link = None
    app = None
    previous = {}

    app_box = [None]      # the streaming loop, once it runs

    def stop(signum, frame):
        log.info("signal %d: stopping", signum)
        for running in (app, app_box[0]):
            if running is not None:
                running.request_stop()

    for signum in (signal.SIGINT, signal.SIGTERM):
        previous[signum] = signal.signal(signum, stop)
    try:
        if args.bus == "sim" and args.robot_kind == "uart":
            bus.attach(args.uart_offset, SimulatedUart())
        link = _make_link(args, bus)
        options = dict(min_symbols=args.min_symbols, max_points=args.max_points,
                       poll_interval=args.poll_ms / 1000.0,
                       gesture_timeout=args.gesture_timeout, heartbeat=args.heartbeat)
        if args.spotting == "continuous":
            return _run_streaming(args, models, bus, link,
                                  lambda running: app_box.__setitem__(0, running))
        if args.bus == "sim" and trajectory is not None:
            x, y, flag = trajectory
            simulation = simulate_trajectory(models, x, y, flag, link=link, bus=bus,
                                             sleep=time.sleep, **options)
            app = simulation.app
            simulation.run()
            print(json.dumps({"gestures": [r.to_dict() for r in simulation.results]}))
            app.shutdown()
            return 0
        if args.bus == "sim":
            bus.attach(0, SimulatedFifoPeripheral(reads_per_frame=1))
        app = GestureApp(models, FifoPeripheral(bus), link, **options)
        log.info("running: bus %s, robot %s, %d classes %s", args.bus, args.robot,
                 len(models.class_names), list(models.class_names))
        app.run()
        app.shutdown()
        return 0
    except Exception as exc:  # last resort: one line, no traceback
        log.error("fatal: %s: %s", type(exc).__name__, exc)
        log.debug("traceback", exc_info=True)
        return 1
    finally:
        if link is not None and app is None and app_box[0] is None:
            link.close()
        bus.close()
        for signum, handler in previous.items():
            signal.signal(signum, handler)


if __name__ == "__main__":
    sys.exit(main())
