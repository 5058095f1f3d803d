"""Compute the disparity map of a rectified stereo pair with the golden model
(sparse census, SHD, best-of selectors, left-right check, median: thesis §6.2)
and write it as a 16-bit PNG whose value is the disparity in pixels
(0 = invalid)."""
from __future__ import annotations

import json
import time

NAME = "stereo"
HELP = "disparity map of a stereo pair (16-bit PNG, 0 = invalid)"


def add_arguments(p):
    p.add_argument("left", metavar="LEFT", help="left image (PNG; colour is converted to BT.601 luma)")
    p.add_argument("right", metavar="RIGHT", help="right image, same size as LEFT")
    p.add_argument("-o", "--output", metavar="DISP.png", required=True,
                   help="output 16-bit PNG: disparity of each left pixel, 0 = invalid")
    p.add_argument("--census-window", type=int, default=7, metavar="WC",
                   help="Wc: side of the 50%% sparse census window, odd, 3..11")
    p.add_argument("--hamming-window", type=int, default=29, metavar="WH",
                   help="Wh: side of the sum-of-Hamming-distances window, odd, 1..63")
    p.add_argument("--max-disparity", type=int, default=48, metavar="D",
                   help="D: number of disparities searched (0..D-1), 1..min(256, width)")
    p.add_argument("--lrcc-threshold", type=int, default=8, metavar="TH",
                   help="Th of eq. 21: keep a pixel whose L2R and R2L disparities differ by "
                        "less than TH, 1..D")
    p.add_argument("--no-match-cost", type=int, default=None, metavar="C",
                   help="cost of a window position with no right partner (left band); "
                        "default: a third of the census bits")
    p.add_argument("--prefilter-median", action="store_true",
                   help="apply the camera pipeline's 3x3 median to both images first")
    p.add_argument("--no-disparity-median", action="store_true",
                   help="skip the 3x3 median of the disparity map")
    p.add_argument("--threads", type=int, default=None,
                   help="worker threads for the cost stage (default: CPUs, at most 4)")


def run(args) -> int:
    from sim.images import read_grey, write_png
    from sim.model.stereo import stereo_match

    left = read_grey(args.left)
    right = read_grey(args.right)
    if left.shape != right.shape:
        raise ValueError(f"LEFT is {left.shape[1]}x{left.shape[0]} but RIGHT is "
                         f"{right.shape[1]}x{right.shape[0]}: the pair must have one size")
    start = time.perf_counter()
    result = stereo_match(left, right, census_window=args.census_window,
                          hamming_window=args.hamming_window,
                          max_disparity=args.max_disparity,
                          lrcc_threshold=args.lrcc_threshold,
                          no_match_cost=args.no_match_cost,
                          prefilter_median=args.prefilter_median,
                          disparity_median=not args.no_disparity_median,
                          threads=args.threads)
    seconds = time.perf_counter() - start
    write_png(args.output, result.disparity, bits=16)
    disp = result.disparity
    print(json.dumps({"output": str(args.output), "width": disp.shape[1], "height": disp.shape[0],
                      "pct_invalid": round(100.0 * float((disp == 0).mean()), 3),
                      "seconds": round(seconds, 3)}))
    return 0
