"""Continuous recognition on people the models never saw (issue 28): each
subject's gestures joined into streams (transit movements between them,
pauses of 0-15 frames), spotted by :class:`sw_hps.continuous.ContinuousRecogniser`
with models trained on the other subjects, leave one subject out
(:func:`recognition.continuous.leave_one_subject_out`; the threshold bias
calibrated on the training subjects only). Also the recogniser's cost per
frame on this machine (CPU microseconds).

``--data dollar`` (default): the $1 unistroke logs (real people, pen front
end, 12 states, 6 px). ``--data corpus``: the synthetic camera corpus
(:func:`recognition.corpus.synthetic_corpus`, 6 people, 40 gestures per class,
``--seed`` 23: people not used to choose the board's defaults, which were
chosen on ``--seed 11``, the development corpus), through the FPGA's centroid
smoothing, with the board's defaults (``stereogest train --continuous``: 8
states, 20 px).

``--distractors`` puts non-gesture motion (:mod:`sim.distractors`, scaled to
each person's gestures) before every gesture, in the held-out streams and in
the calibration's; ``--idle-steps N`` spots N steps of distractors alone per
held-out subject (every command there is false). The spotting's ``max_gap``
and ``max_gap_share`` are learned per fold from the training subjects'
gestures (:func:`recognition.continuous.symbol_gap`, :func:`~recognition.
continuous.symbol_gap_share`). Every held-out stream starts the recogniser
afresh, and a frame whose hand is out of view (an ``out-of-view``
distractor below the picture) flushes it, as on the board.

Run: ``python benchmarks/continuous_recognition.py [--data dollar|corpus]
[--subjects 2,3,4] [--states N] [--step PX] [--distractors] [--idle-steps N]
[--seed 23] [--json FILE]``. Prints the figures; the $1 set takes tens of CPU minutes,
the corpus a few.
"""
from __future__ import annotations

import argparse
import json
import time
from pathlib import Path

import numpy as np

from recognition.continuous import (distance_sequences, leave_one_subject_out, spot_stream,
                                    stream_pixels)
from recognition.datasets import load_trajectories
from recognition.hmm_train import train_models
from recognition.streams import subject_streams
from sw_hps.continuous import ContinuousRecogniser
from sw_hps.orientation import DistanceSymbols

ROOT = Path(__file__).resolve().parents[1]
DOLLAR = ROOT / "data" / "gestures" / "dollar1_unistroke" / "dollar1_unistroke.npz"


