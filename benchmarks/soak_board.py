"""Soak of the board application: the unmodified loop of ``python -m sw_hps``
(:class:`sw_hps.app.GestureApp` for ``--spotting thesis``,
:class:`sw_hps.streaming.StreamingApp` for ``continuous``) on the simulated bus
for ``--frames`` video frames per mode, in simulated time (30 frames per
simulated second, the application's own polls and sleeps), with faults
injected at random all along.

What it is fed: a pool of rendered clips, each run once through the golden
model of the whole pipeline (kept in ``--cache``): the seven gestures and
distractors at 320x240 for the thesis mode (its protocol); at 640x480 for the
continuous mode, with the shipped continuous model's posture commands (the
gestures in the command posture, one in the stop posture, distractors in
their kinds' hands) and each frame's posture record in a simulated posture
slave. Clips are played in a seeded random order, each followed by a gap
without a hand; in a share of the gaps (``--fault-rate``) one fault, drawn at
random:

* ``bus_error``: every access raises :class:`sw_hps.bus.BusError`;
* ``ones`` / ``zeros`` / ``garbage``: every read gives 0xFFFFFFFF, 0 or a
  random word (a bridge with nothing behind it, a core in reset, noise);
* ``vanish``: the core is gone (reads 0, ID included) and comes back reset
  (GO and STREAM cleared, FIFOs empty): the FPGA reloaded;
* ``fifo_full``: the FIFO-FULL bit set (an overflow);
* ``link_drop``: the NXT's Bluetooth link drops (the RN-42 says so) and the
  brick is out of reach for a while (the application sets the module up again).

A fault waits until the application has taken the last clip's records (it may
still be sending a telegram or setting the RN-42 up), so that it comes between
two gestures rather than cutting one; the gap after it leaves the application
four seconds to recover before the next clip.

Every ``--reload-every`` frames the model file is reloaded as SIGHUP does it
(a real SIGHUP to this process; its handler calls the function the supervisor
of :mod:`sw_hps.guard` calls, :func:`sw_hps.__main__._load_models`):
alternately a good file (the application is started again with it, as the
supervisor restarts its child) and a corrupt one (refused in one line; the
application keeps running).

Checked per mode: every gesture named as the offline spotter names it on the
same records (the thesis loop on each clip alone,
:func:`stereogest.pipeline_outputs.board_results`; the continuous spotter,
:class:`sw_hps.streaming.StreamSpotter`, on every frame played;
``differences`` must be 0), resident memory after warm-up (a tenth of the
frames, two good reloads and a refused one) and at the end (``rss_growth_mb``
<= 2), open file descriptors (``fd_growth`` 0), log lines per hour of video (and the most lines one fault episode gave),
no crash, CPU microseconds per frame.

Run: ``python benchmarks/soak_board.py [--frames 1000000] [--modes thesis,continuous]``.
The last line of output is JSON.
"""
from __future__ import annotations

import argparse
import difflib
import json
import logging
import os
import random
import signal
import sys
import time
from collections import Counter, deque
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

FPS = 30
MODES = ("thesis", "continuous")
FAULT_KINDS = ("bus_error", "ones", "zeros", "garbage", "vanish", "fifo_full", "link_drop")
#: Where each mode runs: the thesis protocol's frames, the posture commands' smallest.
SIZES = {"thesis": (320, 240), "continuous": (640, 480)}
#: Frames without a hand after each clip, and at most one fault in them.
GAP_FRAMES = (45, 90)
FAULT_FRAMES = (5, 60)
#: Frames the application gets after a fault before the next clip (its probes
#: back off to 1 s, an RN-42 set-up waits its guard time).
RECOVERY_FRAMES = 120
#: Frames a fault waits while the application has not yet taken the last clip.
FAULT_DELAY = 5
NXT_ADDRESS = "00:16:53:0a:0b:0c"
SCENE_SEED = 4001
WARM_UP_SHARE = 0.1

#: Limits the run checks (the issue's targets).
MAX_RSS_GROWTH_MB = 2.0


def _rss_bytes() -> int:
    with open("/proc/self/statm") as handle:
        return int(handle.read().split()[1]) * os.sysconf("SC_PAGE_SIZE")


def _open_fds() -> int:
    return len(os.listdir("/proc/self/fd"))


