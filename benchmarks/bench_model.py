"""Speed of the numpy golden model (issue: foundation, section 7).

Times, in one run on this machine:

* the whole per-frame pipeline (4:2:2 -> 4:4:4, medians, stereo matching,
  segmentation, opening, centroid) on one 640x480 stereo frame of a rendered
  gesture clip with the thesis run-time parameters (Wc=7, Wh=29, D=48, W=11),
  with a per-stage breakdown;
* OpenCV StereoBM and StereoSGBM at D=48 on the same grey images, and the
  ratios to the model's stereo stage;
* the stereo matcher on Middlebury cones (450x375, Wc=7, Wh=13, D=64), the
  scene for which the thesis reports 375 s of MATLAB.

Prints a table and a final JSON line. Target: whole pipeline <= 250 ms per
VGA stereo frame. Run: ``make bench`` or ``python benchmarks/bench_model.py``.
"""
from __future__ import annotations

import argparse
import json
import os
import statistics
import time
from pathlib import Path

import cv2
import numpy as np

from sim.images import read_grey
from sim.model import (census_bits, centroid, disparity_band, disparity_maps, hand_mask,
                       lr_consistency, median3x3, opening, skin_mask, sparse_census,
                       ycbcr422_to_444)
from sim.model.pipeline import PipelineParams, process_frame
from sim.model.stereo import stereo_match
from sim.render import StereoScene

ROOT = Path(__file__).resolve().parent.parent
TARGET_MS = 250.0


def best_of(fn, repeats):
    """Median wall time of ``repeats`` calls, in ms, after one warm-up call."""
    fn()
    times = []
    for _ in range(repeats):
        start = time.perf_counter()
        fn()
        times.append(1e3 * (time.perf_counter() - start))
    return statistics.median(times)


def stage_breakdown(left_bytes, right_bytes, p: PipelineParams, repeats: int) -> dict:
    y_l, cb_l, cr_l = ycbcr422_to_444(left_bytes)
    y_r, _, _ = ycbcr422_to_444(right_bytes)
    m_l, m_r = median3x3(y_l), median3x3(y_r)
    c_l, c_r = sparse_census(m_l, p.census_window), sparse_census(m_r, p.census_window)
    bits = census_bits(p.census_window)
    maps = disparity_maps(c_l, c_r, p.hamming_window, p.max_disparity, bits)
    checked = lr_consistency(maps.l2r, maps.r2l, p.lrcc_threshold)
    disp = median3x3(checked)
    skin = skin_mask(cb_l, cr_l)
    band = disparity_band(disp, p.band_low, p.band_high, p.max_disparity)
    hand = hand_mask(skin, band)
    opened = opening(hand, p.opening_shape, size=p.opening_size)
    stages = {
        "ycbcr422_to_444 x2": lambda: (ycbcr422_to_444(left_bytes), ycbcr422_to_444(right_bytes)),
        "median3x3 x2": lambda: (median3x3(y_l), median3x3(y_r)),
        "sparse_census x2": lambda: (sparse_census(m_l, p.census_window),
                                     sparse_census(m_r, p.census_window)),
        "hamming+SHD+L2R/R2L": lambda: disparity_maps(c_l, c_r, p.hamming_window,
                                                      p.max_disparity, bits),
        "lr_consistency": lambda: lr_consistency(maps.l2r, maps.r2l, p.lrcc_threshold),
        "disparity median": lambda: median3x3(checked),
        "skin+band+AND": lambda: hand_mask(skin_mask(cb_l, cr_l),
                                           disparity_band(disp, p.band_low, p.band_high,
                                                          p.max_disparity)),
        "opening 11x11 cross": lambda: opening(hand, p.opening_shape, size=p.opening_size),
        "centroid": lambda: centroid(opened),
    }
    return {name: best_of(fn, repeats) for name, fn in stages.items()}


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--repeats", type=int, default=5, help="timed runs per figure (median)")
    args = parser.parse_args(argv)
    if args.repeats < 1:
        parser.error("--repeats must be >= 1")

    params = PipelineParams()
    scene = StereoScene("rotate-right", seed=1, width=640, height=480)
    left_bytes, right_bytes = scene.stereo_frame(scene.motion_span[0] + 20)
    y_l = median3x3(ycbcr422_to_444(left_bytes)[0])
    y_r = median3x3(ycbcr422_to_444(right_bytes)[0])

    print(f"machine: {os.cpu_count()} CPUs; numpy {np.__version__}; OpenCV {cv2.__version__}")
    print("one 640x480 stereo frame, Wc=7 Wh=29 D=48 W=11 (thesis run-time parameters)")
    pipeline_ms = best_of(lambda: process_frame(left_bytes, right_bytes, params), args.repeats)
    stereo_ms = best_of(lambda: stereo_match(y_l, y_r, census_window=7, hamming_window=29,
                                             max_disparity=48, lrcc_threshold=8), args.repeats)
    stages = stage_breakdown(left_bytes, right_bytes, params, args.repeats)
    for name, ms in stages.items():
        print(f"  {name:24s} {ms:8.1f} ms")
    print(f"  {'whole pipeline':24s} {pipeline_ms:8.1f} ms  (target <= {TARGET_MS:.0f} ms: "
          f"{'met' if pipeline_ms <= TARGET_MS else 'NOT met'})")

    bm = cv2.StereoBM_create(numDisparities=48, blockSize=29)
    sgbm = cv2.StereoSGBM_create(minDisparity=0, numDisparities=48, blockSize=7,
                                 P1=8 * 49, P2=32 * 49, mode=cv2.STEREO_SGBM_MODE_SGBM)
    bm_ms = best_of(lambda: bm.compute(y_l, y_r), args.repeats)
    sgbm_ms = best_of(lambda: sgbm.compute(y_l, y_r), args.repeats)
    print(f"  {'model stereo_match':24s} {stereo_ms:8.1f} ms")
    print(f"  {'OpenCV StereoBM':24s} {bm_ms:8.1f} ms   model/BM   = {stereo_ms / bm_ms:5.2f}")
    print(f"  {'OpenCV StereoSGBM':24s} {sgbm_ms:8.1f} ms   model/SGBM = {stereo_ms / sgbm_ms:5.2f}")

    cones = ROOT / "data" / "middlebury" / "cones"
    c_l, c_r = read_grey(cones / "left.png"), read_grey(cones / "right.png")
    cones_ms = best_of(lambda: stereo_match(c_l, c_r, census_window=7, hamming_window=13,
                                            max_disparity=64, lrcc_threshold=8), args.repeats)
    print(f"cones 450x375 Wc=7 Wh=13 D=64: {cones_ms:.1f} ms (thesis MATLAB: 375 s, "
          f"{375e3 / cones_ms:.0f}x)")
    print(json.dumps({"pipeline_ms": round(pipeline_ms, 1), "stereo_ms": round(stereo_ms, 1),
                      "opencv_bm_ms": round(bm_ms, 1), "opencv_sgbm_ms": round(sgbm_ms, 1),
                      "cones_ms": round(cones_ms, 1),
                      "stages_ms": {k: round(v, 1) for k, v in stages.items()}}))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
