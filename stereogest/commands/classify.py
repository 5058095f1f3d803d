"""Classify every trajectory of a labelled dataset with a model file (the
board's decision: the class whose HMM gives the highest forward likelihood)
and print JSON: accuracy (correct / samples; rejected samples count as
errors), the confusion matrix (rows = true class, columns = decision, in the
model's class order), class_names, samples, rejected (no symbol, no finite
likelihood under any model, or a label the model does not know) and
unknown_labels."""
from __future__ import annotations

import json

NAME = "classify"
HELP = "classify a labelled trajectory dataset with a model file (JSON: accuracy, confusion)"


def add_arguments(p):
    p.add_argument("model", metavar="MODEL.json", help="model file written by 'stereogest train'")
    p.add_argument("data", metavar="DATA.npz",
                   help="trajectory dataset (points, offsets, label: strings, or integers "
                        "with class_names)")
    p.add_argument("--resample", metavar="N", default=None,
                   help="pen front end with N points, or 'camera' (default: as the model "
                        "was trained, from its meta)")


def _front_end(option, meta) -> int | None:
    from recognition.features import RESAMPLE_RANGE
    lo, hi = RESAMPLE_RANGE
    if option is not None:
        if option.strip().lower() in ("camera", "none"):
            return None
        try:
            value = int(option)
        except ValueError:
            value = None
        if value is None or not lo <= value <= hi:
            raise ValueError(f"--resample must be an integer in {lo}..{hi} or 'camera', "
                             f"got {option!r}")
        return value
    value = meta.get("resample")
    if value is not None and (isinstance(value, bool) or not isinstance(value, int)
                              or not lo <= value <= hi):
        raise ValueError(f"MODEL.json: meta resample must be null or an integer in "
                         f"{lo}..{hi}, got {value!r} (override with --resample)")
    return value


def run(args) -> int:
    import numpy as np

    from recognition.datasets import load_trajectories
    from recognition.features import sequences
    from sw_hps.hmm import load_models

    models = load_models(args.model)
    resample = _front_end(args.resample, models.meta)
    data = load_trajectories(args.data)
    seqs = sequences(data, resample=resample)
    names = models.class_names
    c = len(names)
    confusion = np.zeros((c, c), dtype=np.int64)
    correct = rejected = 0
    unknown = set()
    for seq, label in zip(seqs, data.label.tolist()):
        if label not in names:
            unknown.add(label)
            rejected += 1
            continue
        decision = models.classify(seq) if len(seq) else -1
        if decision < 0:
            rejected += 1
            continue
        confusion[names.index(label), decision] += 1
        correct += int(decision == names.index(label))
    samples = len(seqs)
    print(json.dumps({"model": str(args.model), "data": str(args.data),
                      "resample": resample, "samples": samples, "correct": correct,
                      "accuracy": correct / samples if samples else 0.0,
                      "rejected": rejected, "unknown_labels": sorted(unknown),
                      "class_names": list(names), "confusion": confusion.tolist()}))
    return 0
