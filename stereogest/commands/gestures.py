"""Write a synthetic corpus of hand-centroid trajectories for the seven gestures.

Every trajectory is the per-frame hand centroid in pixels that the FPGA would
track while a person performs one of the thesis gestures (Fig. 16): a rest in
front of the chest (15-30 frames at 30 fps), 40-80 frames of motion and a rest
again, with each person's own amplitude, aspect, speed and rest position,
tremor, segmentation jitter, fingers cut by the opening and dropped frames.
The file is a trajectory .npz (points, offsets, label = gesture name, subject =
person) plus the ground truth: motion (first and last motion frame of each
trajectory), amplitude, dropped, fps and image_size.

With ``--join DATA.npz`` it writes continuous streams instead: each
person's gestures of a trajectory dataset (the `$1` logs, pendigits, a corpus
written by this command) in a random order, ``--per-stream`` to a stream,
joined by a pause (``--pause MIN-MAX`` steps, the hand still) and a
minimum-jerk transit to the next gesture's start, with every gesture's span
and label (:mod:`recognition.streams`); ``--distractors`` puts non-gesture
motion (:mod:`sim.distractors`, scaled to the person's gestures) and another
pause before every gesture.
"""
from __future__ import annotations

import argparse
import json

from stereogest.commands import DEFAULT_SEED, add_json_switch, check_output_file

NAME = "gestures"
HELP = "write a synthetic corpus of gesture trajectories (hand centroids per frame)"


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("-o", "--output", required=True, metavar="CORPUS.npz",
                        default=argparse.SUPPRESS,
                        help="trajectory file to write (replaced if it exists)")
    parser.add_argument("--per-class", type=int, default=180, metavar="N",
                        help="trajectories per gesture (1..100000); the people take turns")
    parser.add_argument("--people", type=int, default=3, metavar="P",
                        help="number of people, each with their own style (1..1000)")
    parser.add_argument("--seed", type=int, default=DEFAULT_SEED, metavar="S",
                        help="random seed (>= 0); the same arguments give the same file")
    parser.add_argument("--width", type=int, default=640,
                        help="image width in pixels (96..4096)")
    parser.add_argument("--height", type=int, default=480,
                        help="image height in pixels (64..4096)")
    parser.add_argument("--fps", type=int, default=30,
                        help="frame rate (5..240); the durations scale with it (15-30 rest "
                             "and 40-80 motion frames at 30 fps)")
    parser.add_argument("--join", metavar="DATA.npz", default=None,
                        help="join the gestures of this trajectory dataset (with subjects or "
                             "writers) into continuous streams per person and write those")
    parser.add_argument("--per-stream", type=int, default=8, metavar="N",
                        help="with --join: gestures per stream (1..10000)")
    parser.add_argument("--pause", default="0-15", metavar="MIN-MAX",
                        help="with --join: steps the hand rests between two gestures, "
                             "uniform in MIN..MAX (0..10000; 0 = it flows on)")
    parser.add_argument("--distractors", action="store_true",
                        help="with --join: non-gesture motion (out of view and back, a face "
                             "scratch, a reach, a drift, a shapeless wave, a move in depth) "
                             "before every gesture")
    add_json_switch(parser)


def _join(args, output) -> int:
    from recognition.datasets import load_trajectories
    from recognition.streams import PAUSE_RANGE, check_range, save_streams, subject_streams
    # (a library message naming pause or per_stream is named as its option by
    # stereogest.cli.in_option_names)
    pause = check_range("pause", args.pause, *PAUSE_RANGE)
    data = load_trajectories(args.join)
    if data.subject is None:
        raise ValueError(f"--join: {args.join} has no subject (or writer) key: streams are "
                         f"per person")
    streams = subject_streams(data, args.per_stream, args.seed, pause=pause,
                              distractors=args.distractors)
    save_streams(streams, output)
    gestures = sum(len(s.spans) for s in streams)
    steps = sum(len(s) for s in streams)
    print(f"wrote {len(streams)} streams of {gestures} gestures ({steps} steps, pauses "
          f"{pause[0]}-{pause[1]}{', distractors' if args.distractors else ''}, seed "
          f"{args.seed}) from {args.join} -> {output}")
    if args.json:
        import json
        print(json.dumps({"output": str(output), "streams": len(streams),
                          "gestures": gestures, "steps": steps, "pause": list(pause),
                          "distractors": args.distractors, "seed": args.seed}))
    return 0


def run(args: argparse.Namespace) -> int:
    # Imported here so that `stereogest --help` stays fast.
    import numpy as np

    from recognition.corpus import generate_corpus
    from recognition.datasets import save_trajectories
    from sim.gesture_shapes import GESTURE_NAMES

    output = check_output_file(args.output)
    if args.join is not None:
        return _join(args, output)
    if args.distractors:
        raise ValueError("--distractors goes with --join DATA.npz")
    # (a parameter named in the library's message is named as its option by
    # stereogest.cli.in_option_names)
    corpus = generate_corpus(args.per_class, args.people, args.seed, args.width,
                             args.height, args.fps)
    data = corpus.data
    save_trajectories(data, output, motion=corpus.motion, amplitude=corpus.amplitude,
                      dropped=corpus.dropped, fps=np.int64(args.fps),
                      image_size=np.array([args.width, args.height], np.int64))
    lengths = np.diff(data.offsets)
    motion = corpus.motion[:, 1] - corpus.motion[:, 0] + 1
    print(f"wrote {len(data)} trajectories ({len(GESTURE_NAMES)} gestures x {args.per_class}, "
          f"{args.people} people, seed {args.seed}, {args.width}x{args.height} at "
          f"{args.fps} fps): {lengths.min()}-{lengths.max()} frames, motion "
          f"{motion.min()}-{motion.max()} frames, {int(corpus.dropped.sum())} frames dropped "
          f"-> {output}")
    if args.json:
        print(json.dumps({"output": str(output), "trajectories": len(data),
                          "per_class": args.per_class, "people": args.people,
                          "seed": args.seed, "frames": [int(lengths.min()),
                                                        int(lengths.max())]}))
    return 0
