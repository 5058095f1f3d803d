"""Render a synthetic stereo clip of one gesture (--gesture), or of several one
after another (--sequence, with --pause frames of rest between them), with
--distractors non-gesture motion before each gesture (the hand leaves the
picture, scratches the face, reaches to the side, drifts, waves without a
shape, moves across the disparity band); --sequence none --distractors
--frames N renders distractors only.

A person in front of a textured wall performs one of the seven gestures of the
thesis (Fig. 16) with a skin-coloured, textured hand held in front of the chest.
Both cameras are rendered (YCbCr 4:2:2 byte streams, sensor noise, a small
illumination difference) and written as a clip directory: clip.json, left.npy,
right.npy and truth.csv (the exact hand centroid and the hand's posture of
every frame). Gestures are made in the command posture of the shipped
continuous model unless --posture names another (asl0 .. asl9, fist; open,
point, v) or a --sequence entry says NAME@POSTURE; distractors have the hands
people make in them, a share of them the command posture.
"""
from __future__ import annotations

import argparse

from sim.gesture_shapes import GESTURE_NAMES
from stereogest.commands import (DEFAULT_SEED, add_json_switch, add_posture_option,
                                 add_scene_options, parse_sequence, resolve_posture_option,
                                 scene_difficulties)

NAME = "render"
HELP = "render a synthetic stereo clip of one gesture"


def add_arguments(parser: argparse.ArgumentParser) -> None:
    # default=SUPPRESS keeps "(default: None)" out of the help of required options.
    parser.add_argument("--gesture", choices=GESTURE_NAMES, default=None,
                        help="gesture the hand performs (thesis Fig. 16): forward = up and "
                             "back, back = down and back, right = towards the image's left "
                             "edge and back, left = towards its right edge and back, "
                             "rotate-right / rotate-left = a loop on the image's left / "
                             "right side, stop = a downward-pointing triangle")
    add_posture_option(parser)
    parser.add_argument("--sequence", metavar="NAME[@POSTURE][,...]", default=None,
                        help="instead of --gesture: these gestures one after another in "
                             "one clip (the truth names every gesture's frame span), each "
                             "in the posture after its @ (default: --posture's); 'none' "
                             "with --distractors and --frames: no gesture")
    parser.add_argument("--distractors", action="store_true",
                        help="--sequence: non-gesture motion before every gesture, each "
                             "kind as often as the others in a seeded order (the truth "
                             "names their spans too)")
    parser.add_argument("--frames", type=int, default=None, metavar="N",
                        help="--sequence none --distractors: the clip's length in frames "
                             "(1..1000000)")
    parser.add_argument("--pause", metavar="MIN-MAX", default="0-15",
                        help="--sequence: frames of rest between two gestures, drawn from "
                             "the seed (0 = none: the hand flows into the next; default 0-15)")
    parser.add_argument("--seed", type=int, default=DEFAULT_SEED,
                        help="random seed (>= 0): the person and room depend on it, the "
                             "timing, amplitude and start position on it and the gesture")
    parser.add_argument("-o", "--output", required=True, metavar="CLIP",
                        default=argparse.SUPPRESS,
                        help="clip directory to write (replaced if it is already a clip)")
    parser.add_argument("--width", type=int, default=640,
                        help="image width in pixels (even, 96..4096)")
    parser.add_argument("--height", type=int, default=480,
                        help="image height in pixels (even, 64..4096)")
    parser.add_argument("--fps", type=int, default=30,
                        help="frame rate (5..240); the rest and motion durations scale "
                             "with it (15-30 rest and 40-80 motion frames at 30 fps)")
    add_scene_options(parser)
    add_json_switch(parser)


def run(args: argparse.Namespace) -> int:
    # Imported here so that `stereogest --help` stays fast.
    from sim.clip import save_clip
    from sim.render import render_clip
    from stereogest.commands import check_clip_output

    from recognition.streams import check_range
    from sim.render import MAX_SEGMENT_FRAMES, MAX_SEQUENCE_FRAMES, render_sequence
    if (args.gesture is None) == (args.sequence is None):
        raise ValueError("give either --gesture NAME or --sequence NAME[,NAME...]")
    if args.sequence is None and (args.distractors or args.frames is not None):
        raise ValueError("--distractors and --frames go with --sequence")
    posture = resolve_posture_option(args.posture)
    if args.sequence is not None:
        names, postures = parse_sequence(args.sequence, posture)
        if names == ["none"]:
            names = []
            if not args.distractors or args.frames is None:
                raise ValueError("--sequence none needs --distractors and --frames N")
        elif args.frames is not None:
            raise ValueError("--frames goes with --sequence none (a sequence of gestures is "
                             "as long as they are)")
        unknown = [n for n in names if n not in GESTURE_NAMES]
        if unknown or (not names and args.sequence.strip() != "none"):
            raise ValueError(f"--sequence: names must be among {', '.join(GESTURE_NAMES)} "
                             f"(or 'none'), got {args.sequence!r}")
        if args.frames is not None and not 1 <= args.frames <= MAX_SEQUENCE_FRAMES:
            raise ValueError(f"--frames must be in [1, {MAX_SEQUENCE_FRAMES}], got "
                             f"{args.frames}")
        pause = check_range("--pause", args.pause, 0, MAX_SEGMENT_FRAMES)
    difficulties = scene_difficulties(args)
    check_clip_output(args.output)
    if args.sequence is not None:
        clip = render_sequence(names, args.seed, args.width, args.height, pause=pause,
                               fps=args.fps, difficulties=difficulties,
                               distractors=args.distractors, frames=args.frames,
                               postures=postures if names else None)
    else:
        clip = render_clip(args.gesture, args.seed, args.width, args.height, fps=args.fps,
                           difficulties=difficulties, posture=posture)
    path = save_clip(clip, args.output)
    first, last = clip.motion_frames
    what = args.gesture if args.sequence is None else \
        ", ".join(f"{g} {a}-{b}" for g, a, b in clip.sequence) or "no gesture"
    if clip.distractors:
        what += " with distractors " + ", ".join(f"{k} {a}-{b}" for k, a, b in clip.distractors)
    print(f"rendered {what} (seed {args.seed}): {clip.frames} frames of "
          f"{clip.width}x{clip.height}, motion in frames {first}-{last} "
          f"({last - first + 1} frames), written to {path}")
    if args.json:
        import json
        report = {"output": str(path), "gesture": clip.gesture, "seed": args.seed,
                  "frames": clip.frames, "width": clip.width, "height": clip.height,
                  "fps": clip.fps, "motion_frames": [first, last]}
        if clip.sequence is not None:
            report["sequence"] = [{"gesture": g, "motion_frames": [a, b]}
                                  for g, a, b in clip.sequence]
        if clip.distractors is not None:
            report["distractors"] = [{"kind": k, "frames": [a, b]}
                                     for k, a, b in clip.distractors]
        report["postures"] = clip.metadata()["postures"]
        print(json.dumps(report))
    return 0
