"""Soak of the hardware: the Verilated :class:`soc.core.StereogestCore` (the
whole FPGA side, :mod:`verif.system`) at 320x240 for ``--frames`` camera frames,
with camera faults at random all along and the centroid FIFO overflowed now and
then; the FIFO words checked against the golden model.

The two cameras run on one schedule, a frame period apart (``slot`` n is frame n
of both), as two OV5642s fed the same XCLK do; the right one starts 300 cycles
after the left (:data:`verif.clocks.RIGHT_LAG`). Frame n shows frame n modulo
the pool's of a pool of rendered gesture clips (``--pool`` frames). The pins
are generated slot by slot and fed to the running harness in pieces. In a
slot drawn at random (one in ``--fault-every`` on average) one fault, on a
camera drawn at random:

* ``unplug``: the camera is unplugged at a random point of the frame (PCLK
  stops, VSYNC high) and plugged back 1-8 frame periods later; it comes back on
  a frame boundary with a new phase: the cameras' skew drawn again within
  +-:data:`MAX_SKEW` camera cycles (inside the synchroniser's ``max_skew``);
* ``glitch``: a glitched sync (:mod:`sim.camera`): VSYNC early (the frame cut
  short), an HREF glitch, VSYNC inside a line, or the camera silent for the
  frame;
* ``clock_stop``: PCLK stops for 1 to 30,000 cycles at a random point of the
  frame (what the camera sent meanwhile is lost) and runs on;
* ``frame_length``: the frame has extra lines or longer lines (cropped by the
  capture: the frame is kept) or fewer or shorter lines (lost).

The reader (:class:`sw_hps.fifo.FifoPeripheral` on the simulated bridge, the
FIFO in streaming mode: one word pair per frame) polls once per frame period,
half a period after the frame's record is due, and pops what is there; so the
slot of every word is known. ``--overflows`` times it stops reading for the
FIFO's depth plus 4-40 frames (no camera fault meanwhile), then finds
FIFO-FULL, pops the FIFO and clears it.

Checked: the words popped equal the golden model's for the frames that came
out (:func:`sw_hps.simulated.streaming_words` of :func:`sim.model.pipeline.track`
over those frames' centroids, each frame's centroid from
:func:`sim.model.pipeline.process_frame`): ``differences`` must be 0. A fault's
recovery is the first frame out after it (after the replug for an unplugged
camera); recovered when that frame and every one after it until the next fault
match. The frames lost per fault are the slots from the fault to its recovery
without a frame out; a slot lost after a recovery, with no fault to blame,
counts in ``unexplained_losses`` (must be 0).

Run: ``python benchmarks/soak_hardware.py [--frames 10000]``. The last line of
output is JSON; CPU seconds are the harness's (the simulation) and this
process's (pins, golden model, checks).
"""
# (no ``from __future__ import annotations``: tests load this script outside
# sys.modules, where dataclasses could not resolve string annotations)
import argparse
import hashlib
import json
import math
import os
import random
import resource
import sys
import time
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parent.parent
if str(ROOT) not in sys.path:
    sys.path.insert(0, str(ROOT))

WIDTH, HEIGHT = 320, 240
FAULT_KINDS = ("unplug", "glitch", "clock_stop", "frame_length")
#: Largest skew between the cameras' frame starts after a replug, in camera
#: cycles: 750 pixels, within the synchroniser's ``max_skew`` (1,024 words of
#: its 2,048-word FIFOs, 2,048 camera cycles), so frames still pair by slot.
MAX_SKEW = 1500
#: Longest PCLK stop of ``clock_stop`` (camera cycles).
LONGEST_CLOCK_STOP = 30_000
#: Frame periods a camera stays unplugged.
UNPLUGGED = (1, 8)
#: Gestures of the frame pool, rendered in turn (seed 7000 + clip).
POOL_GESTURES = ("forward", "right", "rotate-left", "back", "left", "rotate-right", "stop")
#: Frames an overflow goes on after the FIFO is full: 4 to this many.
OVERFLOW_LONGEST = 40
#: Slots before and after an overflow kept free of camera faults.
OVERFLOW_MARGIN = 3
#: Slots kept free of faults at the start (the first frames after reset).
FIRST_FAULT = 4
#: Frames without a fault after a fault's damage: its recovery shows in them.
SETTLE = 2


