"""Compute the disparity map of a rectified stereo pair (sparse census, SHD,
best-of selectors, left-right check, median: thesis §6.2) and write it as a
16-bit PNG whose value is the disparity in pixels (0 = invalid). The golden
model computes it by default; --backend amaranth or verilator runs the
hardware (hdl/stereo_matcher.py) in a simulator instead and writes the same
PNG. With --calibration an unrectified pair is rectified first (the golden
model of the rectification stage, hdl/rectify.py)."""
from __future__ import annotations

import json
import time
from pathlib import Path

from stereogest.commands import add_calibration_options, add_json_switch

NAME = "stereo"
BACKENDS = ("model", "amaranth", "verilator")
#: The Amaranth simulator runs a few thousand cycles per second.
AMARANTH_MAX_PIXELS = 16384
HELP = "disparity map of a stereo pair (16-bit PNG, 0 = invalid)"


def add_arguments(p):
    p.add_argument("left", metavar="LEFT", help="left image (PNG; colour is converted to BT.601 luma)")
    p.add_argument("right", metavar="RIGHT", help="right image, same size as LEFT")
    p.add_argument("-o", "--output", metavar="DISP.png", required=True,
                   help="output 16-bit PNG: disparity of each left pixel, 0 = invalid "
                        "(it looks black in an image viewer: see DISP_colour.png beside it, "
                        "colour-mapped with a colour bar in pixels of disparity)")
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
                   help="worker threads for the cost stage (default: CPUs, at most 4; "
                        "model backend only)")
    p.add_argument("--backend", choices=BACKENDS, default="model",
                   help="model: the numpy golden model; amaranth: the hardware in the "
                        "Amaranth simulator (small images only, at most "
                        f"{AMARANTH_MAX_PIXELS} pixels); verilator: the emitted Verilog "
                        "under Verilator (first use of a parameter set builds it, cached "
                        "under build/verilator/)")
    add_calibration_options(p)
    add_json_switch(p, always=True)


def run(args) -> int:
    from sim.images import read_grey, write_png
    from sim.model.stereo import check_stereo_params, stereo_match
    from stereogest.commands import check_output_file, load_rectification

    check_output_file(args.output)
    check_output_file(preview_path(args.output), "--output (its preview)")
    left = read_grey(args.left)
    right = read_grey(args.right)
    if left.shape != right.shape:
        raise ValueError(f"LEFT is {left.shape[1]}x{left.shape[0]} but RIGHT is "
                         f"{right.shape[1]}x{right.shape[0]}: the pair must have one size")
    backend = getattr(args, "backend", "model")
    matcher = dict(census_window=args.census_window, hamming_window=args.hamming_window,
                   max_disparity=args.max_disparity, lrcc_threshold=args.lrcc_threshold,
                   no_match_cost=args.no_match_cost)
    check_stereo_params(left.shape[1], left.shape[0], **matcher)     # before any work
    rectification = load_rectification(args, left.shape[1], left.shape[0])
    start = time.perf_counter()
    if rectification is not None:
        from sim.model.rectify import rectify_pair
        (left,), (right,) = rectify_pair((left,), (right,), rectification)
    if backend == "model":
        result = stereo_match(left, right, **matcher, prefilter_median=args.prefilter_median,
                              disparity_median=not args.no_disparity_median,
                              threads=args.threads)
        disp, extra = result.disparity, {}
    else:
        disp, extra = _run_hardware(backend, left, right, matcher, args)
    seconds = time.perf_counter() - start
    from sim.pictures import disparity_preview
    preview = preview_path(args.output)
    write_png(args.output, disp, bits=16)
    write_png(preview, disparity_preview(disp, args.max_disparity), bits=8)
    report = {"output": str(args.output), "preview": str(preview),
              "width": disp.shape[1], "height": disp.shape[0],
              "pct_invalid": round(100.0 * float((disp == 0).mean()), 3),
              "seconds": round(seconds, 3)}
    if backend != "model":
        report.update(backend=backend, **extra)
    print(json.dumps(report))
    return 0


def preview_path(output) -> Path:
    """The colour-mapped preview written beside the 16-bit map: DISP_colour.png."""
    output = Path(output)
    return output.with_name(f"{output.stem}_colour.png")


def _run_hardware(backend, left, right, matcher, args):
    """Disparity map from hdl.stereo_matcher.StereoMatcher in a simulator
    (``matcher``: the checked parameters; Th is a run-time register there)."""
    import numpy as np

    from sim.model.median import median3x3

    h, w = left.shape
    if args.prefilter_median:
        # The input median belongs to the camera pipeline, ahead of the matcher.
        left, right = median3x3(left), median3x3(right)
    params = dict(matcher, disparity_median=not args.no_disparity_median)
    threshold = params.pop("lrcc_threshold")
    if backend == "verilator":
        from verif.stereo import run_matcher
        try:
            maps, stats = run_matcher([(left, right)], threshold=threshold, **params)
        except (RuntimeError, OSError) as exc:
            # a failed build or run: one line, not a traceback (the CLI reports ValueError)
            raise ValueError(f"--backend verilator failed: {str(exc).splitlines()[0]}") from exc
        return maps[0].astype(np.uint8), {"cycles": stats["cycles"],
                                          "cycles_per_second": round(stats["cycles_per_second"])}
    if w * h > AMARANTH_MAX_PIXELS:
        raise ValueError(f"--backend amaranth takes images of at most {AMARANTH_MAX_PIXELS} "
                         f"pixels, got {w}x{h}: use --backend verilator")
    from verif.streams import field, pack, run_stream
    from hdl.stereo_matcher import StereoMatcher
    dut = StereoMatcher(w, h, **params)
    layout = dut.i_stream.payload.shape()
    beats = [pack(layout, {"left": a, "right": b}) for a, b in zip(left.ravel(), right.ravel())]
    cycles = []
    out = run_stream(dut, beats, use_ready=True, extra_cycles=dut.latency + 16,
                     setup=lambda ctx: ctx.set(dut.threshold, threshold),
                     out_cycles=cycles)
    disp = field(dut.o_stream.payload.shape(), out, "disparity").reshape(h, w)
    return disp.astype(np.uint8), {"cycles": cycles[-1] + 1}
