"""Rectification figures (issue 17, thesis §10.1), each printed as a Markdown
table and all of them as a final JSON line:

1. the model's compressed-map remap against ``cv2.remap`` with the full float
   maps, on the three Middlebury left images warped by a known misalignment:
   grey-level error (mean, 99th percentile, maximum; away from the border) and
   the interpolated map's position error (pixels), over grid steps and
   fraction bits;
2. Middlebury pct_good (Wc=7, Wh=13, Th=8, as benchmarks/stereo_quality.py):
   the rectified pair, the same pair from a misaligned rig unrectified,
   rectified by the model and by ``cv2.remap`` (sim.evaluate.misaligned_scores);
3. gesture recognition on rendered clips seen through the default rig
   (sim.calibration.StereoRig scaled to 320x240: lens distortion, under a
   degree of roll, pitch and yaw, principal points apart; golden model, the
   board application's shipped model): aligned (the rendered rectified view),
   unrectified and rectified, with the centroid error against the rendered
   truth;
4. the Rectifier's memory at 640x480 for the default rig (StereoRig) against
   the 5CSEMA5's M10K bits.

Run: ``python benchmarks/bench_rectify.py [--seeds 2] [--first-seed 2001]
[--json FILE]``.
"""
from __future__ import annotations

import argparse
import json
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parent.parent
SCENES = {"tsukuba": (32, 16), "venus": (32, 8), "cones": (64, 4)}   # D, GT scale
MATCHER = dict(census_window=7, hamming_window=13, lrcc_threshold=8)
GESTURES = ("forward", "back", "right", "left", "rotate-right", "rotate-left", "stop")
#: M10K bits of the 5CSEMA5 (397 blocks of 10,240 bits)
DEVICE_M10K_BITS = 397 * 10240


def remap_errors():
    from sim.evaluate import MISALIGNMENT, remap_errors as errors_of
    from sim.images import read_grey
    from sim.model.rectify import misalignment
    rows = []
    for scene in SCENES:
        image = read_grey(ROOT / "data" / "middlebury" / scene / "left.png")
        h, w = image.shape
        hom = misalignment(w, h, **MISALIGNMENT["left"])
        for step in (4, 8, 16):
            for frac in (3, 4, 5, 6):
                grey, pos = errors_of(image, hom, grid_step=step, frac_bits=frac)
                rows.append({"scene": scene, "grid_step": step, "frac_bits": frac,
                             "grey_mean": round(float(grey.mean()), 3),
                             "grey_p99": float(np.percentile(grey, 99)),
                             "grey_max": int(grey.max()),
                             "map_mean_px": round(float(pos.mean()), 4),
                             "map_p99_px": round(float(np.percentile(pos, 99)), 4),
                             "map_max_px": round(float(pos.max()), 4)})
    print("\n| scene | S | F | grey mean | grey p99 | grey max | map mean (px) | map p99 | "
          "map max |\n|---|---|---|---|---|---|---|---|---|")
    for r in rows:
        print(f"| {r['scene']} | {r['grid_step']} | {r['frac_bits']} | {r['grey_mean']} | "
              f"{r['grey_p99']:g} | {r['grey_max']} | {r['map_mean_px']} | {r['map_p99_px']} | "
              f"{r['map_max_px']} |")
    return rows


def middlebury():
    from sim.evaluate import misaligned_scores
    from sim.images import read_array, read_grey
    rows = []
    print("\n| scene | original | misaligned, unrectified | rectified (model) | "
          "rectified (cv2.remap) | rectified - original | same without the leftmost D "
          "columns |\n|---|---|---|---|---|---|---|")
    for scene, (ndisp, scale) in SCENES.items():
        folder = ROOT / "data" / "middlebury" / scene
        r = misaligned_scores(read_grey(folder / "left.png"), read_grey(folder / "right.png"),
                              read_array(folder / "disp_left.png"), scale,
                              matcher=dict(MATCHER, max_disparity=ndisp))
        rows.append({"scene": scene, **r})
        g = {k: r[k]["pct_good"] for k in ("original", "unrectified", "rectified",
                                           "rectified_cv2")}
        ex = {k: r[k]["pct_good_excluding_left"] for k in ("original", "rectified")}
        print(f"| {scene} | {g['original']} | {g['unrectified']} | {g['rectified']} | "
              f"{g['rectified_cv2']} | {g['rectified'] - g['original']:+.2f} | "
              f"{ex['rectified'] - ex['original']:+.2f} |")
    return rows