# ---- the pool of rendered clips ----------------------------------------------------

def _pool_plan(mode: str, small: bool, models):
    """(name, render function) of each clip of a mode's pool."""
    from sim.difficulties import preset
    from sim.gesture_shapes import GESTURE_NAMES
    from sim.render import render_clip, render_sequence
    width, height = SIZES[mode]
    gestures = GESTURE_NAMES[:2] if small else GESTURE_NAMES
    postures = getattr(models, "postures", None)
    command = postures["command"][0] if mode == "continuous" and postures else None
    plan = []
    for k, gesture in enumerate(gestures):
        seed = SCENE_SEED + k
        plan.append((f"{gesture}-{seed}", lambda g=gesture, s=seed: render_clip(
            g, s, width, height, posture=command, difficulties=preset("easy", s))))
    if command is not None:            # one motion in the stop posture: a stop telegram
        stop = postures["stop"]
        seed = SCENE_SEED + 50
        plan.append((f"stop-{seed}", lambda s=seed: render_clip(
            "right", s, width, height, posture=stop, difficulties=preset("easy", s))))
    for k in range(1 if small else 2):
        seed = SCENE_SEED + 100 + k
        plan.append((f"distractors-{seed}", lambda s=seed: render_sequence(
            [], s, width, height, pause=(0, 15), distractors=True, frames=150 if small else 300,
            difficulties=preset("easy", s), command=command)))
    return plan


def load_pool(mode: str, small: bool, cache: Path, models, posture_model, quiet=False):
    """The mode's clips: per clip the golden model's records (``trajectory``:
    ``smoothed``, ``flag``, ``area``, ``posture`` words or None) and, for the
    thesis mode, the names the offline loop gives them (``expected``); for the
    continuous mode each frame's posture (``postures``), for the offline
    spotter that follows the whole stream."""
    from types import SimpleNamespace

    from sim.model.pipeline import PipelineParams, run_clip
    from stereogest.pipeline_outputs import board_results, frame_postures, recognised_gestures
    width, height = SIZES[mode]
    params = PipelineParams.for_frame(width)
    clips = []
    for name, render in _pool_plan(mode, small, models):
        path = cache / f"{width}x{height}" / f"{name}.npz"
        if path.exists():
            with np.load(path, allow_pickle=False) as z:
                data = {k: z[k] for k in z.files}
        else:
            started = time.process_time()
            clip = render()
            trajectory, _ = run_clip(clip.left, clip.right, params)
            data = {"smoothed": np.asarray(trajectory.smoothed, np.int64),
                    "flag": np.asarray(trajectory.flag, bool),
                    "area": np.asarray(trajectory.area, np.int64),
                    "posture": np.asarray(trajectory.posture, np.int64)
                    if trajectory.posture is not None else np.zeros((0, 0), np.int64)}
            path.parent.mkdir(parents=True, exist_ok=True)
            part = path.with_suffix(".part.npz")     # kept whole or not at all
            np.savez_compressed(part, **data)
            part.replace(path)
            if not quiet:
                print(f"  rendered {name} at {width}x{height}: {len(data['flag'])} frames, "
                      f"{time.process_time() - started:.1f} CPU s", flush=True)
        trajectory = SimpleNamespace(smoothed=data["smoothed"], flag=data["flag"],
                                     area=data["area"],
                                     posture=data["posture"] if data["posture"].size else None)
        entry = {"name": name, "trajectory": trajectory}
        if mode == "thesis":     # the thesis loop starts afresh at every flagged gesture
            entry["expected"] = [e["name"] for e in
                                 recognised_gestures(board_results(models, trajectory))]
        else:                    # the spotter runs over the whole stream (Board.reference)
            entry["postures"] = frame_postures(posture_model, trajectory) \
                if posture_model is not None else [None] * len(trajectory.flag)
        clips.append(entry)
    return clips


# ---- the simulated board with faults ------------------------------------------------

class Faults:
    """The fault in effect (shared by every slave on the bridge)."""

    def __init__(self, rng: random.Random):
        self.rng = rng
        self.kind = None

    def value(self, offset: int) -> int:
        from sw_hps.bus import BusError
        if self.kind == "bus_error":
            raise BusError(f"soak: injected bus error at offset {offset:#x}")
        if self.kind == "ones":
            return 0xFFFF_FFFF
        if self.kind in ("zeros", "vanish"):
            return 0
        return self.rng.getrandbits(32)          # garbage

    @property
    def on_reads(self) -> bool:
        return self.kind in ("bus_error", "ones", "zeros", "garbage", "vanish")


