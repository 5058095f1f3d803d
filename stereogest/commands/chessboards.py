"""Render chessboard pairs as a slightly misaligned stereo rig sees them
(:class:`sim.calibration.StereoRig`: rolled, pitched and yawed by under a
degree, principal points a few pixels apart, mild barrel distortion), to try
``stereogest calibrate`` without cameras. ``--truth FILE`` also writes the
rig's own calibration (what ``calibrate`` should recover), which every command
with ``--calibration`` takes: the default rig's maps, as ``stereogest timing``
and the documentation's figures use them."""
from __future__ import annotations

import argparse
from pathlib import Path

from stereogest.commands import DEFAULT_SEED, add_json_switch

NAME = "chessboards"
HELP = "render chessboard pairs from a misaligned rig (input for calibrate)"


def add_arguments(p: argparse.ArgumentParser) -> None:
    p.add_argument("-o", "--output", required=True, metavar="DIR", default=argparse.SUPPRESS,
                   help="folder to write left_NN.png / right_NN.png into")
    p.add_argument("--count", type=int, default=12, help="pairs, 1..100")
    p.add_argument("--seed", type=int, default=DEFAULT_SEED,
                   help="random seed (>= 0) of the board poses")
    p.add_argument("--truth", metavar="CALIB.json", default=None,
                   help="also write the rig's true calibration here (the default rig's, "
                        "for --calibration)")
    add_json_switch(p)


def run(args) -> int:
    import json

    from sim.calibration import DEFAULT_PATTERN, StereoRig, render_chessboard_pairs, \
        rig_calibration, save_calibration
    from sim.images import write_png
    from sim.model.validation import check_int
    from stereogest.commands import OutputDir, check_output_file

    count = check_int("--count", args.count, 1, 100)
    seed = check_int("--seed", args.seed, 0, 2**32 - 1)
    if args.truth is not None and Path(args.truth).resolve() == Path(args.output).resolve():
        raise ValueError(f"--truth: {args.truth} is the --output folder; name a file")
    truth = None if args.truth is None else check_output_file(args.truth, "--truth")
    with OutputDir(args.output, stale=("left_*.png", "right_*.png")) as out:
        pairs = render_chessboard_pairs(StereoRig(), count, seed=seed)
        for k, (left, right) in enumerate(pairs):
            write_png(out / f"left_{k:02d}.png", left)
            write_png(out / f"right_{k:02d}.png", right)
    print(f"rendered {count} chessboard pairs ({DEFAULT_PATTERN[0]}x{DEFAULT_PATTERN[1]} "
          f"inner corners, 640x480) to {out}")
    if truth is not None:
        save_calibration(rig_calibration(StereoRig()), truth)
        print(f"wrote the rig's calibration to {truth}")
    if args.json:
        print(json.dumps({"output": str(out), "pairs": count, "seed": seed,
                          "truth": None if truth is None else str(truth)}))
    return 0