def cost_per_frame(data, states: int, step: int, front_end: str) -> dict:
    """CPU microseconds per frame and per symbol of the recogniser (its
    models trained on every subject: the cost does not depend on the fit)."""
    models = train_models(distance_sequences(data, step, front_end), data.label,
                          data.class_names, states, emission_floor=1e-3)
    rec = ContinuousRecogniser(models)
    streams = subject_streams(data, 8, 0)[:20]
    frames = sum(len(s) for s in streams)
    pixels = [stream_pixels(s.points, front_end) for s in streams]
    symbols = sum(len(DistanceSymbols(step).symbols(p)) for p in pixels)
    start = time.process_time()
    for s in streams:
        spot_stream(rec, s.points, step, front_end)
    cpu = time.process_time() - start
    return {"frames": frames, "symbols": symbols, "cpu_s": round(cpu, 3),
            "us_per_frame": round(1e6 * cpu / frames, 1),
            "us_per_symbol": round(1e6 * cpu / symbols, 1),
            "states": int(sum(m.num_states for m in models.models))}


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--data", choices=("dollar", "corpus"), default="dollar",
                    help="$1 logs (real people) or the synthetic camera corpus")
    ap.add_argument("--subjects", default=None,
                    help="comma-separated subjects to use (default: all)")
    ap.add_argument("--states", type=int, default=None,
                    help="states per class model (default 12 $1, 8 corpus)")
    ap.add_argument("--step", type=int, default=None,
                    help="pixels of travel per symbol (default 6 $1, 20 corpus)")
    ap.add_argument("--distractors", action="store_true",
                    help="non-gesture motion (sim.distractors) before every gesture")
    ap.add_argument("--idle-steps", type=int, default=0,
                    help="per held-out subject, this many steps of distractors alone "
                         "(18000 = 10 minutes at 30 fps)")
    ap.add_argument("--seed", type=int, default=23,
                    help="--data corpus: the corpus' seed (23 = test people; 11 = the "
                         "development corpus the defaults were chosen on)")
    ap.add_argument("--json", default=None,
                    help="report (default build/continuous_recognition_<data>.json)")
    args = ap.parse_args(argv)
    from recognition.hmm_train import MAX_STATES
    corpus = args.data == "corpus"
    states = args.states if args.states is not None else (8 if corpus else 12)
    step = args.step if args.step is not None else (20 if corpus else 6)
    front_end = "camera" if corpus else "pen"
    if not 1 <= states <= MAX_STATES:
        ap.error(f"--states must be in 1..{MAX_STATES}, got {states}")
    if not 1 <= step <= 1000:
        ap.error(f"--step must be in 1..1000 pixels, got {step}")
    if not 0 <= args.seed <= 2 ** 32 - 1:
        ap.error(f"--seed must be in 0..{2 ** 32 - 1}, got {args.seed}")
    if not 0 <= args.idle_steps <= 10_000_000:
        ap.error(f"--idle-steps must be in 0..10000000, got {args.idle_steps}")
    args.states, args.step = states, step
    if corpus:
        from recognition.corpus import synthetic_corpus
        data = synthetic_corpus(per_class=40, people=6, seed=args.seed)
    else:
        data = load_trajectories(DOLLAR)
    if args.subjects:
        try:
            chosen = [int(s) for s in args.subjects.split(",")]
        except ValueError:
            ap.error(f"--subjects must be comma-separated integers, got {args.subjects!r}")
        unknown = sorted(set(chosen) - set(np.unique(data.subject).tolist()))
        if unknown or len(chosen) < 3:
            ap.error(f"--subjects must name at least 3 of {np.unique(data.subject).tolist()}, "
                     f"got {args.subjects!r}")
        data = data.subset(np.flatnonzero(np.isin(data.subject, chosen)))
    start = time.process_time()
    report = leave_one_subject_out(data, states=args.states, step=args.step,
                                   front_end=front_end, distractors=args.distractors,
                                   idle_steps=args.idle_steps)
    report["cpu_s"] = round(time.process_time() - start, 1)
    report["cost"] = cost_per_frame(data, args.states, args.step, front_end)
    out = Path(args.json or ROOT / "build" / f"continuous_recognition_{args.data}.json")
    out.parent.mkdir(parents=True, exist_ok=True)
    out.write_text(json.dumps(report, indent=1) + "\n")
    o = report["overall"]
    what = f"synthetic camera corpus (seed {args.seed})" if corpus else "$1"
    what += ", distractors before every gesture" if args.distractors else ""
    print(f"{what} streams, leave one subject out ({len(report['per_subject'])} subjects, "
          f"{o['gestures']} gestures, {args.states} states, step {args.step} px):")
    print(f"  F1 {100 * o['f1']:.2f} %  precision {100 * o['precision']:.2f} %  "
          f"recall {100 * o['recall']:.2f} %")
    print(f"  false commands {o['false_commands']} ({o['false_commands_per_10_min']:.1f} per 10 "
          f"minutes of the {o['between_gesture_frames']} frames between gestures at 30 fps)")
    print(f"  latency from a gesture's end to its name: median "
          f"{o['latency_median_frames']} frames, 95th percentile {o['latency_p95_frames']}")
    if report["idle"]:
        i = report["idle"]
        print(f"  distractors only: {i['false_commands']} commands in {i['frames']} frames "
              f"({i['minutes']} minutes at 30 fps): {i['false_commands_per_10_min']:.2f} per "
              f"10 minutes; each kind alone, {i['frames'] // 6} frames each: "
              f"{i['kind_alone']}")
    for subject, s in report["per_subject"].items():
        print(f"  subject {subject}: F1 {100 * s['f1']:.2f} %, bias {s['threshold_bias']}")
    c = report["cost"]
    print(f"  cost: {c['us_per_frame']} CPU-us per frame, {c['us_per_symbol']} per symbol "
          f"({c['states']} states); {report['cpu_s']} CPU-s for the cross-validation")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