class FaultySlave:
    """A slave behind the bridge: its reads replaced while a read fault lasts,
    writes lost while the core is gone."""

    def __init__(self, inner, faults: Faults, before_access=None):
        self.inner, self.faults, self.before_access = inner, faults, before_access
        self.span = inner.span

    def read32(self, offset: int) -> int:
        if self.before_access is not None:
            self.before_access()
        if self.faults.on_reads:
            return self.faults.value(offset)
        return self.inner.read32(offset)

    def write32(self, offset: int, value: int) -> None:
        if self.before_access is not None:
            self.before_access()
        if self.faults.kind == "bus_error":
            self.faults.value(offset)
        if self.faults.on_reads:
            return
        self.inner.write32(offset, value)


def make_fifo(slave):
    """The FIFO slave's model playing queued frames, each with its posture
    record pushed to ``slave`` (None: no posture path)."""
    from sw_hps.simulated import SimulatedFifoPeripheral

    class SoakFifo(SimulatedFifoPeripheral):
        def __init__(self):
            super().__init__(reads_per_frame=None)
            self.records = deque()
            self.last_record = None

        def queue(self, x, y, flag, present, records):
            self.queue_trajectory(x, y, flag, present=present)
            if slave is not None:
                self.records.extend(records)

        def queue_idle(self, frames: int, record, front: bool = False):
            """``frames`` frames without a hand (posture ``record``), after what
            is queued or, with ``front``, before it; returns the centroid they
            hold (the last one before them)."""
            pending = self._pending
            near = pending[0] if front and pending else pending[-1] if pending else None
            x, y = (near or self._last or (0, 0))[:2]
            add = pending.extendleft if front else pending.extend
            add([(x, y, False, False)] * frames)
            if slave is not None:
                (self.records.extendleft if front else self.records.extend)([record] * frames)
            return x, y

        def step(self, frames: int = 1) -> int:
            played = 0
            for _ in range(frames):
                queued = bool(self._pending)
                played += super().step(1)
                if slave is not None:
                    if queued:
                        self.last_record = self.records.popleft()
                    if self.last_record is not None:
                        slave.push_record(self.last_record)
            return played

        def reset(self):
            """The core reloaded: GO and STREAM clear, FIFOs empty."""
            self.go = self.streaming = self.full = False
            self.fifo_x.clear()
            self.fifo_y.clear()

    return SoakFifo()


