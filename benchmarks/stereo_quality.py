"""Stereo quality of the golden model on the vendored Middlebury scenes.

Scores every scene the way ``stereogest eval-stereo`` does (within 1 px of
ground truth, over all pixels with known ground truth, invalid counted as
wrong) with the parameters of the thesis author's VHDL core (Wc=7, Wh=13,
Th=8; D=32 for tsukuba and venus, D=64 for cones) and prints a Markdown table
beside that core's scores, then an ablation of the model's own choices.
Run: ``python benchmarks/stereo_quality.py``.
"""
from __future__ import annotations

import json
from pathlib import Path

import cv2

from sim.evaluate import score_disparity
from sim.images import read_array, read_grey
from sim.model.stereo import stereo_match

ROOT = Path(__file__).resolve().parent.parent
SCENES = {  # name: (D, GT scale, author's core pct_good as quoted in the issue)
    "tsukuba": (32, 16, 88.75),
    "venus": (32, 8, 94.83),
    "cones": (64, 4, 84.52),
}
BASE = dict(census_window=7, hamming_window=13, lrcc_threshold=8)
ABLATION = {
    "model defaults": {},
    "no disparity median": dict(disparity_median=False),
    "input 3x3 median (camera pipeline)": dict(prefilter_median=True),
    "no_match_cost = 0": dict(no_match_cost=0),
    "no_match_cost = 12 (half the bits)": dict(no_match_cost=12),
    "no_match_cost = 24 (all bits)": dict(no_match_cost=24),
}


def score(scene: str, **options) -> dict:
    ndisp, scale, _ = SCENES[scene]
    folder = ROOT / "data" / "middlebury" / scene
    result = stereo_match(read_grey(folder / "left.png"), read_grey(folder / "right.png"),
                          max_disparity=ndisp, **{**BASE, **options})
    return score_disparity(result.disparity, read_array(folder / "disp_left.png"), scale,
                           exclude_left=ndisp)


def score_sgbm(scene: str) -> dict:
    """OpenCV StereoSGBM (block 5, P1 = 8*25, P2 = 32*25) on the same metric."""
    ndisp, scale, _ = SCENES[scene]
    folder = ROOT / "data" / "middlebury" / scene
    sgbm = cv2.StereoSGBM_create(minDisparity=0, numDisparities=ndisp, blockSize=5,
                                 P1=8 * 25, P2=32 * 25)
    disp = sgbm.compute(read_grey(folder / "left.png"), read_grey(folder / "right.png"))
    return score_disparity(disp / 16.0, read_array(folder / "disp_left.png"), scale)


def main() -> int:
    print("| scene | D | pct_good | pct_invalid | pct_good without the leftmost D columns "
          "| author's VHDL core | OpenCV SGBM |")
    print("|---|---|---|---|---|---|---|")
    table = {}
    for scene, (ndisp, _, author) in SCENES.items():
        s = score(scene)
        table[scene] = s
        print(f"| {scene} | {ndisp} | {s['pct_good']:.2f} | {s['pct_invalid']:.2f} | "
              f"{s['pct_good_excluding_left']:.2f} | {author:.2f} | "
              f"{score_sgbm(scene)['pct_good']:.2f} |")
    print()
    print("| variant | " + " | ".join(SCENES) + " |")
    print("|---|" + "---|" * len(SCENES))
    for name, options in ABLATION.items():
        cells = [f"{score(scene, **options)['pct_good']:.2f}" for scene in SCENES]
        print(f"| {name} | " + " | ".join(cells) + " |")
    print(json.dumps(table))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
