"""Which postures should command (issue 42)? Measured on development seeds,
never the benchmark's: for each candidate posture, rendered sessions of the
seven gestures made in it (scene seeds ``--seed`` onwards, 640x480), through
the golden model of the whole pipeline, the shipped posture classifier on
every frame's record and the shipped continuous spotter without posture
commands; and distractors alone (their kinds' hands, none in a command
posture) through the same.

Per posture it reports: the spotter's F1 on the gestures made in it (a hand
shape changes the centroid's path: thin fingers come and go in the mask),
the share of each gesture's frames named that posture, and, at each share
threshold, the gestures that pass the gate and the distractors that would
(their frames named that posture). A good command posture keeps F1, passes
its gestures and no distractor. ``--json`` keeps every figure, and each
gesture's and distractor's count of frames per posture name (to judge a set
of command postures at any share).

Run: ``python benchmarks/command_postures.py [--sessions 2] [--distractor-frames 3000]
[--distractor-clips 1] [--distractor-command POSTURE] [--postures asl1,asl2,...]
[--seed 300] [--json FILE]``.
"""
from __future__ import annotations

import argparse
import json
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
#: Share thresholds reported.
SHARES = (0.3, 0.4, 0.5, 0.6, 0.7)


def _counts(names) -> dict:
    """How many frames each posture name (None: "none") has."""
    out = {}
    for name in names:
        key = name or "none"
        out[key] = out.get(key, 0) + 1
    return out


def spans_named(postures, spans):
    """Per span (first, last), the list of its frames' posture names."""
    return [postures[a:b + 1] for a, b in spans]


def main(argv=None) -> int:
    from sim.gesture_shapes import GESTURE_NAMES
    from sim.hand_postures import POSTURE_NAMES
    from sim.model.pipeline import PipelineParams, run_clip
    from sim.render import render_sequence
    from stereogest.pipeline_outputs import (frame_postures, load_board_models,
                                             load_posture_model, sequence_score,
                                             stream_results)
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--sessions", type=int, default=2)
    ap.add_argument("--distractor-frames", type=int, default=3000,
                    help="frames per clip of distractors alone")
    ap.add_argument("--distractor-clips", type=int, default=1,
                    help="clips of distractors alone (scene seeds --seed + 50 onwards)")
    ap.add_argument("--distractor-command", default=None, metavar="POSTURE",
                    help="make a share of the distractors in this posture, as the "
                         "continuous benchmarks do (default: none)")
    ap.add_argument("--postures", default=",".join(n for n in POSTURE_NAMES if n != "fist"))
    ap.add_argument("--seed", type=int, default=300)
    ap.add_argument("--stop", default="fist", help="the stop posture (runs in distractors)")
    ap.add_argument("--width", type=int, default=640)
    ap.add_argument("--height", type=int, default=480)
    ap.add_argument("--json", default=str(ROOT / "build" / "command_postures.json"))
    args = ap.parse_args(argv)
    from sim.hand_postures import HAND_SHAPE_NAMES
    for option, value, lo, hi in (("--sessions", args.sessions, 0, 100),
                                  ("--distractor-frames", args.distractor_frames, 100, 3000),
                                  ("--distractor-clips", args.distractor_clips, 0, 100)):
        if not lo <= value <= hi:
            ap.error(f"{option} must be in {lo}..{hi}, got {value}")
    if args.distractor_command not in (None, *HAND_SHAPE_NAMES):
        ap.error(f"--distractor-command must be one of {', '.join(HAND_SHAPE_NAMES)}, got "
                 f"{args.distractor_command!r}")
    candidates = [p.strip() for p in args.postures.split(",")]
    import dataclasses
    # the trajectory side alone: the shipped model without its posture commands
    models = dataclasses.replace(load_board_models(None, "continuous"), postures=None)
    posture_model = load_posture_model()
    params = PipelineParams.for_frame(args.width)
    started = time.process_time()

    def through(clip):
        trajectory, _ = run_clip(clip.left, clip.right, params)
        return trajectory, frame_postures(posture_model, trajectory)

    # distractors alone: each one's frames' posture names
    distractors = []
    for k in range(args.distractor_clips):
        clip = render_sequence([], args.seed + 50 + k, args.width, args.height,
                               distractors=True, frames=args.distractor_frames,
                               command=args.distractor_command)
        _, names = through(clip)
        distractors += [(kind, names[a:b + 1]) for kind, a, b in clip.distractors]
    print(f"{len(distractors)} distractors in {args.distractor_clips} x "
          f"{args.distractor_frames} frames", flush=True)
    # the stop posture: the longest run of frames named it in each distractor
    runs = {}
    for kind, span in distractors:
        longest = run = 0
        for n in span:
            run = run + 1 if n == args.stop else 0
            longest = max(longest, run)
        runs.setdefault(kind, []).append(longest)
    print(f"{args.stop} in a row in the distractors, longest per kind: "
          + ", ".join(f"{k} {max(v)}" for k, v in runs.items()) + "; every distractor's: "
          + ", ".join(f"{k} {sorted(v)}" for k, v in runs.items()), flush=True)
    rows = {}
    for posture in (candidates if args.sessions else []):
        totals = dict(true=0, named=0, correct=0)
        held, counts = [], []
        for k in range(args.sessions):
            seed = args.seed + k
            rng = np.random.default_rng(seed)
            gestures = [str(g) for g in rng.permutation(GESTURE_NAMES)]
            clip = render_sequence(gestures, seed, args.width, args.height,
                                   postures=[posture] * len(gestures), command=None)
            trajectory, names = through(clip)
            score = sequence_score(stream_results(models, trajectory, args.width),
                                   clip.sequence)
            for key in totals:
                totals[key] += score[key]
            spans = spans_named(names, [(a, b) for _, a, b in clip.sequence])
            held += [float(np.mean([n == posture for n in span])) for span in spans]
            counts += [_counts(span) for span in spans]
        f1 = 2 * totals["correct"] / max(1, totals["true"] + totals["named"])
        false_share = [float(np.mean([n == posture for n in span])) for _, span in distractors]
        rows[posture] = {
            "f1": round(f1, 4), **totals, "held_median": round(float(np.median(held)), 3),
            "held": [round(h, 3) for h in held],
            "gestures_passing": {str(s): round(float(np.mean([h >= s for h in held])), 3)
                                 for s in SHARES},
            "distractors_passing": {str(s): round(float(np.mean([h >= s for h in false_share])),
                                                  3) for s in SHARES},
            "distractor_frames_named": round(float(np.mean(
                [n == posture for _, span in distractors for n in span])), 4),
            "gesture_counts": counts}
        r = rows[posture]
        print(f"{posture}: F1 {100 * f1:.1f} %, held median {r['held_median']:.2f}; passing at "
              + ", ".join(f"{s}: gestures {r['gestures_passing'][str(s)]:.2f} distractors "
                          f"{r['distractors_passing'][str(s)]:.2f}" for s in SHARES),
              flush=True)
    report = {"seed": args.seed, "sessions": args.sessions, "width": args.width,
              "distractor_frames": args.distractor_frames,
              "distractor_clips": args.distractor_clips,
              "distractor_command": args.distractor_command,
              "distractor_kinds": [k for k, _ in distractors], "postures": rows,
              "stop_runs_in_distractors": runs,
              "distractor_counts": [[kind, _counts(span)] for kind, span in distractors],
              "cpu_s": round(time.process_time() - started, 1)}
    Path(args.json).parent.mkdir(parents=True, exist_ok=True)
    Path(args.json).write_text(json.dumps(report, indent=1) + "\n")
    print(f"{report['cpu_s']} CPU s")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
