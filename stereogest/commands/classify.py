"""Classify every trajectory of a labelled dataset with a model file (the
board's decision: the class whose HMM gives the highest forward likelihood,
refused when the model file's rejection rule says it is not a gesture) and
print JSON:

* ``accuracy``: correct / in-vocabulary samples (label among the model's
  classes); refused samples count as errors;
* ``rejection_rate_in``: in-vocabulary samples refused / in-vocabulary samples;
* ``rejection_rate_out``: samples whose label the model does not know that
  were refused / such samples (null when there are none);
* ``confusion``: rows = true class, columns = decision, in the model's class
  order, plus a last column "none" (refused);
* ``class_names``, ``samples``, ``in_vocabulary``, ``unknown_labels``,
  ``rejected`` (all refused samples), ``accuracy_without_rejection`` (the
  best class whatever its score).

The model must be one the board application runs (``sw_hps.app.check_models``:
discrete models emit the 8 orientation symbols), else an error (exit status 2).
Samples whose label is not one of the model's classes are out-of-vocabulary:
a warning on stderr names those labels, and they count in
``rejection_rate_out`` only. When no label of the data is a class of the model
(a different vocabulary), the accuracy would mean nothing: an error (exit
status 2), nothing classified.
"""
from __future__ import annotations

import json
import sys

from stereogest.commands import add_json_switch

NAME = "classify"
HELP = "classify a labelled trajectory dataset with a model file (JSON: accuracy, confusion)"


def add_arguments(p):
    p.add_argument("model", metavar="MODEL.json", help="model file written by 'stereogest train'")
    p.add_argument("data", metavar="DATA.npz",
                   help="trajectory dataset (points, offsets, label as strings or as integers "
                        "with class_names)")
    p.add_argument("--resample", metavar="N", default=None,
                   help="pen front end with N points, or 'camera' (default: as the model "
                        "was trained, from its meta; gaussian models always compute their "
                        "features on the points they were trained with)")
    p.add_argument("--plot", "--confusion-png", dest="confusion_png", metavar="PNG",
                   default=None,
                   help="also draw the confusion matrix, with the class names, to this PNG")
    add_json_switch(p, always=True)


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


def unknown_labels(labels, class_names) -> list[str]:
    """The labels (sorted, once each) that are not among ``class_names``."""
    return sorted(set(labels) - set(class_names))


def _listed(names, most: int = 10) -> str:
    """``a, b, c`` (the first ``most``, then how many more): one line however many."""
    names = list(names)
    more = f" and {len(names) - most} more" if len(names) > most else ""
    return ", ".join(names[:most]) + more


def run(args) -> int:
    import numpy as np

    from recognition.datasets import load_trajectories
    from recognition.evaluation import confusion_matrix, confusion_png
    from recognition.features import feature_sets, sequences
    from recognition.recogniser import Recogniser
    from stereogest.pipeline_outputs import load_board_models

    # what the board application would refuse is no model to score
    models = load_board_models(args.model)
    resample = _front_end(args.resample, models.meta)
    if args.confusion_png is not None and not str(args.confusion_png).endswith(".png"):
        raise ValueError(f"--plot must name a .png file, got {args.confusion_png!r}")
    if args.confusion_png is not None:
        from stereogest.commands import check_output_file
        check_output_file(args.confusion_png, "--plot")
    data = load_trajectories(args.data)
    if len(data) == 0:
        raise ValueError(f"{args.data}: holds no trajectories")
    unknown = unknown_labels(data.label.tolist(), models.class_names)
    if len(unknown) == len(set(data.label.tolist())):
        raise ValueError(f"{args.data}: none of its labels ({_listed(unknown)}) is a class of "
                         f"{args.model} ({_listed(models.class_names)}); nothing to score")
    if unknown:
        print(f"stereogest classify: warning: {args.data}: labels the model has no class for "
              f"({_listed(unknown)}): scored as out-of-vocabulary (rejection_rate_out), "
              f"not in accuracy", file=sys.stderr)
    if models.emission == "gaussian":
        samples = feature_sets(data, models.resample, camera=resample is None)
    else:
        samples = sequences(data, resample=resample)
    decided, best = Recogniser(emission=models.emission).decisions(models, samples)
    names = models.class_names
    c = len(names)
    labels = data.label.tolist()
    known = np.array([label in names for label in labels], dtype=bool)
    truth = np.array([names.index(label) if label in names else -1 for label in labels])
    confusion = confusion_matrix(truth[known], decided[known], c)
    inside = int(known.sum())
    outside = int((~known).sum())
    correct = int((decided[known] == truth[known]).sum())
    refused_in = int((decided[known] < 0).sum())
    refused_out = int((decided[~known] < 0).sum())
    if models.emission == "gaussian" and resample is not None:
        resample = models.resample          # the features use the model's own resampling
    report = {"model": str(args.model), "data": str(args.data), "emission": models.emission,
              "resample": resample, "samples": len(samples), "in_vocabulary": inside,
              "correct": correct, "accuracy": correct / inside if inside else None,
              "accuracy_without_rejection":
                  float((best[known] == truth[known]).mean()) if inside else None,
              "rejection_rate_in": refused_in / inside if inside else None,
              "rejection_rate_out": refused_out / outside if outside else None,
              "rejected": refused_in + refused_out,
              "unknown_labels": unknown,
              "class_names": list(names), "confusion": confusion.tolist()}
    if args.confusion_png is not None:
        confusion_png(confusion, names, args.confusion_png,
                      title=f"{args.data}: {100 * (report['accuracy'] or 0):.2f} % "
                            f"({inside} samples)")
        report["confusion_png"] = str(args.confusion_png)
    print(json.dumps(report))
    return 0
