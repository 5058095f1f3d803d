"""Calibrate a stereo pair of cameras from chessboard pictures (OpenCV's stereo
calibration and rectification, :mod:`sim.calibration`) and write the
calibration file that ``stereo``, ``pipeline``, ``demo`` and ``generate`` take
with ``--calibration``.

PAIRS is a folder of ``left_<name>.png`` / ``right_<name>.png`` pictures (pairs
matched by ``<name>``; ``stereogest chessboards`` renders such a folder), or a
clip directory of the two cameras (``stereogest clip``: each frame is a pair).
"""
from __future__ import annotations

import argparse

from stereogest.commands import add_json_switch

NAME = "calibrate"
HELP = "calibrate the two cameras from chessboard pairs (writes CALIB.json)"


def add_arguments(p: argparse.ArgumentParser) -> None:
    from sim.calibration import DEFAULT_PATTERN, DEFAULT_SQUARE_MM
    p.add_argument("pairs", metavar="PAIRS",
                   help="folder of left_*.png / right_*.png chessboard pictures, or a clip")
    p.add_argument("-o", "--output", required=True, metavar="CALIB.json",
                   default=argparse.SUPPRESS, help="calibration file to write")
    p.add_argument("--pattern", default="{}x{}".format(*DEFAULT_PATTERN), metavar="COLSxROWS",
                   help="inner corners of the chessboard (not squares), each 3..40")
    p.add_argument("--square", type=float, default=DEFAULT_SQUARE_MM, metavar="MM",
                   help="side of a square in mm (the unit of T and of the baseline)")
    add_json_switch(p, always=True)


def read_pairs(path):
    """The (left, right) grey pictures of PAIRS, and their names."""
    from pathlib import Path

    from sim.clip import is_clip_dir, load_clip
    from sim.images import read_grey
    from sim.model.ycbcr import ycbcr422_to_444
    path = Path(path)
    if not path.is_dir():
        raise ValueError(f"PAIRS: {path} is not a folder or a clip directory")
    if is_clip_dir(path):
        clip = load_clip(path)
        return ([(ycbcr422_to_444(l)[0], ycbcr422_to_444(r)[0])
                 for l, r in zip(clip.left, clip.right)],
                [f"frame {k}" for k in range(clip.frames)])
    lefts = {p.name[len("left_"):]: p for p in sorted(path.glob("left_*.png"))}
    rights = {p.name[len("right_"):]: p for p in sorted(path.glob("right_*.png"))}
    names = sorted(set(lefts) & set(rights))
    unmatched = sorted(set(lefts) ^ set(rights))
    if unmatched:
        raise ValueError(f"PAIRS: {len(unmatched)} pictures have no partner (e.g. "
                         f"{'left' if unmatched[0] in lefts else 'right'}_{unmatched[0]})")
    if not names:
        raise ValueError(f"PAIRS: {path} holds no left_*.png / right_*.png pairs and is "
                         f"not a clip")
    return [(read_grey(lefts[n]), read_grey(rights[n])) for n in names], names


def run(args) -> int:
    import json

    from sim.calibration import calibrate, parse_pattern, save_calibration
    from sim.model.validation import check_number
    from stereogest.commands import check_output_file

    pattern = parse_pattern(args.pattern)
    square = check_number("--square", args.square, 0, 10000, unit="mm", lo_open=True)
    out = check_output_file(args.output)
    pairs, _ = read_pairs(args.pairs)
    calib = calibrate(pairs, pattern, square)
    save_calibration(calib, out)
    print(f"calibrated from {calib.pairs} of {len(pairs)} pairs: RMS reprojection error "
          f"{calib.rms:.3f} px, baseline {calib.baseline:.1f} mm, written to {out}")
    print(json.dumps({"output": str(out), "pairs": calib.pairs, "offered": len(pairs),
                      "rms_px": round(calib.rms, 4), "baseline_mm": round(calib.baseline, 3),
                      "focal_px": [round(float(calib.camera_left[0, 0]), 2),
                                   round(float(calib.camera_right[0, 0]), 2)]}))
    return 0
