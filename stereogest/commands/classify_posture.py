"""Classify every picture of a labelled DATA.npz with a posture model file (the
board's classifier, sw_hps.posture) and print JSON: ``accuracy`` (right /
pictures; refused pictures count as errors), ``per_class`` (accuracy per true
class), ``confusion`` (rows true class, columns decision in the model's class
order, a last column for refused), ``refused``, ``class_names``, ``pictures``.

The pictures go the camera's way (as train-posture) and must be of a size
the model was trained on (its meta picture_sizes); their labels index the
data's class_names (or asl0..asl9), each of which the model must know."""
from __future__ import annotations

import json

from stereogest.commands import add_json_switch

NAME = "classify-posture"
HELP = "classify labelled pictures (DATA.npz) with a posture model (JSON: accuracy, confusion)"


def add_arguments(p):
    p.add_argument("model", metavar="POSTURE.json", help="model file of train-posture")
    p.add_argument("data", metavar="DATA.npz", help="pictures, as train-posture reads them")
    add_json_switch(p, always=True)


def run(args) -> int:
    import numpy as np

    from recognition import posture as rp
    from recognition.evaluation import confusion_matrix
    from sw_hps.posture import read_posture_model

    from sim.model.posture import FEATURES
    model = read_posture_model(args.model)
    if model.features != FEATURES:
        raise ValueError(f"{args.model}: features must be {FEATURES} (the descriptor's), "
                         f"got {model.features}")
    data = rp.load_postures(args.data)
    sizes = model.meta.get("picture_sizes")
    if sizes is not None and list(data.image.shape[1:3]) not in [list(s) for s in sizes]:
        trained = ", ".join(f"{s[0]} x {s[1]}" for s in sizes)
        raise ValueError(f"{args.data}: pictures are {data.image.shape[1]} x "
                         f"{data.image.shape[2]}, the model was trained on {trained} "
                         f"(its meta picture_sizes)")
    unknown = sorted(set(data.class_names) - set(model.class_names))
    if unknown:
        raise ValueError(f"{args.data}: class_names {', '.join(unknown)} are not postures of "
                         f"{args.model} ({', '.join(model.class_names)})")
    truth = np.array([model.class_names.index(data.class_names[k]) for k in data.label])
    decided = model.decide(rp.picture_features(data, args.data))
    confusion = confusion_matrix(truth, decided, len(model.class_names))
    present = confusion.sum(axis=1) > 0
    report = {"model": str(args.model), "data": str(args.data), "pictures": len(data),
              "accuracy": float(np.mean(decided == truth)),
              "per_class": {name: float(confusion[k, k] / confusion[k].sum())
                            for k, name in enumerate(model.class_names) if present[k]},
              "refused": int((decided < 0).sum()), "class_names": model.class_names,
              "confusion": confusion.tolist()}
    print(json.dumps(report))
    return 0
