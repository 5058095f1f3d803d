"""The posture classifier on real hands, students held out.

The photos of data/hand_postures (the ten ASL digits, 111 students) go the
camera's way (recognition.posture) to the descriptor of sim/model/posture.py
and the board's classifier. Estimate: ``--folds``-fold cross-validation with
whole students held out, ``--repeats`` times with the students dealt to the
folds in different seeded orders; inside each fold, the classifier's C is
chosen by a 4-fold cross-validation over the training students only (nested),
and only the training students' pictures are augmented. The descriptor, the
augmentation recipe and the kernel width are fixed in the code (chosen on
these photos before this benchmark: say so beside the figure).

Prints per repeat the accuracy, then the mean, the per-class accuracy and the
extended-finger count (0-5) of all repeats' decisions, the model trained on
all the photos (support vectors, file size) and its cost per picture (CPU
microseconds, one picture at a time, as the board decides).

Run: ``python benchmarks/posture_accuracy.py [--repeats 3] [--json FILE]
[--confusion-png FILE]``.
"""
from __future__ import annotations

import argparse
import json
import sys
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from recognition import posture as rp  # noqa: E402
from recognition.evaluation import confusion_matrix  # noqa: E402

DATA = ROOT / "data" / "hand_postures" / "sign_language_digits_dev.npz"


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("--data", default=str(DATA))
    p.add_argument("--copies", type=int, default=8)
    p.add_argument("--folds", type=int, default=5)
    p.add_argument("--repeats", type=int, default=3)
    p.add_argument("--seed", type=int, default=1, help="augmentation seed")
    p.add_argument("--json", default=None)
    p.add_argument("--confusion-png", default=None)
    args = p.parse_args(argv)
    start = time.process_time()
    data = rp.load_postures(args.data)
    if data.subject is None:
        raise SystemExit(f"{args.data}: needs a subject array")
    masks = rp.picture_masks(data, args.data)
    features = rp.still_features(masks)
    augmented = rp.still_features(rp.augment_masks(masks, args.copies, seed=args.seed))
    aug_labels = np.tile(data.label, args.copies)
    aug_of = np.tile(np.arange(len(data)), args.copies)
    print(f"{len(data)} pictures, {len(np.unique(data.subject))} students, "
          f"{args.copies} copies each for training; {time.process_time() - start:.1f} CPU s")
    runs, decisions = [], []
    for repeat in range(args.repeats):
        decided, chosen = rp.grouped_predictions(
            features, data.label, data.subject, data.class_names, augmented=augmented,
            augmented_labels=aug_labels, augmented_of=aug_of, folds=args.folds,
            shuffle=repeat)
        accuracy = float(np.mean(decided == data.label))
        runs.append({"shuffle": repeat, "accuracy": accuracy, "c": chosen})
        decisions.append(decided)
        print(f"repeat {repeat}: {100 * accuracy:.2f} % (C per fold "
              f"{', '.join(f'{c:g}' for c in chosen)}); {time.process_time() - start:.0f} CPU s",
              flush=True)
    decided = np.concatenate(decisions)
    truth = np.tile(data.label, args.repeats)
    confusion = confusion_matrix(truth, decided, len(data.class_names))
    per_class = {name: float(confusion[k, k] / confusion[k].sum())
                 for k, name in enumerate(data.class_names)}
    report = {"data": str(args.data), "pictures": len(data),
              "students": int(len(np.unique(data.subject))), "folds": args.folds,
              "copies": args.copies, "runs": runs,
              "accuracy": float(np.mean([r["accuracy"] for r in runs])),
              "accuracy_min": min(r["accuracy"] for r in runs),
              "accuracy_max": max(r["accuracy"] for r in runs),
              "per_class": per_class, "class_names": data.class_names,
              "confusion": confusion.tolist()}
    if data.class_names == list(rp.ASL_NAMES):
        fingers = np.array(rp.ASL_FINGERS)
        report["finger_count_accuracy"] = float(np.mean(fingers[decided] == fingers[truth]))
    # the model on all the photos, and its cost per picture on the board's path
    model = rp.train_posture(features, data.label, data.class_names, c=rp.choose_c(
        features, data.label, data.subject, data.class_names, augmented=augmented,
        augmented_labels=aug_labels, augmented_of=aug_of), augmented=augmented,
        augmented_labels=aug_labels)
    size = len(json.dumps(model.to_dict()))
    t = time.process_time()
    for row in features[:200]:
        model.decide(row)
    cost_us = (time.process_time() - t) / 200 * 1e6
    report.update(support_vectors=len(model.support_vectors), model_bytes=size,
                  decide_cpu_us=round(cost_us, 1), cpu_s=round(time.process_time() - start, 1))
    print(f"held-out students: {100 * report['accuracy']:.2f} % (mean of {args.repeats}; "
          f"{100 * report['accuracy_min']:.2f} to {100 * report['accuracy_max']:.2f})")
    print("per class: " + ", ".join(f"{k} {100 * v:.1f}" for k, v in per_class.items()))
    if "finger_count_accuracy" in report:
        print(f"extended-finger count (0-5): {100 * report['finger_count_accuracy']:.2f} %")
    print(f"model on all photos: {len(model.support_vectors)} support vectors, "
          f"{size / 1e6:.2f} MB JSON; decide {cost_us:.0f} CPU us per picture here; "
          f"{report['cpu_s']:.0f} CPU s in all")
    if args.confusion_png:
        from recognition.evaluation import confusion_png
        confusion_png(confusion, data.class_names, args.confusion_png,
                      title=f"postures, students held out: {100 * report['accuracy']:.2f} %")
    if args.json:
        Path(args.json).write_text(json.dumps(report, indent=1) + "\n")
    return 0


if __name__ == "__main__":
    sys.exit(main())