class Board:
    """The simulated bus, its slaves and simulated time: frames advance with
    the clock (30 per second) whenever the application touches the bridge."""

    def __init__(self, clips, rng, fault_rate, posture_words, reference=None,
                 fault_kinds=FAULT_KINDS):
        from sw_hps.bus import SimBus
        from sw_hps.posture import POSTURE_OFFSET
        from sw_hps.simulated import (SimulatedClock, SimulatedPostureSlave, SimulatedRn42,
                                      SimulatedUart)
        from soc.hps_interface import UART_BASE, FIFO_BASE
        self.clips, self.rng, self.fault_rate = clips, rng, fault_rate
        self.fault_kinds = tuple(fault_kinds)
        self.clock = SimulatedClock()
        self.faults = Faults(rng)
        self.posture_slave = SimulatedPostureSlave() if posture_words else None
        self.fifo = make_fifo(self.posture_slave)
        self.rn42 = SimulatedRn42(NXT_ADDRESS, status_prefix=b"", clock=self.clock)
        self.uart = SimulatedUart(responder=self.rn42)
        self.bus = SimBus(span=0x1000)
        self.bus.attach(0, FaultySlave(self.fifo, self.faults, self.advance))
        self.uart_offset = UART_BASE - FIFO_BASE
        self.bus.attach(self.uart_offset, FaultySlave(self.uart, self.faults, self.advance))
        if self.posture_slave is not None:
            self.bus.attach(POSTURE_OFFSET, FaultySlave(self.posture_slave, self.faults,
                                                        self.advance))
        self.no_hand_record = [0] * posture_words if posture_words else None
        self.played = 0                 # frames played
        self.expected: list[str] = []   # what the offline spotter names
        self.sources: list[tuple[str, int]] = []   # where each came from (clip, frame)
        # continuous: the offline spotter (StreamSpotter) on every frame played
        self.reference = reference
        self.reference_frames = deque()
        self.clips_played = 0
        self.fault_log: list[tuple[int, str, int]] = []   # (frame, kind, frames)
        self._events: list[tuple[int, str]] = []         # (frame, what) in the current gap
        self.fault_counts = Counter()
        self.on_event = None            # called with each event (the log counter's marks)
        self.feeding = True             # False: no new clip, idle frames only
        self.clip_log: list[tuple[int, str]] = []        # (first frame, clip)
        self.clip_end = 0               # the frame after the latest clip queued
        self.postponed = 0              # faults moved on: the last clip not yet taken

    def _queue_next(self) -> None:
        clip = self.rng.choice(self.clips)
        self.clip_log.append((self.played + self.fifo.frames_pending, clip["name"]))
        t = clip["trajectory"]
        records = list(map(list, t.posture)) if self.posture_slave is not None else None
        present = np.asarray(t.area) > 0
        self.clip_end = self.played + self.fifo.frames_pending + len(t.flag)
        self.fifo.queue(t.smoothed[:, 0], t.smoothed[:, 1], t.flag, present, records)
        if self.reference is None:
            self.expected += clip["expected"]
            end = self.played + self.fifo.frames_pending
            self.sources += [(clip["name"], end)] * len(clip["expected"])
        else:
            self.reference_frames.extend(zip(t.smoothed[:, 0].tolist(),
                                             t.smoothed[:, 1].tolist(), present.tolist(),
                                             clip["postures"]))
        self.clips_played += 1
        gap = self.rng.randint(*GAP_FRAMES)
        start = self.played + self.fifo.frames_pending
        if self.rng.random() < self.fault_rate:
            kind = self.rng.choice(self.fault_kinds)
            length = self.rng.randint(*FAULT_FRAMES)
            at = start + 5
            self._events += [(at, "start:" + kind + ":" + str(length)), (at + length, "end"),
                             (at + length + RECOVERY_FRAMES - 10, "settled")]
            gap = max(gap, 5 + length + RECOVERY_FRAMES)
        self._idle(gap)

    def _idle(self, frames: int, front: bool = False) -> None:
        """Frames without a hand after what is queued, or before it
        (``front``), for the FIFO, the posture slave and the offline spotter."""
        x, y = self.fifo.queue_idle(frames, self.no_hand_record, front)
        if self.reference is not None:
            idle = [(int(x), int(y), False, None)] * frames
            (self.reference_frames.extendleft if front else self.reference_frames.extend)(idle)

    def insert_idle(self, frames: int) -> None:
        """Frames without a hand before whatever is queued: the application's
        start (the RN-42 set-up takes seconds) must not cut a gesture."""
        self._idle(frames, front=True)

    def advance(self) -> None:
        """Play the frames the clock has reached, and the faults due by then."""
        due = int(self.clock.now * FPS)
        while self.played < due:
            if self.fifo.frames_pending == 0 and self.feeding:
                self._queue_next()
            while self._events and self._events[0][0] <= self.played:
                if self._events[0][1].startswith("start:") and self._unread_clip_records():
                    self._postpone(FAULT_DELAY)
                    break
                self._event(self._events.pop(0)[1])
            self.fifo.step(1)
            self.played += 1
            if self.reference is not None and self.reference_frames:
                named = [c.name for c in self.reference.take(*self.reference_frames.popleft())]
                self.expected += named
                self.sources += [("stream", self.played)] * len(named)

    def _unread_clip_records(self) -> bool:
        """The application has not yet taken every record of the last clip:
        a fault now would cut a gesture rather than come between two (the
        loop may still be busy with a telegram or an RN-42 set-up)."""
        gap_records = max(0, self.played - self.clip_end)
        return len(self.fifo.fifo_x) > gap_records or self.fifo.flag

    def _postpone(self, frames: int) -> None:
        """Move the gap's events (the fault's start, end and settling) on, and
        make the gap as much longer."""
        self._events = [(at + frames, what) for at, what in self._events]
        self.postponed += 1
        self._idle(frames)

    def _event(self, what: str) -> None:
        if self.on_event is not None:
            self.on_event(what)
        if what == "settled":
            return
        if what.startswith("start:"):
            _, kind, length = what.split(":")
            self.fault_counts[kind] += 1
            self.fault_log.append((self.played, kind, int(length)))
            if kind == "fifo_full":
                self.fifo.full = True
            elif kind == "link_drop":
                self.uart.receive_queue.extend(self.rn42.drop())
                self.rn42.reachable = False
                self.faults.kind = "link_drop"
            else:
                self.faults.kind = kind
        else:
            if self.faults.kind == "vanish":
                self.fifo.reset()
            self.rn42.reachable = True
            self.faults.kind = None

    @property
    def in_gap(self) -> bool:
        """Between clips, the last one a second behind and no fault under way
        or due: a reload may come (its restart gets idle frames before the
        rest of the gap, :meth:`insert_idle`)."""
        return (self.faults.kind is None and not self._events
                and self.played >= self.clip_end + FPS and self.fifo.frames_pending > 0)


