"""Render chessboard pairs as a slightly misaligned stereo rig sees them
(:class:`sim.calibration.StereoRig`: rolled, pitched and yawed by under a
degree, principal points a few pixels apart, mild barrel distortion), to try
``stereogest calibrate`` without cameras."""
from __future__ import annotations

import argparse

from stereogest.commands import DEFAULT_SEED, add_json_switch

NAME = "chessboards"
HELP = "render chessboard pairs from a misaligned rig (input for calibrate)"


def add_arguments(p: argparse.ArgumentParser) -> None:
    p.add_argument("-o", "--output", required=True, metavar="DIR", default=argparse.SUPPRESS,
                   help="folder to write left_NN.png / right_NN.png into")
    p.add_argument("--count", type=int, default=12, help="pairs, 1..100")
    p.add_argument("--seed", type=int, default=DEFAULT_SEED,
                   help="random seed (>= 0) of the board poses")
    add_json_switch(p)


def run(args) -> int:
    import json

    from sim.calibration import DEFAULT_PATTERN, StereoRig, render_chessboard_pairs
    from sim.images import write_png
    from sim.model.validation import check_int
    from stereogest.commands import OutputDir

    count = check_int("--count", args.count, 1, 100)
    seed = check_int("--seed", args.seed, 0, 2**32 - 1)
    with OutputDir(args.output, stale=("left_*.png", "right_*.png")) as out:
        pairs = render_chessboard_pairs(StereoRig(), count, seed=seed)
        for k, (left, right) in enumerate(pairs):
            write_png(out / f"left_{k:02d}.png", left)
            write_png(out / f"right_{k:02d}.png", right)
    print(f"rendered {count} chessboard pairs ({DEFAULT_PATTERN[0]}x{DEFAULT_PATTERN[1]} "
          f"inner corners, 640x480) to {out}")
    if args.json:
        print(json.dumps({"output": str(out), "pairs": count, "seed": seed}))
    return 0
