"""How far per-class likelihood rejection can go on the $1 open-set protocol.

The shipped rejection (``recognition.recogniser``) calibrates its thresholds
on the training subjects.  This benchmark asks what the same statistic
could do at best: the thresholds are chosen on the *test* subjects
themselves (an oracle no deployed recogniser has), each class' threshold
at the quantile that refuses ``--refuse-in`` of its own gestures.  It also
runs the two-class likelihood-ratio test on the near-twin pairs (the test
that knows the unseen class, which by the Neyman-Pearson lemma no one-class
rule beats at the same refusal of the accepted class).

Protocol as ``recognition.evaluation.open_set_rejection``: 12 gestures
trained, the other 4 presented as non-gestures, rotated; subjects dealt to
3 groups, each held out in turn.

Run: ``python benchmarks/open_set_ceiling.py`` (about 2 CPU-minutes).
"""
from __future__ import annotations

import argparse
import sys
import time
from dataclasses import replace
from pathlib import Path

import numpy as np

from recognition.datasets import load_trajectories
from recognition.evaluation import class_rotations
from recognition.recogniser import Recogniser, fold_of_groups

sys.path.insert(0, str(Path(__file__).resolve().parent))
from recognition_accuracy import DOLLAR  # noqa: E402  (benchmarks/ is not a package)

#: Near-twin pairs of the $1 set: (accepted class, unseen class).
PAIRS = (("check", "v"), ("v", "check"), ("left_curly_brace", "left_sq_bracket"),
         ("left_sq_bracket", "left_curly_brace"), ("circle", "triangle"))


def oracle_open_set(recogniser, data, refuse_in, held_classes=4, folds=3, seed=0):
    names = list(data.class_names)
    labels = np.asarray(data.label)
    fold = fold_of_groups(labels, data.subject, folds)
    samples = recogniser.samples(data)
    refused_in = total_in = refused_out = total_out = 0
    accepted_as = {}
    for held in class_rotations(names, held_classes, seed):
        vocab = [n for n in names if n not in held]
        best_in, score_in, best_out, score_out, label_out = [], [], [], [], []
        for f in np.unique(fold):
            train = np.flatnonzero((fold != f) & np.isin(labels, vocab))
            models = recogniser.fit([samples[i] for i in train], labels[train], vocab)
            for index, best, score in ((np.flatnonzero((fold == f) & np.isin(labels, vocab)),
                                        best_in, score_in),
                                       (np.flatnonzero((fold == f) & ~np.isin(labels, vocab)),
                                        best_out, score_out)):
                scores, steps = recogniser.scores(models, [samples[i] for i in index])
                best.append(scores.argmax(1))
                score.append(scores.max(1) / np.maximum(steps, 1))
            label_out.append(labels[(fold == f) & ~np.isin(labels, vocab)])
        best_in, score_in = np.concatenate(best_in), np.concatenate(score_in)
        best_out, score_out = np.concatenate(best_out), np.concatenate(score_out)
        label_out = np.concatenate(label_out)
        for c, name in enumerate(vocab):
            own = score_in[best_in == c]
            if own.size == 0:
                continue
            threshold = np.quantile(own, refuse_in)
            refused_in += int((own < threshold).sum())
            total_in += own.size
            taken = best_out == c
            refused_out += int((score_out[taken] < threshold).sum())
            for lab, ok in zip(label_out[taken], score_out[taken] >= threshold):
                key = f"{lab} as {name}"
                accepted_as[key] = accepted_as.get(key, 0) + int(ok)
        total_out += label_out.size
    return refused_in / total_in, refused_out / total_out, total_out, accepted_as


def pair_tests(recogniser, data, refuse_in, folds=3):
    """Two-class likelihood-ratio test per pair on held-out subject groups."""
    names = list(data.class_names)
    labels = np.asarray(data.label)
    fold = fold_of_groups(labels, data.subject, folds)
    samples = recogniser.samples(data)
    scores = np.zeros((len(labels), len(names)))
    for f in np.unique(fold):
        train = np.flatnonzero(fold != f)
        test = np.flatnonzero(fold == f)
        models = recogniser.fit([samples[i] for i in train], labels[train], names)
        scores[test] = recogniser.scores(models, [samples[i] for i in test])[0]
    out = []
    for accepted, unseen in PAIRS:
        a, u = names.index(accepted), names.index(unseen)
        own = scores[labels == accepted]
        other = scores[labels == unseen]
        threshold = np.quantile(own[:, a] - own[:, u], refuse_in)
        out.append((accepted, unseen, float(((other[:, a] - other[:, u]) < threshold).mean())))
    return out


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--refuse-in", type=float, default=0.01,
                        help="fraction of each class' own gestures refused (default 0.01)")
    args = parser.parse_args(argv)
    if not 0 < args.refuse_in < 0.5:
        parser.error(f"--refuse-in must be in (0, 0.5), got {args.refuse_in}")
    data = load_trajectories(DOLLAR)
    recogniser = replace(Recogniser(resample=64), reject=False)
    start = time.process_time()
    refused_in, refused_out, count, accepted_as = oracle_open_set(recogniser, data,
                                                                   args.refuse_in)
    print(f"oracle per-class thresholds (chosen on the test subjects): {100 * refused_in:.2f} % "
          f"of gestures refused, {100 * refused_out:.2f} % of {count} non-gestures refused")
    print("most accepted non-gestures: " + ", ".join(
        f"{k} {v}" for k, v in sorted(accepted_as.items(), key=lambda kv: -kv[1])[:6]))
    for accepted, unseen, refused in pair_tests(recogniser, data, args.refuse_in):
        print(f"two-class test, {100 * args.refuse_in:g} % of {accepted} refused: "
              f"{100 * refused:.1f} % of {unseen} refused")
    print(f"CPU {time.process_time() - start:.0f} s")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
