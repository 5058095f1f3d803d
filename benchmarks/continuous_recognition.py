"""Continuous recognition on real people (issue 28): the $1 unistroke logs'
gestures of each subject joined into streams (transit movements between them,
pauses of 0-15 steps), spotted by :class:`sw_hps.continuous.ContinuousRecogniser`
with models trained on the other subjects, leave one subject out
(:func:`recognition.continuous.leave_one_subject_out`; the threshold bias
calibrated on the training subjects only). Also the recogniser's cost per
frame on this machine (CPU microseconds).

Run: ``python benchmarks/continuous_recognition.py [--subjects 2,3,4]
[--states 12] [--step 6] [--json FILE]``. Prints the figures; the whole set
takes tens of CPU minutes.
"""
from __future__ import annotations

import argparse
import json
import time
from pathlib import Path

import numpy as np

from recognition.continuous import leave_one_subject_out, spot_stream
from recognition.datasets import load_trajectories
from recognition.hmm_train import train_models
from recognition.streams import subject_streams
from sw_hps.continuous import ContinuousRecogniser
from sw_hps.orientation import DistanceSymbols

ROOT = Path(__file__).resolve().parents[1]
DOLLAR = ROOT / "data" / "gestures" / "dollar1_unistroke" / "dollar1_unistroke.npz"


def cost_per_frame(data, states: int, step: int) -> dict:
    """CPU microseconds per frame and per symbol of the recogniser (its
    models trained on every subject: the cost does not depend on the fit)."""
    sequences = [DistanceSymbols(step).symbols(np.rint(t).astype(np.int64))
                 for t in data.trajectories()]
    models = train_models(sequences, data.label, data.class_names, states,
                          emission_floor=1e-3)
    rec = ContinuousRecogniser(models)
    streams = subject_streams(data, 8, 0)[:20]
    frames = sum(len(s) for s in streams)
    symbols = sum(len(DistanceSymbols(step).symbols(np.rint(s.points).astype(np.int64)))
                  for s in streams)
    start = time.process_time()
    for s in streams:
        spot_stream(rec, s.points, step)
    cpu = time.process_time() - start
    return {"frames": frames, "symbols": symbols, "cpu_s": round(cpu, 3),
            "us_per_frame": round(1e6 * cpu / frames, 1),
            "us_per_symbol": round(1e6 * cpu / symbols, 1),
            "states": int(sum(m.num_states for m in models.models))}


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--subjects", default=None,
                    help="comma-separated subjects to use (default: all seven)")
    ap.add_argument("--states", type=int, default=12, help="states per class model")
    ap.add_argument("--step", type=int, default=6, help="pixels of travel per symbol")
    ap.add_argument("--json", default=str(ROOT / "build" / "continuous_recognition.json"))
    args = ap.parse_args(argv)
    from recognition.hmm_train import MAX_STATES
    if not 1 <= args.states <= MAX_STATES:
        ap.error(f"--states must be in 1..{MAX_STATES}, got {args.states}")
    if not 1 <= args.step <= 1000:
        ap.error(f"--step must be in 1..1000 pixels, got {args.step}")
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
    report = leave_one_subject_out(data, states=args.states, step=args.step)
    report["cpu_s"] = round(time.process_time() - start, 1)
    report["cost"] = cost_per_frame(data, args.states, args.step)
    Path(args.json).parent.mkdir(parents=True, exist_ok=True)
    Path(args.json).write_text(json.dumps(report, indent=1) + "\n")
    o = report["overall"]
    print(f"$1 streams, leave one subject out ({len(report['per_subject'])} subjects, "
          f"{o['gestures']} gestures, {args.states} states, step {args.step} px):")
    print(f"  F1 {100 * o['f1']:.2f} %  precision {100 * o['precision']:.2f} %  "
          f"recall {100 * o['recall']:.2f} %")
    print(f"  false commands {o['false_commands']} ({o['false_commands_per_10_min']:.1f} per 10 "
          f"minutes of the {o['between_gesture_frames']} frames between gestures at 30 fps)")
    print(f"  latency from a gesture's end to its name: median "
          f"{o['latency_median_frames']} frames, 95th percentile {o['latency_p95_frames']}")
    for subject, s in report["per_subject"].items():
        print(f"  subject {subject}: F1 {100 * s['f1']:.2f} %, bias {s['threshold_bias']}")
    c = report["cost"]
    print(f"  cost: {c['us_per_frame']} CPU-us per frame, {c['us_per_symbol']} per symbol "
          f"({c['states']} states); {report['cpu_s']} CPU-s for the cross-validation")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
