"""Recognition and rejection figures (docs/figures/recognition.md), on people the models never saw.

Sections (``--section``, repeatable; default all):

``robot``
    The seven thesis gestures, camera front end: models trained on the
    synthetic corpus (``stereogest gestures --per-class 180 --people 3
    --seed 1``) and tested on a corpus of other seeds (other people), with
    the thesis recogniser and the default one; non-gestures (random walks,
    scribbles, wandering hands) presented to the default model.
``dollar``
    The $1 unistroke logs (16 gestures, 7 subjects), leave-one-subject-out,
    pen front end (64 points), every variant; the open-set rejection
    protocol (12 gestures trained, the other 4 presented as non-gestures,
    rotated, each subject held out in turn); random walks and scribbles.
``pendigits``
    UCI pendigits training writers (10 digits, 30 writers), writer-grouped
    5-fold cross-validation (6 whole writers held out per fold), every variant.

Rejection thresholds are always calibrated on the training subjects only.
Writes ``--json`` (default build/recognition_accuracy.json) and the
confusion matrices of the default recogniser to ``--docs`` (default docs/).
Prints Markdown tables.

Run: ``python benchmarks/recognition_accuracy.py [--section dollar] [--quick]``.
"""
from __future__ import annotations

import argparse
import json
import time
from dataclasses import replace
from pathlib import Path

import numpy as np

from recognition.corpus import synthetic_corpus
from recognition.datasets import load_trajectories
from recognition.evaluation import (confusion_matrix, confusion_png, grouped_cross_validation,
                                   open_set_rejection)
from recognition.non_gestures import (as_centroid_tracks, random_walks, scribbles,
                                      wandering_hands)
from recognition.recogniser import DEFAULT_REJECT_BUDGET, Recogniser

ROOT = Path(__file__).resolve().parent.parent
DOLLAR = ROOT / "data" / "gestures" / "dollar1_unistroke" / "dollar1_unistroke.npz"
PENDIGITS = ROOT / "data" / "gestures" / "uci_pendigits" / "pendigits_orig.npz"
SECTIONS = ("robot", "dollar", "pendigits")


def variants(resample):
    """(name, recogniser) of the figures' table, the default last."""
    return [
        ("discrete, 5 states, no floor (thesis §9.4)",
         Recogniser(emission="discrete", resample=resample, states=5, reject=False)),
        ("discrete, 12 states, floor 1e-3",
         Recogniser(emission="discrete", resample=resample, states=12, emission_floor=1e-3,
                    reject=False)),
        ("gaussian, 16 states, 1 component",
         Recogniser(resample=resample, components=1, reject=False)),
        (f"margin chosen for a {100 * DEFAULT_REJECT_BUDGET:g} % budget (--reject-margin auto)",
         Recogniser(resample=resample, reject_margin=None)),
        ("default: gaussian, 16 states, components by samples, rejection",
         Recogniser(resample=resample)),
    ]


def _cpu() -> float:
    return time.process_time()


def _table(title, rows):
    print(f"\n{title}\n")
    print("| recogniser | accuracy | accuracy without rejection | refused | CPU s |")
    print("|---|---|---|---|---|")
    for r in rows:
        refused = "-" if r["rejection_rate_in"] is None else f"{100 * r['rejection_rate_in']:.2f} %"
        print(f"| {r['variant']} | {100 * r['accuracy']:.2f} % | "
              f"{100 * r['accuracy_without_rejection']:.2f} % | {refused} | {r['cpu_s']:.0f} |",
              flush=True)


def cross_validated(name, data, groups, folds, resample, docs, quick):
    rows = []
    chosen = variants(resample)
    if quick:
        chosen = chosen[-1:]
    for label, recogniser in chosen:
        start = _cpu()
        outcome = grouped_cross_validation(recogniser, data, groups, folds=folds)
        row = dict(outcome.summary(), variant=label, cpu_s=round(_cpu() - start, 1),
                   recogniser=recogniser.describe())
        if not recogniser.reject:
            row["rejection_rate_in"] = None
        else:
            row["refused_by_subject"] = outcome.refused_by(data.subject)
            row["refused_worst_subject"] = max(row["refused_by_subject"].values())
            row["refused_right_by_subject"] = outcome.refused_right_by(data.subject)
            row["refused_right_worst_subject"] = max(row["refused_right_by_subject"].values())
            for key, what in (("refused_by_subject", "refused"),
                              ("refused_right_by_subject", "refused that would be named right")):
                print(f"{name}, {label}: {what}, per held-out subject "
                      + ", ".join(f"{k} {100 * v:.2f} %" for k, v in row[key].items()),
                      flush=True)
        rows.append(row)
        if recogniser.reject and docs is not None:
            confusion_png(outcome.confusion(), outcome.class_names, docs / f"confusion_{name}.png",
                          title=f"{name}: {100 * outcome.accuracy:.2f} % on held-out people "
                                f"({outcome.truth.size} samples)")
            row["confusion"] = outcome.confusion().tolist()
    return rows


def refusals(models, recogniser, data, camera=False):
    samples = replace(recogniser, resample=None if camera else recogniser.resample).samples(data)
    decided, _ = recogniser.decisions(models, samples)
    return float((decided < 0).mean())