def log(message: str) -> None:
    print(message, file=sys.stderr, flush=True)


# ------------------------------------------------------------------ frames and golden model


def frame_pool(count: int, params, cache: Path | None):
    """``count`` stereo frames of rendered gesture clips at 320x240 and each
    frame's golden centroid (x, y) and area: (lefts, rights, centroids, areas),
    kept in ``cache``."""
    from sim.model.pipeline import process_frame
    from sim.render import render_clip
    key = hashlib.sha256(json.dumps([count, POOL_GESTURES, params.as_dict()], sort_keys=True,
                                    default=str).encode()).hexdigest()[:12]
    path = None if cache is None else cache / f"pool-{key}.npz"
    if path is not None and path.exists():
        data = np.load(path)
        return data["lefts"], data["rights"], data["centroids"], data["areas"]
    lefts, rights = [], []
    clip_no = 0
    while len(lefts) < count:
        gesture = POOL_GESTURES[clip_no % len(POOL_GESTURES)]
        clip = render_clip(gesture, 7000 + clip_no, WIDTH, HEIGHT, n_pre_rest=2, n_post_rest=2)
        lefts.extend(clip.left)
        rights.extend(clip.right)
        clip_no += 1
    lefts, rights = np.stack(lefts[:count]), np.stack(rights[:count])
    centroids = np.zeros((count, 2), np.int64)
    areas = np.zeros(count, np.int64)
    for k in range(count):
        # no hand tracking: a frame's centroid does not depend on the frames before
        c = process_frame(lefts[k], rights[k], params).centroid
        centroids[k], areas[k] = (c.x, c.y), c.area
    if path is not None:
        path.parent.mkdir(parents=True, exist_ok=True)
        tmp = path.with_suffix(".tmp.npz")
        np.savez(tmp, lefts=lefts, rights=rights, centroids=centroids, areas=areas)
        os.replace(tmp, path)
    return lefts, rights, centroids, areas


# ------------------------------------------------------------------ faults


@dataclass
class Fault:
    slot: int
    kind: str
    camera: int                 #: 0 left, 1 right
    detail: str
    #: unplug: frame periods away, new skew
    periods: int = 0
    skew: int = 0
    #: filled in by the check
    lost: int = 0
    recovered: bool = False


