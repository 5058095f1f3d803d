"""Train the posture classifier from labelled pictures of hands and write the
model file the board loads (sw_hps.posture).

Each picture goes the camera's way (recognition.posture.picture_hand: the
model's YCbCr, 4:2:2, the skin box, the band all-in), then the posture mask
and the descriptor (sim.model.posture), presented as a still picture; a file
from 'stereogest postures' brings the pipeline's own records' features
instead, and its masks presented as still pictures are added as copies.
Each training picture adds --copies turned, scaled and (half of them)
longer-armed copies of its mask. C is chosen by a cross-validation over
--groups (whole subjects apart; without it, pictures apart). Prints a JSON
last line."""
from __future__ import annotations

import json
import sys

from stereogest.commands import DEFAULT_SEED, add_json_switch, check_output_file

NAME = "train-posture"
HELP = "train the posture classifier from labelled pictures (DATA.npz) into POSTURE.json"

_COPIES = 8
_COPIES_RANGE = (0, 32)


def add_arguments(p):
    p.add_argument("data", metavar="DATA.npz", nargs="+",
                   help="pictures: image (N x H x W x 3 uint8 RGB), label (ints; class_names "
                        "if given, else asl0..asl9), optional subject, mask and features (the "
                        "pipeline's mask and posture record, 'stereogest postures'); several "
                        "files are joined by class name, each file's subjects apart")
    p.add_argument("-o", "--output", metavar="POSTURE.json", required=True,
                   help="model file to write")
    p.add_argument("--groups", choices=("subject",), default=None,
                   help="choose C with whole subjects held out (needs the subject key)")
    p.add_argument("--copies", type=int, default=_COPIES, metavar="N",
                   help=f"augmented copies per picture, {_COPIES_RANGE[0]}..{_COPIES_RANGE[1]} "
                        f"(default {_COPIES})")
    p.add_argument("--seed", type=int, default=DEFAULT_SEED, help="augmentation seed")
    add_json_switch(p, always=True)


def run(args) -> int:
    import numpy as np

    from recognition import posture as rp
    from sim.atomic import write_text_atomic

    from sim.model.validation import check_int
    lo, hi = _COPIES_RANGE
    if not lo <= args.copies <= hi:
        raise ValueError(f"--copies must be an integer in {lo}..{hi}, got {args.copies}")
    check_int("--seed", args.seed, 0, 2 ** 63 - 1)
    check_output_file(args.output)
    sets = [rp.load_postures(path) for path in args.data]
    if args.groups == "subject":
        for path, data in zip(args.data, sets):
            if data.subject is None:
                raise ValueError(f"{path}: --groups subject needs a subject array")
    names = []          # joined by name, in the order the files give them
    for data in sets:
        names += [n for n in data.class_names if n not in names]
    features, labels, groups, aug_features, aug_labels, aug_of = [], [], [], [], [], []
    for k, (path, data) in enumerate(zip(args.data, sets)):
        label = np.array([names.index(data.class_names[i]) for i in data.label], np.int64)
        offset = sum(len(f) for f in features)
        features.append(rp.picture_features(data, path))
        labels.append(label)
        # each file's subjects (or pictures) are groups of their own
        own = data.subject if args.groups == "subject" else np.arange(len(data))
        groups.append([f"{k}:{g}" for g in own])
        copies = args.copies
        if copies:
            augmented = rp.augment_masks(rp.picture_masks(data, path), copies,
                                         seed=args.seed + k)
            aug_features.append(rp.still_features(augmented))
        if data.features is not None and data.mask is not None:
            # the record's mask as a still picture: the same hand about its own reference
            aug_features.append(rp.still_features(data.mask))
            copies += 1
        aug_labels.append(np.tile(label, copies))
        aug_of.append(offset + np.tile(np.arange(len(data)), copies))
    features, labels = np.vstack(features), np.concatenate(labels)
    groups = np.unique(np.concatenate(groups), return_inverse=True)[1]
    aug_features = np.vstack(aug_features or [np.zeros((0, features.shape[1]))])
    aug_labels, aug_of = np.concatenate(aug_labels), np.concatenate(aug_of)
    c = rp.choose_c(features, labels, groups, names, augmented=aug_features,
                    augmented_labels=aug_labels, augmented_of=aug_of)
    model = rp.train_posture(features, labels, names, c=c,
                             augmented=aug_features, augmented_labels=aug_labels)
    sizes = []
    for data in sets:
        if list(data.image.shape[1:3]) not in sizes:
            sizes.append(list(data.image.shape[1:3]))
    model.meta = {"data": [str(path) for path in args.data],
                  "pictures": [len(data) for data in sets], "picture_sizes": sizes,
                  "copies": args.copies, "seed": args.seed, "c": c, "groups": args.groups}
    write_text_atomic(args.output, json.dumps(model.to_dict()) + "\n")
    print(f"stereogest train-posture: {args.output}: {len(model.class_names)} postures, "
          f"{len(model.support_vectors)} support vectors, C {c:g}", file=sys.stderr)
    print(json.dumps({"model": str(args.output), "class_names": model.class_names,
                      "pictures": int(len(labels)), "copies": args.copies, "c": c,
                      "support_vectors": len(model.support_vectors)}))
    return 0