def section_robot(docs, quick):
    per_class = 60 if quick else 180
    train = synthetic_corpus(per_class=per_class, people=3, seed=1)
    test = synthetic_corpus(per_class=10 if quick else 30, people=3, seed=77)
    out = {"train": len(train), "test": len(test)}
    rows = []
    for label, recogniser in [("discrete, 5 states, no floor (thesis §9.4)",
                               Recogniser(emission="discrete", states=5, reject=False)),
                              ("default: gaussian with rejection", Recogniser())]:
        start = _cpu()
        models = recogniser.fit(recogniser.samples(train), train.label, train.class_names,
                                groups=train.subject)
        decided, best = recogniser.decisions(models, recogniser.samples(test))
        truth = np.array([train.class_names.index(x) for x in test.label])
        row = {"variant": label, "accuracy": float((decided == truth).mean()),
               "accuracy_without_rejection": float((best == truth).mean()),
               "rejection_rate_in": float((decided < 0).mean()) if recogniser.reject else None,
               "cpu_s": round(_cpu() - start, 1)}
        rows.append(row)
        if recogniser.reject:
            count = 50 if quick else 500
            out["non_gestures_refused"] = {
                "wandering_hands": refusals(models, recogniser, wandering_hands(count, seed=3),
                                            camera=True),
                "random_walks_as_tracks": refusals(models, recogniser,
                                                   as_centroid_tracks(random_walks(count, seed=1), origin=(200.0, 150.0)),
                                                   camera=True),
                "count": count}
            if docs is not None:
                conf = confusion_matrix(truth, decided, len(models.class_names))
                confusion_png(conf, models.class_names, docs / "confusion_robot.png",
                              title=f"robot gestures, other seeds: {100 * row['accuracy']:.2f} %")
    _table("Seven robot gestures, camera front end, trained on seed 1, tested on seed 77 "
           f"({len(test)} trajectories)", rows)
    print(f"\nnon-gestures refused by the default model: {out['non_gestures_refused']}")
    out["rows"] = rows
    return out


def section_dollar(docs, quick):
    data = load_trajectories(DOLLAR)
    rows = cross_validated("dollar1", data, data.subject, None, 64, docs, quick)
    _table("$1 unistroke logs, 16 gestures, leave-one-subject-out (7 subjects), 64 points", rows)
    out = {"rows": rows}
    rules = [("", Recogniser(resample=64))]
    if not quick:
        rules.append(("_auto_margin", Recogniser(resample=64, reject_margin=None)))
    for key, recogniser in rules:
        rule = "margin chosen (--reject-margin auto)" if key else "default"
        start = _cpu()
        open_set = open_set_rejection(recogniser, data, data.subject, held_classes=4,
                                      folds=3 if quick else None)
        open_set["cpu_s"] = round(_cpu() - start, 1)
        print(f"\n{rule}: open set (12 trained, 4 presented as non-gestures, rotated): "
              f"refused {100 * open_set['refused_out']:.2f} % of non-gestures, "
              f"{100 * open_set['refused_in']:.2f} % of gestures; accuracy on gestures "
              f"{100 * open_set['accuracy_in']:.2f} %")
        for r in open_set["rotations"]:
            print(f"  held out {', '.join(r['held_out_classes'])}: refused "
                  f"{100 * r['refused_out'] / r['out']:.1f} % of them, "
                  f"{100 * r['refused_in'] / r['in']:.2f} % of the others")
        models = recogniser.fit(recogniser.samples(data), data.label, data.class_names,
                                groups=data.subject)
        count = 50 if quick else 500
        noise = {"random_walks": refusals(models, recogniser, random_walks(count, seed=1)),
                 "scribbles": refusals(models, recogniser, scribbles(count, seed=2)),
                 "count": count, "margin": models.meta["rejection"]["margin"]}
        print(f"{rule}: non-gestures refused by the model of all 16 gestures: {noise}")
        out["open_set" + key] = open_set
        out["non_gestures_refused" + key] = noise
    return out


def section_pendigits(docs, quick):
    data = load_trajectories(PENDIGITS)
    if quick:
        keep = np.flatnonzero(data.subject <= 6)
        data = data.subset(keep)
    rows = cross_validated("pendigits", data, data.subject, 5 if not quick else 3, 64, docs,
                           quick)
    _table("UCI pendigits training writers, 10 digits, writer-grouped 5-fold CV, 64 points",
           rows)
    return {"rows": rows}


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--section", action="append", choices=SECTIONS, default=None)
    parser.add_argument("--quick", action="store_true",
                        help="the default recogniser only, on less data (a smoke run)")
    parser.add_argument("--json", default=str(ROOT / "build" / "recognition_accuracy.json"))
    parser.add_argument("--docs", default=str(ROOT / "docs"),
                        help="directory for the confusion PNGs ('' for none)")
    args = parser.parse_args(argv)
    docs = Path(args.docs) if args.docs else None
    if docs is not None:
        docs.mkdir(parents=True, exist_ok=True)
    figures = {}
    run = {"robot": section_robot, "dollar": section_dollar, "pendigits": section_pendigits}
    for name in args.section or SECTIONS:
        start = _cpu()
        figures[name] = run[name](docs, args.quick)
        figures[name]["section_cpu_s"] = round(_cpu() - start, 1)
    path = Path(args.json)
    path.parent.mkdir(parents=True, exist_ok=True)
    previous = json.loads(path.read_text()) if path.exists() else {}
    previous.update(figures)
    path.write_text(json.dumps(previous, indent=1) + "\n")
    print(json.dumps({k: {kk: vv for kk, vv in v.items() if kk != "rows"}
                      for k, v in figures.items()}, default=str)[:2000])
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
