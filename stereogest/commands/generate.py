"""Write the Quartus project and the Platform Designer pieces of the recogniser
for the DE1-SoC into DIR: the board top's Verilog, the .qsf (device
5CSEMA5F31C6 and every pin), the .sdc (every clock), the core's Verilog, its
_hw.tcl component, the qsys-script that builds the HPS system (the core's
slaves on the lightweight HPS-to-FPGA bridge at 0x000, 0x100 and 0x200), the Quartus
flow script and a README with the steps. DIR must be new, empty, or a bundle
written before (it is replaced as a whole). Quartus itself is not needed. With
--calibration the pipeline rectifies both cameras with its maps; with
--hand-tracking its centroid tracks the hand; --vga-scale sets the VGA debug
view's resolution; --scl-khz lowers the cameras' I2C clock (for camera modules
without their own pull-ups)."""
from __future__ import annotations

import json
import sys

from stereogest.commands import (add_calibration_options, add_hand_tracking_option,
                                 add_json_switch, add_vga_scale_option, frame_size_help)

NAME = "generate"
HELP = "write the Quartus / Platform Designer bundle for the DE1-SoC"


def add_arguments(p):
    p.add_argument("-o", "--output", "--out", dest="out_dir", metavar="DIR", required=True,
                   help="bundle directory (new, empty or a previous bundle); --out is the "
                        "older spelling")
    frame_size_help(p)
    p.add_argument("--quiet", action="store_true", help="no progress lines on stderr")
    add_calibration_options(p)
    add_hand_tracking_option(p)
    add_vga_scale_option(p)
    p.add_argument("--scl-khz", type=float, default=400.0, metavar="KHZ",
                   help="highest SCL frequency of the cameras' I2C, in (0, 400] kHz "
                        "(default 400, fast mode; 100 for modules without pull-ups)")
    add_json_switch(p, always=True)


def run(args) -> int:
    from soc.generate import check_out_dir, generate
    from stereogest.commands import check_output_dir, load_rectification, vga_scale_of

    vga_scale = vga_scale_of(args)
    if not 0 < args.scl_khz <= 400:
        raise ValueError(f"--scl-khz must be in (0, 400] kHz, got {args.scl_khz:g}")
    check_out_dir(args.out_dir)
    check_output_dir(args.out_dir)
    rectification = load_rectification(args, args.width, args.height)

    def progress(message):
        if not args.quiet:
            print(message, file=sys.stderr, flush=True)

    info = generate(args.out_dir, args.width, args.height, rectification=rectification,
                    hand_tracking=args.hand_tracking, vga_scale=vga_scale,
                    scl_hz=args.scl_khz * 1e3, progress=progress)
    print(f"wrote {len(info.files)} files to {info.out_dir} in {info.seconds:.1f} s; "
          f"next: see {info.out_dir}/README.md (or run quartus_build.sh there)")
    print(json.dumps({"out": str(info.out_dir), "files": list(info.files),
                      "seconds": round(info.seconds, 1)}))
    return 0