def gestures(seeds: int, first_seed: int, width: int = 320, height: int = 240):
    from sim.calibration import (StereoRig, camera_frames, rig_calibration,
                                 stereo_rectification)
    from sim.evaluate import track_errors
    from sim.model.pipeline import PipelineParams, run_clip
    from sim.render import render_clip
    from stereogest.pipeline_outputs import recognise, shipped_model_path
    from sw_hps.hmm import load_models

    models = load_models(shipped_model_path())
    params = PipelineParams.for_frame(width)
    # the default rig at this picture size; the renderer draws its rectified view
    calib = rig_calibration(StereoRig().resized(width, height))
    rect = stereo_rectification(calib)
    rows = []
    for gesture in GESTURES:
        for seed in range(first_seed, first_seed + seeds):
            clip = render_clip(gesture, seed, width, height)
            left = camera_frames(clip.left, calib, "left")
            right = camera_frames(clip.right, calib, "right")
            truth = clip.hand_xy
            row = {"gesture": gesture, "seed": seed}
            for name, frames, rectification in (("aligned", (clip.left, clip.right), None),
                                                ("unrectified", (left, right), None),
                                                ("rectified", (left, right), rect)):
                start = time.process_time()
                traj, _ = run_clip(*frames, params, threads=1, rectification=rectification)
                recognised, _ = recognise(models, traj)
                row[name] = {"recognised": recognised, "correct": recognised == gesture,
                             **track_errors(truth, traj), "frames": clip.frames,
                             "cpu_seconds": round(time.process_time() - start, 1)}
            rows.append(row)
            print(f"  {gesture} {seed}: " + ", ".join(
                f"{k} {row[k]['recognised']}" for k in ("aligned", "unrectified", "rectified")),
                flush=True)
    summary = {}
    print("\n| clips (320x240, the default rig) | recognised | hand found in frames | "
          "centroid error mean / p95 (px) |\n|---|---|---|---|")
    for name in ("aligned", "unrectified", "rectified"):
        ok = sum(r[name]["correct"] for r in rows)
        hand = sum(r[name]["hand_frames"] for r in rows)
        frames = sum(r[name]["frames"] for r in rows)
        means = [r[name]["centroid_error_mean"] for r in rows
                 if r[name]["centroid_error_mean"] is not None]
        p95 = [r[name]["centroid_error_p95"] for r in rows
               if r[name]["centroid_error_p95"] is not None]
        summary[name] = {"recognised": ok, "clips": len(rows), "hand_frames": hand,
                         "frames": frames,
                         "centroid_error_mean": round(float(np.mean(means)), 2) if means else None,
                         "centroid_error_p95": round(float(np.mean(p95)), 2) if p95 else None}
        s = summary[name]
        print(f"| {name} | {ok} of {len(rows)} | {hand} of {frames} | "
              f"{s['centroid_error_mean']} / {s['centroid_error_p95']} |")
    return {"clips": rows, "summary": summary}


def hardware_memory():
    from hdl.gesture_pipeline import pipeline_memory_bits
    from sim.calibration import StereoRig, rig_calibration, stereo_rectification
    from sim.model.pipeline import PipelineParams
    rect = stereo_rectification(rig_calibration(StereoRig()))
    # the pipeline's memory_bits, from its stages' memory functions (nothing is built)
    memory_bits = pipeline_memory_bits(640, 480, PipelineParams(), rect)
    parts = {k: v for k, v in memory_bits.items() if k.startswith("rectify")}
    total = sum(parts.values())
    share = 100.0 * total / DEVICE_M10K_BITS
    reach = rect.max_shift
    print(f"\nRectifier memory at 640x480 (default rig, reach {reach[0]} x {reach[1]} px): "
          f"{total:,} bits = {share:.1f} % of the 5CSEMA5's M10K bits; {parts}")
    return {"max_shift": list(reach), "bits": total, "m10k_share_pct": round(share, 2),
            "parts": parts}


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--seeds", type=int, default=2, help="clips per gesture")
    parser.add_argument("--first-seed", type=int, default=2001)
    parser.add_argument("--json", metavar="FILE", default=None)
    args = parser.parse_args(argv)
    start = time.process_time()
    report = {"remap_errors": remap_errors(), "middlebury": middlebury(),
              "hardware_memory": hardware_memory(),
              "gestures": gestures(args.seeds, args.first_seed)}
    report["cpu_seconds"] = round(time.process_time() - start, 1)
    text = json.dumps(report, default=float)
    if args.json:
        Path(args.json).write_text(text + "\n")
    print(text)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
