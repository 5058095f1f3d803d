"""Command line of the board application: ``python -m sw_hps`` (thesis §8.5).

Runs on the board's ARM: Python and numpy only (the floor is declared and checked
in :mod:`sw_hps`), nothing else from this project.

::

    python -m sw_hps --model MODEL.json --bus devmem|uio|sim
                     --robot serial:/dev/ttyUSB0|uart|none
                     [--bridge-offset 0x0] [--uio /dev/uio0] [--uart-offset 0x100]
                     [--baudrate 115200] [--rn42-address ADDR] [--robot-ack [SECONDS]]
                     [--poll-ms 5] [--min-symbols 5] [--max-points 300] [--gesture-timeout 2]
                     [--heartbeat 60] [--sim-trajectory FILE.csv] [--log-level info]
                     [--spotting thesis|continuous] [--fault-retries 0] [--user NAME]

The FIFO slave sits at ``--bridge-offset`` inside the lightweight bridge
(``/dev/mem`` at ``0xFF200000``) or at offset 0 of the UIO map; the UART (``--robot
uart``) at ``--uart-offset`` from the FIFO's base, in the same window. ``--bus sim``
runs against :class:`~sw_hps.simulated.SimulatedFifoPeripheral` (and a simulated UART
for ``--robot uart``, with a simulated RN-42 and NXT behind it), playing
``--sim-trajectory`` (``frame,x,y,flag`` in pixels, as ``stereogest pipeline``
writes it), one video frame per poll, then prints one JSON line ``{"gestures":
[...]}`` and exits; without a trajectory it idles until stopped.

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

The robot (``docs/robot-link.md``): ``--rn42-address`` sets up an RN-42 on the
serial port or the FPGA UART to connect to the brick, and again when the link
drops; ``--robot-ack`` sends each telegram with "reply required" and waits up to
SECONDS (0.3 by default) for the brick's answer. Each gesture's ``delivery`` (in
the log and the JSON) is ``acknowledged`` (the brick confirmed), ``unconfirmed``
(the bytes left, nothing can tell more: no ``--robot-ack``) or ``failed``; the
log says "sent" only for ``acknowledged``.

``python -m sw_hps --check [--bus devmem|uio|sim] [--bridge-offset ...] [--uio ...]``
(``--model``/``--robot`` optional; ``--bus`` defaults to devmem) reports the FPGA,
the bridge and the core and exits 0 if a stereogest core answers, 1 otherwise
(:mod:`sw_hps.check`). A normal run does the same checks first: with ``--bus devmem``
the FPGA manager and the bridge's reset bit before any access to the bridge, then
(devmem, uio) the ID and Version registers.

Faults on the bridge (:mod:`sw_hps.app`, Faults): reads of all ones, all zeros or
other patterns no working core gives are logged once, backed off (probing up to once
a second) and recovered from without a restart. A bus error the CPU raises as a
signal cannot be handled inside Python, so with ``--bus devmem`` or ``uio`` (and for
``--check`` on them) the application runs in a child process supervised by
:mod:`sw_hps.guard`: SIGINT/SIGTERM are passed on to it, its exit status is passed
through, and if it dies of SIGBUS (or SIGSEGV) the supervisor logs one error line
naming the device, the address window, the likely cause and ``--check``, then exits
with status 1 (the service manager restarts it), or with ``--fault-retries N`` first
starts it again up to N times in a row after a growing wait (:mod:`sw_hps.guard`).
SIGHUP reloads: the model file (and ``--posture-model``) is loaded and checked
again and, if good, the application restarts with it; a bad one is refused in one line and the running
application keeps its model. ``--bus sim`` runs in one process without the supervisor (SIGHUP is not
handled there).

``--user NAME`` (:mod:`sw_hps.privileges`): once the bus is open and mapped, the
process runs as NAME with its groups, so that a service started as root for
``/dev/mem`` keeps root no longer than the mapping; it checks that NAME can read
the package and the model files (reloads read them again).

Exit status: 0 after SIGINT/SIGTERM or the end of a simulated trajectory, 2 for a bad
argument or model file (one line on stderr), 1 if the bus cannot be opened or the
start-up checks fail (one line naming the fix), or if the application died of a bus
error (SIGBUS/SIGSEGV; after ``--fault-retries``) or was killed by another signal
(one line each).
"""
from __future__ import annotations

from . import __version__, check_floor

check_floor()   # one line instead of an ImportError from the modules below that need numpy

import argparse
import json
import logging
import os
import signal
import sys
import termios
import time

from .app import (DEFAULT_GESTURE_TIMEOUT, DEFAULT_HEARTBEAT, DEFAULT_MAX_POINTS,
                  DEFAULT_MIN_SYMBOLS, GestureApp, check_models)