def draw_faults(rng: random.Random, frames: int, fault_every: float,
                overflows: list[tuple[int, int]], period: int) -> dict[int, Fault]:
    """One fault in a slot with probability 1 / ``fault_every``, none in the first
    slots, none within an overflow (and its margin), and none until
    :data:`SETTLE` frames have come after the last one's damage (so that
    each recovery is seen)."""
    busy = set()
    for start, length in overflows:
        busy.update(range(start - OVERFLOW_MARGIN, start + length + OVERFLOW_MARGIN))
    faults: dict[int, Fault] = {}
    free_from = FIRST_FAULT
    for slot in range(FIRST_FAULT, frames - SETTLE):
        if slot < free_from or slot in busy or rng.random() >= 1 / fault_every:
            continue
        camera = rng.randrange(2)
        kind = rng.choice(FAULT_KINDS)
        free_from = slot + 1 + SETTLE
        if kind == "unplug":
            periods = rng.randint(*UNPLUGGED)
            if slot + periods + SETTLE >= frames or \
                    any(s in busy for s in range(slot, slot + periods + 1)):
                continue
            skew = rng.randint(-MAX_SKEW, MAX_SKEW)
            cut = rng.randrange(0, period - 2 * MAX_SKEW)
            faults[slot] = Fault(slot, kind, camera, f"cut={cut}", periods, skew)
            free_from += periods
        elif kind == "glitch":
            what = rng.choice(("cut_frame", "href_glitch", "vsync_in_line", "silent_frame"))
            line, byte = rng.randrange(1, HEIGHT), rng.randrange(0, 2 * WIDTH - 8)
            faults[slot] = Fault(slot, kind, camera, f"{what} line={line} byte={byte}")
        elif kind == "clock_stop":
            length = min(int(10 ** rng.uniform(0, math.log10(LONGEST_CLOCK_STOP))), period - 1)
            start = rng.randrange(0, period - length)
            faults[slot] = Fault(slot, kind, camera, f"cycle={start} length={length}")
        else:
            what = rng.choice(("extra_lines", "longer_lines", "fewer_lines", "shorter_lines"))
            amount = {"extra_lines": rng.randint(1, 8), "longer_lines": 4 * rng.randint(1, 8),
                      "fewer_lines": rng.randint(1, HEIGHT - 1),
                      "shorter_lines": 4 * rng.randint(1, WIDTH // 2 - 1)}[what]
            faults[slot] = Fault(slot, kind, camera, f"{what}={amount}")
    return faults


# ------------------------------------------------------------------ camera pins


class Cameras:
    """The two cameras' packed pins (:func:`sim.camera.pack_pins`), slot by slot."""

    def __init__(self, lefts, rights, timing, faults: dict[int, Fault]):
        from verif.clocks import LEFT_START_DELAY, RIGHT_LAG
        self.frames = (lefts, rights)
        self.timing = timing
        self.period = timing.frame_cycles(WIDTH, HEIGHT)
        self.faults = faults
        self.start = [LEFT_START_DELAY, LEFT_START_DELAY + RIGHT_LAG]   # slot 0's start
        self.away = [0, 0]          # a camera unplugged skips slots before this one
        self._blocks: dict[tuple[int, int], np.ndarray] = {}

    def slot_start(self, camera: int, slot: int) -> int:
        """Camera cycle at which ``camera``'s frame of ``slot`` begins (its VSYNC
        pulse), as the schedule stands (a replug moves it)."""
        return self.start[camera] + slot * self.period

    def _wave(self, camera: int, index: int, frame=None, timing=None):
        from sim.camera import camera_waveform
        return camera_waveform([self.frames[camera][index] if frame is None else frame],
                               timing or self.timing)

    def _fit(self, pins: np.ndarray) -> np.ndarray:
        """One frame period of samples: the closing VSYNC pulse cut off, or idle
        samples (VSYNC high) added."""
        if len(pins) >= self.period:
            return pins[:self.period]
        return np.concatenate([pins, np.full(self.period - len(pins), 1 << 9, np.uint16)])

    def block(self, camera: int, slot: int) -> np.ndarray:
        """``camera``'s samples of ``slot`` with the slot's fault on it if any."""
        from sim import camera as cam
        index = slot % len(self.frames[0])
        fault = self.faults.get(slot)
        if fault is None or fault.camera != camera or fault.kind == "unplug":
            key = (camera, index)
            if key not in self._blocks:
                self._blocks[key] = self._fit(cam.pack_pins(self._wave(camera, index)))
            return self._blocks[key]
        words = dict(item.split("=") for item in fault.detail.split()[1:]) \
            if fault.kind == "glitch" else dict(item.split("=") for item in fault.detail.split())
        if fault.kind == "glitch":
            what = fault.detail.split()[0]
            wave = self._wave(camera, index)
            line, byte = int(words["line"]), int(words["byte"])
            wave = {"cut_frame": lambda: cam.cut_frame(wave, 0, line),
                    "href_glitch": lambda: cam.href_glitch(wave, 0, line, byte),
                    "vsync_in_line": lambda: cam.vsync_in_line(wave, 0, line, byte,
                                                               length=1 + byte % 8),
                    "silent_frame": lambda: cam.stop_frame(wave, 0)}[what]()
            return self._fit(cam.pack_pins(wave))
        if fault.kind == "clock_stop":
            wave = cam.stop_clock(self._wave(camera, index), int(words["cycle"]),
                                  int(words["length"]))
            return self._fit(cam.pack_pins(wave))
        return self._fit(cam.pack_pins(self._odd_length(camera, index, fault.detail)))

    def _odd_length(self, camera: int, index: int, detail: str):
        """A frame of a different length, on the same frame period (the back
        porch takes up the difference)."""
        from dataclasses import replace as with_
        from sim.camera import camera_waveform
        what, amount = detail.split("=")
        amount = int(amount)
        frame = self.frames[camera][index]
        junk = ((np.arange(frame.size * 2) * 37 + 11) % 251).astype(np.uint8)
        t = self.timing
        if what == "extra_lines":
            frame = np.vstack([frame, junk[:amount * frame.shape[1]].reshape(amount, -1)])
        elif what == "longer_lines":
            frame = np.hstack([frame, junk[:amount * HEIGHT].reshape(HEIGHT, amount)])
            t = with_(t, hblank=t.hblank - amount)
        elif what == "fewer_lines":
            frame = frame[:HEIGHT - amount]
        else:
            frame = frame[:, :frame.shape[1] - amount]
            t = with_(t, hblank=t.hblank + amount)
        rows, row_bytes = frame.shape
        length = t.frame_cycles(row_bytes // 2, rows)
        t = with_(t, back_porch=t.back_porch + self.period - length)
        return camera_waveform([frame], t)

    def pins(self, first: int, last: int) -> tuple[np.ndarray, np.ndarray]:
        """Both cameras' samples of slots ``first`` to ``last - 1`` (and, for slot
        0, the idle samples before it)."""
        out = ([], [])
        for slot in range(first, last):
            fault = self.faults.get(slot)
            for camera in (0, 1):
                if slot == 0:
                    out[camera].append(np.full(self.start[camera], 1 << 9, np.uint16))
                if slot < self.away[camera]:
                    continue
                block = self.block(camera, slot)
                if fault is not None and fault.kind == "unplug" and fault.camera == camera:
                    out[camera].append(block[:int(fault.detail.split("=")[1])])
                    out[camera].append(self._unplugged(camera, fault))
                else:
                    out[camera].append(block)
        return (np.concatenate(out[0]) if out[0] else np.zeros(0, np.uint16),
                np.concatenate(out[1]) if out[1] else np.zeros(0, np.uint16))

    def _unplugged(self, camera: int, fault: Fault) -> np.ndarray:
        """PCLK stopped (VSYNC high, HREF low) from the cut to the camera's start
        of slot ``fault.slot + fault.periods``, moved to the new skew."""
        from sim.camera import CLOCK_STOPPED
        cut = int(fault.detail.split("=")[1])
        back = fault.slot + fault.periods
        old_skew = self.start[1] - self.start[0]
        shift = (fault.skew - old_skew) if camera == 1 else (old_skew - fault.skew)
        gap = self.slot_start(camera, back) + shift - (self.slot_start(camera, fault.slot) + cut)
        self.start[camera] += shift
        self.away[camera] = back
        return np.full(gap, CLOCK_STOPPED | (1 << 9), np.uint16)


# ------------------------------------------------------------------ the run


def account(faults: dict[int, Fault], came_out: set, bad: set, frames: int) -> list[dict]:
    """Each fault's recovery and frames lost, set on it; returns the slots lost
    with no fault to blame (``{"slot", "after"}``).

    A fault's recovery is the first frame out from its slot on, or for an
    unplugged camera from the slot it is plugged back in (a frame it finished
    before the cut may come out, the ones while it is away cannot); recovered
    when that frame and every later one up to the next fault match the golden
    model. Its frames lost: the slots from the fault to the recovery without a
    frame out."""
    slots = sorted(faults)
    bounds = slots + [frames]
    unexplained = []
    for k, slot in enumerate(slots):
        f = faults[slot]
        end = bounds[k + 1]
        back = slot + (f.periods if f.kind == "unplug" else 0)
        out = [s for s in range(back, end) if s in came_out]
        f.recovered = bool(out) and not any(s in bad for s in out)
        first = out[0] if out else end
        f.lost = sum(1 for s in range(slot, first) if s not in came_out)
        unexplained += [{"slot": s, "after": f"{f.kind} {f.detail} camera {f.camera} at slot "
                                             f"{slot}"}
                        for s in range(first, end) if s not in came_out]
    unexplained += [{"slot": s, "after": "no fault"}
                    for s in range(slots[0] if slots else frames) if s not in came_out]
    return unexplained


@dataclass
class Run:
    stored: dict[int, tuple[int, int]] = field(default_factory=dict)   #: slot -> words
    processed: list[int] = field(default_factory=list)  #: slots the pipeline completed
    overflow_dropped: int = 0
    overflow_full_seen: int = 0


def run(args) -> dict:
    from hdl.gesture_pipeline import pipeline_timing
    from sim.model.pipeline import PipelineParams, track
    from soc.hps_interface import FIFO_DEPTH
    from sw_hps.fifo import FifoPeripheral
    from sw_hps.simulated import streaming_words
    from verif.clocks import Clocks, clip_timing
    from verif.system import SystemBus, VerilatorSystem, build_system
    from verif.verilator import build_root

    params = PipelineParams.for_frame(WIDTH)
    depth = args.fifo_depth or FIFO_DEPTH
    clocks = Clocks()
    cpu0 = time.process_time()
    lefts, rights, centroids, areas = frame_pool(args.pool, params, build_root("soak_hardware"))
    log(f"frame pool: {len(lefts)} frames, {int((areas > 0).sum())} with a hand")
    exe = build_system(WIDTH, HEIGHT, params, clocks, log=log, fifo_depth=args.fifo_depth)
    timing = clip_timing(WIDTH, HEIGHT, pipeline_timing(WIDTH, HEIGHT, params).flush, clocks)
    rng = random.Random(args.seed)
    period = timing.frame_cycles(WIDTH, HEIGHT)
    overflows = []
    for k in range(args.overflows):
        # spread over the run: one in each stretch, at a random place in it
        stretch = args.frames // args.overflows
        length = depth + rng.randint(4, OVERFLOW_LONGEST)
        lo, hi = k * stretch + FIRST_FAULT + OVERFLOW_MARGIN, (k + 1) * stretch - length - 4
        overflows.append((rng.randint(lo, max(lo, hi)), length))
    faults = draw_faults(rng, args.frames, args.fault_every, overflows, period)
    cameras = Cameras(lefts, rights, timing, faults)
    stall = {}
    for start, length in overflows:
        stall.update({s: (start, length) for s in range(start, start + length)})

    chunk = 8
    left, right = cameras.pins(0, chunk)
    fed = chunk
    result = Run()
    started = time.perf_counter()
    child0 = resource.getrusage(resource.RUSAGE_CHILDREN)
    with VerilatorSystem(lefts[:1], rights[:1], params, clocks=clocks, exe=exe,
                         pins=(left, right)) as system:
        bus = SystemBus(system)
        fifo = FifoPeripheral(bus)
        identity = fifo.identify()
        if not identity.supported:
            raise RuntimeError(f"the core does not identify: {identity.describe()}")
        fifo.clear(streaming=True)
        level = 0           # words in the FIFO after the last poll
        for slot in range(args.frames):
            while fed < min(slot + 3, args.frames + 2):
                system.append_pins(*cameras.pins(fed, fed + chunk))
                fed += chunk
            # half a period after the record of the slot's frame is due
            due = cameras.slot_start(0, slot) + period + period // 2
            ahead = due * clocks.left_ps / 1000 - system.cycles * clocks.sync_ps / 1000
            if ahead > 0:
                system.advance(ahead * 1e-9)
            lx, ly = fifo.lengths()
            if lx != ly:
                raise RuntimeError(f"slot {slot}: Longitud_X {lx} != Longitud_Y {ly}")
            new = lx - level
            if new not in (0, 1):
                raise RuntimeError(f"slot {slot}: {new} words in one frame period")
            window = stall.get(slot)
            if new:
                result.processed.append(slot)
                result.stored[slot] = None
            elif window is not None and lx == depth:
                result.processed.append(slot)   # full: the record was dropped
                result.overflow_dropped += 1
            if window is None or slot == window[0] + window[1] - 1:
                if window is not None and fifo.status().full:
                    result.overflow_full_seen += 1
                pending = [s for s, w in result.stored.items() if w is None]
                if len(pending) != lx:
                    raise RuntimeError(f"slot {slot}: {lx} words in the FIFO, "
                                       f"{len(pending)} expected")
                for s in pending:
                    result.stored[s] = fifo.pop_words()
                if window is not None:
                    fifo.clear(streaming=True)
                level = 0
            else:
                level = lx
            if args.progress and slot % args.progress == 0 and slot:
                rate = slot / (time.perf_counter() - started)
                log(f"slot {slot}/{args.frames}: {len(result.processed)} frames out, "
                    f"{rate:.1f} frames/s")
        stats = system.close()
    child = resource.getrusage(resource.RUSAGE_CHILDREN)
    harness_cpu = (child.ru_utime - child0.ru_utime) + (child.ru_stime - child0.ru_stime)

    # golden model over the frames the pipeline completed
    processed = np.array(result.processed, dtype=np.int64)
    index = processed % len(lefts)
    trajectory = track(centroids[index], areas[index], params)
    golden = streaming_words(trajectory, depth=len(processed) + 1)
    expected = dict(zip(result.processed, golden))
    differences = [s for s, w in result.stored.items() if tuple(w) != tuple(expected[s])]

    # recoveries and frames lost per fault
    per_kind: dict[str, list[Fault]] = {k: [] for k in FAULT_KINDS}
    unexplained_slots = account(faults, set(result.processed), set(differences), args.frames)
    unexplained = len(unexplained_slots)
    for f in faults.values():
        per_kind[f.kind].append(f)
    for item in unexplained_slots:
        window = stall.get(item["slot"])
        if window is not None:
            item["overflow"] = f"slots {window[0]}-{window[0] + window[1] - 1}"
    cpu = time.process_time() - cpu0
    kinds = {}
    for kind, items in per_kind.items():
        lost = [f.lost for f in items]
        kinds[kind] = {"faults": len(items), "recovered": sum(f.recovered for f in items),
                       "frames_lost_mean": round(float(np.mean(lost)), 2) if lost else None,
                       "frames_lost_max": max(lost) if lost else None}
    details = {}
    for f in faults.values():
        what = f.kind if f.kind in ("unplug", "clock_stop") else \
            f.detail.split()[0].split("=")[0]
        d = details.setdefault(what, {"faults": 0, "lost": [], "beyond": []})
        d["faults"] += 1
        d["lost"].append(f.lost)
        d["beyond"].append(f.lost - f.periods)
    passed = (len(differences) == 0 and unexplained == 0
              and sum(f.recovered for f in faults.values()) == len(faults)
              and result.overflow_full_seen == len(overflows))
    return {
        "benchmark": "soak_hardware", "passed": passed, "frames": args.frames,
        "size": f"{WIDTH}x{HEIGHT}",
        "seed": args.seed, "pool": len(lefts), "fifo_depth": depth,
        "faults": len(faults), "recoveries": sum(f.recovered for f in faults.values()),
        "per_kind": kinds,
        # unplug: "beyond" is what it cost besides the frame periods it was away
        "frames_lost": {k: {"faults": v["faults"], "mean": round(float(np.mean(v["lost"])), 2),
                            "max": max(v["lost"]), "max_beyond_away": max(v["beyond"])}
                        for k, v in sorted(details.items())},
        "overflows": len(overflows), "overflow_full_seen": result.overflow_full_seen,
        "overflow_frames_dropped": result.overflow_dropped,
        "frames_out": len(result.processed), "words_checked": len(result.stored),
        "differences": len(differences), "first_differences": differences[:5],
        "unexplained_losses": unexplained, "first_unexplained": unexplained_slots[:10],
        "cycles": stats.get("cycles"), "harness_cpu_s": round(harness_cpu, 1),
        "python_cpu_s": round(cpu, 1),
        "cycles_per_cpu_s": round(stats.get("cycles", 0) / harness_cpu) if harness_cpu else None,
    }


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--frames", type=int, default=10_000,
                        help="camera frames (slots) to run (default 10000)")
    parser.add_argument("--fault-every", type=float, default=20.0,
                        help="mean frames between camera faults (default 20)")
    parser.add_argument("--overflows", type=int, default=4,
                        help="times the reader stops until the FIFO overflows (default 4)")
    parser.add_argument("--fifo-depth", type=int, default=None,
                        help="entries of the centroid FIFOs (default: the board's)")
    parser.add_argument("--pool", type=int, default=120,
                        help="distinct rendered frames played in turn (default 120)")
    parser.add_argument("--seed", type=int, default=1)
    parser.add_argument("--progress", type=int, default=500,
                        help="a progress line every N frames on stderr (0: none)")
    parser.add_argument("--json", type=Path, help="also write the result here")
    args = parser.parse_args(argv)
    for name, low in (("frames", 10), ("overflows", 0), ("pool", 1), ("progress", 0)):
        if getattr(args, name) < low:
            parser.error(f"--{name} must be at least {low}, got {getattr(args, name)}")
    if not 1 <= args.fault_every <= 1e9:
        parser.error(f"--fault-every must be in [1, 1e9], got {args.fault_every}")
    if args.fifo_depth is not None and not (16 <= args.fifo_depth <= 4096
                                            and args.fifo_depth & (args.fifo_depth - 1) == 0):
        parser.error(f"--fifo-depth must be a power of two in [16, 4096], got "
                     f"{args.fifo_depth}")
    from soc.hps_interface import FIFO_DEPTH
    need = args.overflows * ((args.fifo_depth or FIFO_DEPTH) + OVERFLOW_LONGEST
                             + FIRST_FAULT + OVERFLOW_MARGIN + 4)
    if args.frames < need:
        parser.error(f"--frames must be at least {need} for {args.overflows} --overflows of "
                     f"the {args.fifo_depth or FIFO_DEPTH}-entry FIFO, got {args.frames}")
    try:
        result = run(args)
    except KeyboardInterrupt:
        log("soak_hardware: interrupted")
        return 130
    for key, value in result.items():
        if key not in ("per_kind", "frames_lost"):
            print(f"{key:24s} {value}")
    for kind, row in result["frames_lost"].items():
        beyond = (f" (at most {row['max_beyond_away']} besides the periods away)"
                  if kind == "unplug" else "")
        print(f"  {kind:16s} {row['faults']:4d} faults, frames lost mean {row['mean']}, "
              f"max {row['max']}{beyond}")
    line = json.dumps(result)
    if args.json:
        tmp = args.json.with_suffix(".tmp")
        tmp.write_text(line + "\n")
        os.replace(tmp, args.json)
    print(line)
    return 0 if result["passed"] else 1


if __name__ == "__main__":
    sys.exit(main())
