"""Make a clip from your own footage: two video files, two image sequences (a
folder or a glob pattern) or two webcams (camera indices, read through OpenCV).
Frames are resized and converted to the cameras' YCbCr 4:2:2 byte stream
(full-range ITU-R BT.601, as OpenCV's COLOR_BGR2YCrCb) and written as a clip
directory without truth, which 'stereogest pipeline' and 'stereogest demo
--clip' run. The two sources must be a stereo pair: the left and the right
camera, side by side and looking the same way, rows aligned."""
from __future__ import annotations

import argparse
import sys

from sim.gesture_shapes import GESTURE_NAMES

from stereogest.commands import add_camera_options, add_json_switch

NAME = "clip"
HELP = "make a clip from two video files, image sequences or webcams"


def add_arguments(p: argparse.ArgumentParser) -> None:
    add_camera_options(p, required=True)
    p.add_argument("-o", "--output", required=True, metavar="CLIP", default=argparse.SUPPRESS,
                   help="clip directory to write (replaced if it is already a clip)")
    p.add_argument("--width", type=int, default=640, help="clip width in pixels (even, 96..4096)")
    p.add_argument("--height", type=int, default=480, help="clip height in pixels (64..4096)")
    p.add_argument("--fps", type=int, default=None,
                   help="frame rate, 1..1000 (default: the left video's, else 30)")
    p.add_argument("--frames", type=int, default=None,
                   help="frame pairs to keep, 1..1800 (default: until a source ends; "
                        "required with cameras)")
    p.add_argument("--gesture", choices=GESTURE_NAMES, default=None,
                   help="label the clip with the gesture it shows (optional)")
    add_json_switch(p)
    p.add_argument("--quiet", action="store_true", help="no progress lines on stderr")


def run(args) -> int:
    import json

    from sim.clip import save_clip
    from sim.footage import footage_clip
    from stereogest.commands import check_clip_output

    check_clip_output(args.output)

    def progress(done: int) -> None:
        if not args.quiet and done % 25 == 0:
            print(f"  {done} frame pairs", file=sys.stderr, flush=True)

    clip = footage_clip(args.left, args.right, width=args.width, height=args.height,
                        fps=args.fps, frames=args.frames, gesture=args.gesture,
                        progress=progress)
    path = save_clip(clip, args.output)
    print(f"{clip.frames} frame pairs of {clip.width}x{clip.height} at {clip.fps} frames/s "
          f"from {clip.source['left']} and {clip.source['right']}, written to {path}")
    if args.json:
        print(json.dumps({"clip": str(path), "frames": clip.frames, "width": clip.width,
                          "height": clip.height, "fps": clip.fps, "gesture": clip.gesture}))
    return 0