from .bus import BusError, DevMemBus, SimBus, UioBus
from .busfault import describe_bus
from .guard import MAX_FAULT_RETRIES, RETRY_INITIAL, RETRY_MAX, supervise
from .check import DEV_MEM, identity_problem, needed_span, preflight_bridge, run_check
from soc.hps_interface import CORE_REVISION, FIFO_BASE, GESTURE_NAMES, UART_BASE, UART_SPAN

from .fifo import LIGHTWEIGHT_BRIDGE_BASE, REGISTER_SPAN, FifoPeripheral
from .class_commands import unmapped
from .hmm import load_models
from .privileges import PrivilegeError, drop_privileges, look_up_user
from .robot import (ACK_TIMEOUT_RANGE, DEFAULT_ACK_TIMEOUT, RN42_STATUS_PREFIX, NullLink,
                    RobotChannel, SerialLink, UartLink, normalise_bt_address)
from .simulated import (SimulatedFifoPeripheral, SimulatedRn42, SimulatedUart,
                        read_trajectory_csv, run_stream, simulate_stream, simulate_trajectory)
from .streaming import StreamingApp, check_streaming_models

PROG = "python -m sw_hps"
#: Bytes mapped from the FIFO's base (FIFO and UART must fit).
WINDOW_SPAN = 0x1000
#: Size of the lightweight HPS-to-FPGA bridge.
BRIDGE_SIZE = 0x200000
LOG_LEVELS = ("debug", "info", "warning", "error")
#: Buses that map the bridge into the process: run under the guard (sw_hps.guard).
GUARDED_BUSES = ("devmem", "uio")
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
    parser.add_argument("--version", action="version",
                        version=f"%(prog)s {__version__} (register interface revision "
                                f"{CORE_REVISION})")
    parser.add_argument("--check", action="store_true",
                        help="check the FPGA, the lightweight bridge and the core, print what "
                        "is found and exit (0: a stereogest core answers); --model and "
                        "--robot are optional, --bus defaults to devmem")
    parser.add_argument("--model", help="HMM model file (JSON); required unless --check")
    parser.add_argument("--bus", choices=("devmem", "uio", "sim"),
                        help="register access: /dev/mem, a UIO device, or a simulation; "
                        "required unless --check")
    parser.add_argument("--robot",
                        help="serial:DEVICE (Bluetooth serial adapter), uart (FPGA UART) "
                        "or none; required unless --check")
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
                        help="set up an RN-42 on the robot link (serial or uart) to connect "
                        "to this Bluetooth address first, and again when the link drops")
    parser.add_argument("--robot-ack", type=float, nargs="?", const=DEFAULT_ACK_TIMEOUT,
                        metavar="SECONDS",
                        help="ask the NXT to confirm each telegram and wait up to SECONDS "
                        f"for its reply (default {DEFAULT_ACK_TIMEOUT:g}); without it "
                        "deliveries are unconfirmed")
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
    parser.add_argument("--posture-model",
                        help="posture classifier (JSON, 'stereogest train-posture') naming "
                        "each gesture's posture from the posture slave's records, in both "
                        "spotting modes (default: none)")
    parser.add_argument("--spotting", default="thesis", choices=("thesis", "continuous"),
                        help="thesis: the FPGA's flag marks each gesture (default); "
                        "continuous: every frame streamed, gestures found one after another "
                        "(a model file from 'stereogest train --continuous')")
    parser.add_argument("--fault-retries", type=int, default=0, metavar="N",
                        help="after the application dies of a bus error (SIGBUS), start it "
                        f"again up to N times in a row, waiting {RETRY_INITIAL:g} s doubling "
                        f"to {RETRY_MAX:g} s (devmem, uio; default 0: exit with status 1, "
                        f"for systemd's Restart=on-failure; at most {MAX_FAULT_RETRIES})")
    parser.add_argument("--user", metavar="NAME",
                        help="once the bus is open, run as this user (its groups too): what "
                        "needs root (mapping /dev/mem) is done by then; for a service started "
                        "as root (default: stay as started)")
    parser.add_argument("--log-level", default="info", choices=LOG_LEVELS,
                        help="logging level (default info)")
    return parser


