"""Score a disparity map against ground truth and print JSON: pct_good is the
percentage of pixels with known ground truth (GT > 0) whose disparity is
valid and within 1 px of GT / scale; pct_invalid the percentage of those
pixels left invalid (0)."""
from __future__ import annotations

import json
import math

from stereogest.commands import add_json_switch

NAME = "eval-stereo"
HELP = "score a disparity PNG against ground truth (JSON: pct_good, pct_invalid)"


def add_arguments(p):
    p.add_argument("disparity", metavar="DISP.png", help="disparity map written by 'stereogest stereo'")
    p.add_argument("ground_truth", metavar="GT.png", help="ground-truth disparity image (0 = unknown)")
    p.add_argument("--gt-scale", type=float, required=True, metavar="S",
                   help="GT pixel value per pixel of disparity (Middlebury: tsukuba 16, venus 8, cones 4)")
    p.add_argument("--max-error", type=float, default=1.0, metavar="PX",
                   help="largest error in pixels that still counts as good")
    p.add_argument("--exclude-left", type=int, default=0, metavar="N",
                   help="also report pct_good_excluding_left over columns >= N (e.g. N = D)")
    add_json_switch(p, always=True)


def run(args) -> int:
    from sim.evaluate import score_disparity
    from sim.images import read_array

    if not (math.isfinite(args.gt_scale) and args.gt_scale > 0):
        raise ValueError(f"--gt-scale must be a positive number, got {args.gt_scale}")
    if not (math.isfinite(args.max_error) and args.max_error >= 0):
        raise ValueError(f"--max-error must be a finite number >= 0, got {args.max_error}")
    disp = read_array(args.disparity)
    gt = read_array(args.ground_truth)
    for name, path, image in (("DISP.png", args.disparity, disp),
                              ("GT.png", args.ground_truth, gt)):
        if image.ndim != 2:
            raise ValueError(f"{name} ({path}) must be a single-channel disparity image, got "
                             f"{image.shape[2] if image.ndim == 3 else image.ndim} channels "
                             f"(a colour picture?)")
    if disp.shape != gt.shape:
        raise ValueError(f"DISP.png is {disp.shape[1]}x{disp.shape[0]} but GT.png is "
                         f"{gt.shape[1]}x{gt.shape[0]}")
    print(json.dumps(score_disparity(disp, gt, args.gt_scale, max_error=args.max_error,
                                     exclude_left=args.exclude_left)))
    return 0