# ---- one mode's soak ----------------------------------------------------------------

class LogCounter(logging.Handler):
    """Counts the application's log lines (at the service's level, INFO), by
    message template, and the lines of each fault episode."""

    def __init__(self):
        super().__init__(logging.INFO)
        self.lines = 0
        self.templates = Counter()
        self.levels = Counter()

    def emit(self, record):
        self.lines += 1
        self.levels[record.levelname] += 1
        self.templates[str(record.msg)[:70]] += 1


def soak(mode: str, frames: int, clips, models_path: Path, posture_path, *, seed: int,
         fault_rate: float, reload_every: int, work: Path, quiet: bool,
         fault_kinds=FAULT_KINDS) -> dict:
    from sw_hps import __main__ as board_main
    from sw_hps.fifo import FifoPeripheral
    from sw_hps.posture import POSTURE_WORD_COUNT, PostureReader, PostureTracker
    from sw_hps.app import GestureApp
    from sw_hps.streaming import StreamingApp, StreamSpotter

    good = work / f"{mode}-model.json"
    good.write_bytes(models_path.read_bytes())
    argv = ["--model", str(good), "--bus", "sim", "--robot", "uart", "--rn42-address",
            NXT_ADDRESS, "--robot-ack", "--spotting", mode]
    if posture_path is not None:
        argv += ["--posture-model", str(posture_path)]
    args = board_main.parse_args(argv)
    models = board_main._load_models(args)
    rng = random.Random(seed)
    reference = StreamSpotter(models[0], SIZES[mode][0]) if mode == "continuous" else None
    board = Board(clips, rng, fault_rate,
                  POSTURE_WORD_COUNT if models[1] is not None else 0, reference, fault_kinds)
    clock = board.clock

    def start(models):
        """What the supervisor's child does: the link, then the loop's object."""
        gestures, posture_model = models
        channel = board_main._make_link(args, board.bus, clock=clock, sleep=clock.sleep)
        posture = PostureTracker(PostureReader(board.bus), posture_model) \
            if posture_model is not None else None
        fifo = FifoPeripheral(board.bus)
        if mode == "continuous":
            return StreamingApp(gestures, fifo, channel, sleep=clock.sleep, clock=clock,
                                poll_interval=args.poll_ms / 1000.0, posture=posture)
        return GestureApp(gestures, fifo, channel, sleep=clock.sleep, clock=clock,
                          poll_interval=args.poll_ms / 1000.0, posture=posture)

    counter = LogCounter()
    episode = {"start": None, "lines": []}

    def mark(what):
        if what.startswith("start:"):
            episode["start"] = counter.lines
        elif what == "settled" and episode["start"] is not None:
            episode["lines"].append(counter.lines - episode["start"])
            episode["start"] = None
    board.on_event = mark
    logger = logging.getLogger("sw_hps")
    logger.addHandler(counter)
    logger.setLevel(logging.INFO)
    logger.propagate = False

    hup = {"pending": False}
    # Ctrl-C: the loops return from run() on it; the soak stops after that chunk
    interrupted = {"yes": False}

    def on_interrupt(signum, frame):
        interrupted["yes"] = True
        if running:
            running[0].request_stop()
    running = []
    previous_int = signal.signal(signal.SIGINT, on_interrupt)
    previous = signal.signal(signal.SIGHUP, lambda signum, frame: hup.__setitem__("pending", True))
    reloads = {"good": 0, "refused": 0, "accepted_corrupt": 0, "refused_good": 0}
    names: list[str] = []
    crashes = 0
    board.insert_idle(RECOVERY_FRAMES)
    app = start(models)
    running.append(app)
    next_reload = reload_every
    reload_corrupt = False
    chunk = 3000
    # Warm-up: a tenth of the frames, and two good reloads and a refused one if
    # the run has them (loading the 2.9 MB posture model twice brings the
    # allocator's arenas to their steady size, measured: +4 MB, then flat).
    warm_share = int(frames * WARM_UP_SHARE)
    reloads_planned = frames // reload_every

    def warmed_up():
        if board.played < warm_share:
            return False
        return reloads_planned < 4 or (reloads["good"] >= 2 and reloads["refused"] >= 1)
    rss_warm = fds_warm = warm_frame = None
    before_reload = []              # (frame, rss, fds) just before each reload
    fds_start = _open_fds()
    rss_start = _rss_bytes()
    started_cpu = time.process_time()
    try:
        while board.played < frames:
            target = min(frames, board.played + chunk)
            if board.played >= next_reload:     # on to the next gap between clips
                def until():
                    return board.in_gap or board.played >= frames
            else:
                def until():
                    return board.played >= target
            try:
                done = app.run(until=until)
            except Exception as exc:        # the loop must never raise: count it, go on
                crashes += 1
                logging.getLogger("soak").error("crash: %s: %s", type(exc).__name__, exc)
                app = running[0] = start(models)
                continue
            names += [r.class_name for r in done
                      if (mode == "continuous") or r.outcome == "recognised"]
            if interrupted["yes"]:
                raise KeyboardInterrupt
            board.rn42.messages.clear()
            board.uart.transmitted.clear()
            board.rn42.commands.clear()
            if rss_warm is None and warmed_up():
                rss_warm, fds_warm, warm_frame = _rss_bytes(), _open_fds(), board.played
            if board.played >= next_reload and board.in_gap:
                next_reload += reload_every
                before_reload.append((board.played, _rss_bytes(), _open_fds()))
                if reload_corrupt:
                    good_bytes = good.read_bytes()
                    good.write_bytes(good_bytes[:len(good_bytes) // 2])   # cut mid-file
                os.kill(os.getpid(), signal.SIGHUP)
                assert hup["pending"], "SIGHUP did not arrive"
                hup["pending"] = False
                try:
                    reloaded = board_main._load_models(args)
                except (board_main.UsageError, ValueError) as exc:
                    logging.getLogger("sw_hps.guard").error(
                        "SIGHUP: not reloaded, the running application keeps its model: %s", exc)
                    reloads["refused" if reload_corrupt else "refused_good"] += 1
                else:
                    reloads["accepted_corrupt" if reload_corrupt else "good"] += 1
                    app.shutdown()
                    models = reloaded
                    board.insert_idle(RECOVERY_FRAMES)
                    app = running[0] = start(models)   # a new child: its spotter starts afresh
                    if board.reference is not None:
                        board.reference = StreamSpotter(models[0], SIZES[mode][0])
                if reload_corrupt:
                    good.write_bytes(models_path.read_bytes())
                reload_corrupt = not reload_corrupt
            if not quiet and board.played % 100_000 < chunk:
                print(f"  {mode}: {board.played:,} frames, {len(names)} named, "
                      f"{sum(board.fault_counts.values())} faults, {counter.lines} log lines, "
                      f"rss {_rss_bytes() / 2**20:.1f} MB", flush=True)
        # the last clip played out, then idle frames: the application names what is left
        board.feeding = False
        end = board.played + board.fifo.frames_pending + RECOVERY_FRAMES
        done = app.run(until=lambda: board.played >= end)
        names += [r.class_name for r in done
                  if (mode == "continuous") or r.outcome == "recognised"]
        app.shutdown()
    finally:
        signal.signal(signal.SIGHUP, previous)
        signal.signal(signal.SIGINT, previous_int)
        logger.removeHandler(counter)
        logger.propagate = True
    cpu = time.process_time() - started_cpu
    rss_final, fds_final = _rss_bytes(), _open_fds()
    rss_end, fds_end = rss_final, fds_final
    if rss_warm is None:
        rss_warm, fds_warm, warm_frame = rss_start, fds_start, 0
    # Memory swings by several MB from one reload to the next (the 2.9 MB
    # posture model parsed, the old models freed): the highest of the samples
    # taken just before the reloads in the second half after warm-up, against
    # the highest in the first half, when there are four or more.
    phase = [sample for sample in before_reload if sample[0] >= warm_frame]
    if len(phase) >= 4:
        half = len(phase) // 2
        rss_warm = max(r for _, r, _ in phase[:half])
        rss_end = max(r for _, r, _ in phase[half:])
        measured = (f"highest before the reloads at frames {phase[0][0]}-{phase[half - 1][0]} "
                    f"and at {phase[half][0]}-{phase[-1][0]}")
    else:
        measured = f"at frame {warm_frame} and at the end"
    expected = board.expected
    matcher = difflib.SequenceMatcher(a=expected, b=names, autojunk=False)
    differences = sum(max(i2 - i1, j2 - j1) for op, i1, i2, j1, j2 in matcher.get_opcodes()
                      if op != "equal")
    def context(i):
        """Where expected entry i came from: its clip, the two clips before, and
        the faults in the 600 frames before it."""
        source, frame = board.sources[min(i, len(board.sources) - 1)]
        clips = [c for c in board.clip_log if c[0] <= frame][-3:]
        faults = [f for f in board.fault_log if frame - 600 <= f[0] <= frame]
        return {"source": source, "frame": frame, "clips": clips, "faults": faults}

    mismatches = [{"op": op, "expected": expected[i1:i2], "named": names[j1:j2],
                   **(context(i1) if board.sources else {})}
                  for op, i1, i2, j1, j2 in matcher.get_opcodes() if op != "equal"][:10]
    hours = board.played / FPS / 3600
    return {
        "frames": board.played, "hours_of_video": round(hours, 2),
        "clips": board.clips_played, "gestures_expected": len(expected),
        "gestures_named": len(names), "differences": differences, "mismatches": mismatches,
        "crashes": crashes,
        "faults": dict(board.fault_counts), "faults_postponed": board.postponed,
        "reloads": reloads,
        "rss_start_mb": round(rss_start / 2**20, 2), "warm_up_frames": warm_frame,
        "rss_warm_mb": round(rss_warm / 2**20, 2),
        "rss_end_mb": round(rss_end / 2**20, 2), "rss_final_mb": round(rss_final / 2**20, 2),
        "rss_peak_mb": round(max([r for _, r, _ in before_reload] + [rss_final, rss_warm])
                             / 2**20, 2),
        "rss_growth_mb": round((rss_end - rss_warm) / 2**20, 2), "rss_measured": measured,
        "rss_before_reloads_mb": [round(r / 2**20, 2) for _, r, _ in before_reload],
        "fd_start": fds_start, "fd_growth": fds_final - fds_warm,
        "log_lines": counter.lines, "log_lines_per_hour": round(counter.lines / hours, 1),
        "log_levels": dict(counter.levels),
        "most_log_lines_per_fault": max(episode["lines"], default=0),
        "mean_log_lines_per_fault": round(float(np.mean(episode["lines"])), 2)
        if episode["lines"] else 0.0,
        "top_log_lines": counter.templates.most_common(8),
        "cpu_s": round(cpu, 1), "cpu_us_per_frame": round(1e6 * cpu / board.played, 1),
    }


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--frames", type=int, default=1_000_000,
                    help="video frames per mode (default 1,000,000: about 9 h at 30 fps)")
    ap.add_argument("--modes", default=",".join(MODES),
                    help="thesis, continuous or both, comma-separated (default both)")
    ap.add_argument("--fault-rate", type=float, default=0.5,
                    help="share of the gaps between clips with a fault (default 0.5)")
    ap.add_argument("--reload-every", type=int, default=100_000, metavar="FRAMES",
                    help="frames between two SIGHUP reloads (default 100,000)")
    ap.add_argument("--faults", default=",".join(FAULT_KINDS),
                    help="the kinds of fault drawn from, comma-separated (default all: "
                    + ", ".join(FAULT_KINDS) + ")")
    ap.add_argument("--seed", type=int, default=1, help="the random order and faults (default 1)")
    ap.add_argument("--small-pool", action="store_true",
                    help="two gestures and one distractor clip per mode (the test's short run)")
    ap.add_argument("--cache", default=str(Path(os.environ.get("STEREOGEST_BUILD_DIR",
                                                               ROOT / "build")) / "soak_board"),
                    help="where the rendered clips are kept (default build/soak_board)")
    ap.add_argument("--json", help="also write the report to this file")
    ap.add_argument("--quiet", action="store_true", help="only the JSON line")
    args = ap.parse_args(argv)
    modes = [m.strip() for m in args.modes.split(",") if m.strip()]
    bad = [m for m in modes if m not in MODES]
    if bad or not modes:
        ap.error(f"--modes must name thesis and/or continuous, got {args.modes!r}")
    if not 1_000 <= args.frames <= 100_000_000:
        ap.error(f"--frames must be in 1000..100000000, got {args.frames}")
    kinds = [k.strip() for k in args.faults.split(",") if k.strip()]
    if not kinds or any(k not in FAULT_KINDS for k in kinds):
        ap.error(f"--faults must name some of {', '.join(FAULT_KINDS)}, got {args.faults!r}")
    if not 0.0 <= args.fault_rate <= 1.0:
        ap.error(f"--fault-rate must be in [0, 1], got {args.fault_rate}")
    if not 1_000 <= args.reload_every <= 100_000_000:
        ap.error(f"--reload-every must be in 1000..100000000, got {args.reload_every}")
    if not Path("/proc/self/statm").exists():
        ap.error("the soak reads its memory and descriptors from /proc (Linux)")

    from stereogest.pipeline_outputs import (load_models_with_postures, shipped_model_path,
                                             shipped_posture_model_path)
    cache = Path(args.cache)
    work = cache / "work"
    work.mkdir(parents=True, exist_ok=True)
    report = {"frames_per_mode": args.frames, "fault_rate": args.fault_rate,
              "reload_every": args.reload_every, "seed": args.seed, "modes": {}}
    ok = True
    for mode in modes:
        models, posture_model = load_models_with_postures(None, mode)
        posture_path = shipped_posture_model_path() if getattr(models, "postures", None) \
            else None
        if not args.quiet:
            print(f"{mode}: the pool ({SIZES[mode][0]}x{SIZES[mode][1]})", flush=True)
        clips = load_pool(mode, args.small_pool, cache, models,
                          posture_model if posture_path else None, quiet=args.quiet)
        try:
            row = soak(mode, args.frames, clips, shipped_model_path(mode), posture_path,
                       seed=args.seed, fault_rate=args.fault_rate,
                       reload_every=args.reload_every, work=work, quiet=args.quiet,
                       fault_kinds=kinds)
        except KeyboardInterrupt:
            print(f"soak_board: interrupted in the {mode} mode; no report", file=sys.stderr)
            return 130
        report["modes"][mode] = row
        passed = (row["differences"] == 0 and row["crashes"] == 0 and row["fd_growth"] == 0
                  and row["rss_growth_mb"] <= MAX_RSS_GROWTH_MB)
        ok &= passed
        if not args.quiet:
            print(f"{mode}: {row['frames']:,} frames ({row['hours_of_video']} h of video), "
                  f"{row['gestures_named']} gestures named, {row['differences']} differences "
                  f"from the offline spotter, {sum(row['faults'].values())} faults, reloads "
                  f"{row['reloads']}, {row['crashes']} crashes; rss {row['rss_warm_mb']} -> "
                  f"{row['rss_end_mb']} MB ({row['rss_growth_mb']:+} MB), fds "
                  f"{row['fd_growth']:+}; {row['log_lines_per_hour']} log lines per hour; "
                  f"{row['cpu_us_per_frame']} CPU us per frame ({row['cpu_s']} CPU s)"
                  + ("" if passed else "  FAILED"), flush=True)
    report["passed"] = ok
    if args.json:
        Path(args.json).write_text(json.dumps(report, indent=1) + "\n")
    print(json.dumps(report))
    return 0 if ok else 1


if __name__ == "__main__":
    raise SystemExit(main())