def parse_args(argv):
    """Parse and validate; ``UsageError`` with a one-line message on any problem."""
    args = build_parser().parse_args(argv)
    if args.check:
        args.bus = args.bus or "devmem"
        args.robot = args.robot or "none"
    else:
        missing = [f"--{name}" for name in ("model", "bus", "robot")
                   if getattr(args, name) is None]
        if missing:
            raise UsageError(f"the following arguments are required: {', '.join(missing)} "
                             f"(only --check runs without them)")
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
    if not 0 <= args.fault_retries <= MAX_FAULT_RETRIES:
        raise UsageError(f"argument --fault-retries: must be in [0, {MAX_FAULT_RETRIES}], "
                         f"got {args.fault_retries}")
    if args.fault_retries and args.bus not in GUARDED_BUSES:
        raise UsageError("argument --fault-retries: only with --bus devmem or uio")
    if args.rn42_address is not None:
        if args.robot_kind == "none":
            raise UsageError("argument --rn42-address: only with --robot serial:DEVICE or uart")
        try:
            args.rn42_address = normalise_bt_address(args.rn42_address)
        except ValueError as exc:
            raise UsageError(f"argument --rn42-address: {exc}") from None
    if args.robot_ack is not None:
        low, high = ACK_TIMEOUT_RANGE
        if not low <= args.robot_ack <= high:  # also refuses nan
            raise UsageError(f"argument --robot-ack: must be in [{low:g}, {high:g}] seconds, "
                             f"got {args.robot_ack:g}")
    if getattr(termios, f"B{args.baudrate}", None) is None or args.baudrate <= 0:
        raise UsageError(f"argument --baudrate: not a standard serial rate: {args.baudrate}")
    if args.user is not None:
        if args.check:
            raise UsageError("argument --user: not with --check (it opens nothing to keep)")
        try:
            look_up_user(args.user)
        except PrivilegeError as exc:
            raise UsageError(str(exc)) from None
    return args


def _make_link(args, bus, *, clock=time.monotonic, sleep=time.sleep):
    """The robot link of --robot, in a channel that knows --robot-ack and
    --rn42-address (the RN-42 set up here unless the NXT answers already);
    ``clock`` and ``sleep`` for the UART and the channel (simulated time in
    the soak, benchmarks/soak_board.py)."""
    if args.robot_kind == "none":
        link = NullLink()
    elif args.robot_kind == "uart":
        link = UartLink(bus, args.uart_offset, clock=clock, sleep=sleep)
    else:
        link = SerialLink(args.serial_device, args.baudrate)
    channel = RobotChannel(link, ack_timeout=args.robot_ack, rn42_address=args.rn42_address,
                           clock=clock, sleep=sleep)
    if args.rn42_address is not None and not channel.setup():
        log.warning("RN-42 set-up failed; sending anyway (the module may already be connected)")
    if args.robot_kind != "none" and args.robot_ack is None:
        log.info("%s link: deliveries unconfirmed; --robot-ack asks the NXT to confirm",
                 "UART" if args.robot_kind == "uart" else "serial")
    return channel


def _run_streaming(args, models, bus, link, started) -> int:
    """--spotting continuous: the streaming loop on the bus (a simulated FIFO
    playing --sim-trajectory with --bus sim)."""
    models, posture_model = models
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
    app = StreamingApp(models, FifoPeripheral(bus), link, poll_interval=args.poll_ms / 1000.0,
                       posture=_posture_tracker(args, bus, posture_model))
    started(app)
    log.info("running (continuous spotting): bus %s, robot %s, %d classes %s", args.bus,
             args.robot, len(models.class_names), list(models.class_names))
    app.run()
    app.shutdown()
    return 0


def _posture_tracker(args, bus, posture_model):
    """The posture slave's tracker for ``posture_model`` (None without one); a
    simulated slave on ``--bus sim``."""
    if posture_model is None:
        return None
    from .posture import POSTURE_OFFSET, PostureReader, PostureTracker
    if args.bus == "sim":
        from .simulated import SimulatedPostureSlave
        bus.attach(POSTURE_OFFSET, SimulatedPostureSlave())
    return PostureTracker(PostureReader(bus), posture_model)


def _load_models(args):
    """The model file, checked for the chosen spotting, and the posture model
    or None (at start, and by the guard on SIGHUP): ``(models, posture)``;
    ``UsageError`` / ``ValueError`` with a one-line message."""
    models = check_models(load_models(args.model))
    missing = unmapped(models.commands, models.class_names)
    if missing:
        raise UsageError(f"argument --model: {args.model}: {', '.join(map(repr, missing))} "
                         f"map{'s' if len(missing) == 1 else ''} to no robot command (the "
                         f"robot's: {', '.join(GESTURE_NAMES)}); train it with --commands "
                         f"CLASS=COMMAND,...")
    if args.spotting == "continuous":
        try:
            check_streaming_models(models)
        except ValueError as exc:
            raise UsageError(f"argument --spotting: {exc}") from None
    posture = None
    if args.posture_model is not None:
        from .posture import read_posture_model
        posture = read_posture_model(args.posture_model)
    if models.postures is not None:
        if posture is None:
            raise UsageError(f"argument --posture-model: the model file {args.model} has a "
                             "postures entry (command and stop postures): give the posture "
                             "model it names")
        from .posture_commands import check_posture_classes
        check_posture_classes(models.postures, posture.class_names,
                              where=f"{args.model}: postures")
    return models, posture


