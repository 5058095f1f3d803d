"""Recognition accuracy figures of the README (issue: recognition, section 6).

1. The synthetic corpus of the seven thesis gestures (``stereogest gestures``,
   180 per class, 3 people, seed 1): 10-fold cross-validation with the thesis
   configuration (camera front end, 5 states, no emission floor) and a few
   state counts.
2. The $1 unistroke logs (data/gestures/dollar1_unistroke, 16 gestures, 7
   subjects): leave-one-subject-out accuracy of the same recogniser, pen front
   end (``--resample``), and what the emission floor, the resampling and the
   number of states are worth.

Run: ``python benchmarks/recognition_accuracy.py [--quick]``. Prints Markdown
tables and a final JSON line.
"""
from __future__ import annotations

import argparse
import json
import time
from pathlib import Path

from recognition.corpus import synthetic_corpus
from recognition.crossval import cross_validate
from recognition.datasets import load_trajectories
from recognition.features import sequences

ROOT = Path(__file__).resolve().parent.parent
DOLLAR = ROOT / "data" / "gestures" / "dollar1_unistroke" / "dollar1_unistroke.npz"


def synthetic(states, folds=10):
    data = synthetic_corpus(per_class=180, people=3, seed=1)
    seqs = sequences(data)
    start = time.perf_counter()
    result = cross_validate(seqs, data.label, states, folds=folds, seed=0)
    return result, time.perf_counter() - start


def dollar(states, resample, floor):
    data = load_trajectories(DOLLAR)
    seqs = sequences(data, resample=resample)
    start = time.perf_counter()
    result = cross_validate(seqs, data.label, states, groups=data.subject,
                            emission_floor=floor)
    return result, time.perf_counter() - start


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--quick", action="store_true", help="fewer variants")
    args = parser.parse_args(argv)
    figures = {}

    states = [5] if args.quick else [3, 5, 8]
    result, seconds = synthetic(states)
    print("Synthetic corpus, 7 gestures x 180, 3 people, 10-fold CV (camera front end, "
          "no emission floor):\n")
    print("| states | accuracy |\n|---|---|")
    for n, acc in zip(result.state_counts, result.accuracy):
        print(f"| {n} | {100 * acc:.2f} % |")
    print(f"\n({seconds:.0f} s)\n")
    figures["synthetic"] = {str(n): round(100 * a, 2)
                            for n, a in zip(result.state_counts, result.accuracy)}

    variants = [(8, 64, 0.0), (8, 64, 1e-3)] if args.quick else [
        (5, 64, 0.0), (8, 64, 0.0), (8, 64, 1e-3), (12, 64, 1e-3), (8, 32, 1e-3)]
    print("$1 unistroke logs, 16 gestures, leave-one-subject-out (7 subjects), pen front end:\n")
    print("| states | resample | emission floor | accuracy |\n|---|---|---|---|")
    figures["dollar"] = []
    for n, resample, floor in variants:
        result, seconds = dollar([n], resample, floor)
        acc = 100 * result.accuracy[0]
        print(f"| {n} | {resample} | {floor:g} | {acc:.2f} % |", flush=True)
        figures["dollar"].append({"states": n, "resample": resample, "floor": floor,
                                  "accuracy": round(acc, 2), "seconds": round(seconds, 1)})
    print(json.dumps(figures))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