def main(argv=None, *, guard: bool = False) -> int:
    """Entry point; returns the exit status (never raises).

    Parameters
    ----------
    argv : list of str, optional
        The arguments (``sys.argv[1:]`` if None).
    guard : bool
        Run the application in a supervised child process for the mapped buses
        (:mod:`sw_hps.guard`), as ``python -m sw_hps`` does; callers that keep
        the application in their own process (tests) leave it off.
    """
    try:
        args = parse_args(sys.argv[1:] if argv is None else argv)
        if args.check:
            def check(_reloaded=None):
                return run_check(args, sys.stdout, window_span=WINDOW_SPAN, mem_path=DEV_MEM)
            if guard and args.bus in GUARDED_BUSES:   # its reads of the bridge may fault too
                where = (f"--bus devmem, {DEV_MEM} at "
                         f"{LIGHTWEIGHT_BRIDGE_BASE + args.bridge_offset:#010x}"
                         if args.bus == "devmem" else f"--bus uio, {args.uio}")
                return supervise(check, where=where)
            return check()
        models = _load_models(args)       # (HMMs, posture model or None)
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
            # the HPS's own registers first: a bridge in reset or an unconfigured FPGA
            # would stop the ARM with a bus error at the first access
            problem = preflight_bridge(DEV_MEM)
            if problem is not None:
                print(f"{PROG}: error: {problem}", file=sys.stderr)
                return 1
            bus = DevMemBus(LIGHTWEIGHT_BRIDGE_BASE, args.bridge_offset, WINDOW_SPAN,
                            path=DEV_MEM)
        elif args.bus == "uio":
            bus = UioBus(args.uio, WINDOW_SPAN,
                         need=needed_span(args.robot_kind, args.uart_offset))
        else:
            bus = SimBus(span=WINDOW_SPAN)
    except BusError as exc:
        print(f"{PROG}: error: {exc}", file=sys.stderr)
        return 1
    if args.user is not None:
        # the mapping is made; the rest (reloads, the robot's tty) needs no root
        readable = [os.path.dirname(os.path.abspath(__file__)), args.model]
        readable += [args.posture_model] if args.posture_model is not None else []
        try:
            if drop_privileges(args.user, readable=readable):
                log.info("running as user %s", args.user)
        except PrivilegeError as exc:
            bus.close()
            print(f"{PROG}: error: {exc}", file=sys.stderr)
            return 1
    if guard and args.bus in GUARDED_BUSES:
        # Every access to the bridge happens in the child: a bus error (SIGBUS) there
        # becomes one line from the parent instead of a silent death.
        try:
            return supervise(lambda reloaded: _serve(args, reloaded or models, trajectory, bus),
                             where=f"--bus {args.bus}, {describe_bus(bus)}",
                             reload=lambda: _load_models(args),
                             fault_retries=args.fault_retries)
        finally:
            bus.close()
    return _serve(args, models, trajectory, bus)


def _serve(args, models, trajectory, bus) -> int:
    """From the first access to the bus on: the ID check, the robot link and the
    loop, until stopped; returns the exit status (never raises)."""
    if args.bus != "sim":
        # the ID register tells a stereogest core from another design or a dead bridge
        where = (f"{LIGHTWEIGHT_BRIDGE_BASE + args.bridge_offset:#x}" if args.bus == "devmem"
                 else args.uio)
        try:
            identity = FifoPeripheral(bus).identify()
            problem = identity_problem(identity, where)
        except BusError as exc:
            problem = str(exc)
        if problem is not None:
            bus.close()
            print(f"{PROG}: error: {problem}", file=sys.stderr)
            return 1
        log.info("core at %s: %s", where, identity.describe())

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
            # the module and brick at the far end: connected already unless the
            # run names an address to set the module up with
            rn42 = SimulatedRn42(args.rn42_address, status_prefix=RN42_STATUS_PREFIX)
            bus.attach(args.uart_offset, SimulatedUart(responder=rn42))
        link = _make_link(args, bus)
        options = dict(min_symbols=args.min_symbols, max_points=args.max_points,
                       poll_interval=args.poll_ms / 1000.0,
                       gesture_timeout=args.gesture_timeout, heartbeat=args.heartbeat)
        if args.spotting == "continuous":
            return _run_streaming(args, models, bus, link,
                                  lambda running: app_box.__setitem__(0, running))
        models, posture_model = models
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
        app = GestureApp(models, FifoPeripheral(bus), link,
                         posture=_posture_tracker(args, bus, posture_model), **options)
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
    sys.exit(main(guard=True))
