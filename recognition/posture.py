"""Training and scoring the posture classifier (:class:`sw_hps.posture.PostureModel`)
on labelled pictures of hands.

A picture goes the camera's way (:func:`picture_hand`): RGB to YCbCr with the
model's integer conversion, packed to 4:2:2 and back as the camera stream
delivers it, the skin box, the disparity band taken as all-in (a photo has no
disparity); then the posture mask and the descriptor of
:mod:`sim.model.posture`, the picture presented twice (:func:`describe_still`).

Training (:func:`train_posture`) adds, per training picture, ``copies`` masks
turned by up to +-10 degrees and scaled by up to +-10 % about their centroid
(people hold the hand at a tilt), half of them with a longer forearm (the hand
shrunk towards its top and its lowest row repeated down to the edge: at the
camera the arm shows more than in a photo); the standardisation and an RBF
support-vector machine (scikit-learn's ``SVC``, one-vs-one) are fitted on
those and the pictures, and exported for the board. ``C`` is chosen by a
cross-validation over the training subjects (:func:`choose_c`).
"""
from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np

from sim.model.posture import FEATURES, describe_still
from sw_hps.posture import PostureModel

__all__ = ["PostureSet", "load_postures", "picture_hand", "picture_masks", "still_features",
           "picture_features", "augment_masks",
           "train_posture", "choose_c", "grouped_predictions", "C_CHOICES", "GAMMA_PER_FEATURE",
           "ASL_NAMES", "ASL_FINGERS"]

#: The support-vector machine's ``C`` choices and kernel width (gamma = this / features).
C_CHOICES = (10.0, 30.0)
GAMMA_PER_FEATURE = 0.5
#: The names of labels 0-9 of the ASL digit pictures.
ASL_NAMES = tuple(f"asl{k}" for k in range(10))
#: The extended fingers of each ASL digit (6-9: three, the fourth touches the thumb).
ASL_FINGERS = (0, 1, 2, 3, 4, 5, 3, 3, 3, 3)
#: Augmentation: the largest turn (degrees) and scale change; the share of the
#: copies with a longer forearm and their shrink range.
TURN_DEG, SCALE = 10.0, 0.10
FOREARM_SHARE, FOREARM_SHRINK = 0.5, (0.6, 1.0)


@dataclass
class PostureSet:
    """Labelled pictures: ``image`` (N, H, W, 3) uint8 RGB, ``label`` (N,) ints
    indexing ``class_names``, ``subject`` (N,) ints or None, ``mask`` (N, H, W)
    bool or None: the camera's segmented mask of each picture (rendered
    frames through the pipeline), used instead of the picture path;
    ``features`` (N, FEATURES) or None: the features of the pipeline's own
    posture record of each picture, used instead of the mask's."""

    image: np.ndarray
    label: np.ndarray
    class_names: list
    subject: np.ndarray | None
    mask: np.ndarray | None = None
    features: np.ndarray | None = None

    def __len__(self):
        return len(self.label)


def load_postures(path) -> PostureSet:
    """A DATA.npz of pictures: ``image`` (N x H x W x 3 uint8 RGB), ``label``
    (ints, indexing ``class_names`` if given, else 0-9 as ``asl0`` ...
    ``asl9``), optional ``subject``, ``mask`` (N x H x W bool: the
    pipeline's segmented mask of each picture) and ``features`` (N x FEATURES
    finite floats: the features of the pipeline's posture record of each
    picture; both from :mod:`recognition.posture_renders`). ``ValueError``
    names the file and the key."""
    from recognition.datasets import read_npz
    path = Path(path)
    if not path.is_file():
        raise ValueError(f"{path}: no such file")
    arrays = read_npz(path)
    for key in ("image", "label"):
        if key not in arrays:
            raise ValueError(f"{path}: has no '{key}' array (a DATA.npz of pictures needs "
                             f"image and label)")
    image, label = arrays["image"], arrays["label"]
    if len(label) == 0 or len(image) == 0:
        raise ValueError(f"{path}: holds no pictures")
    if image.dtype != np.uint8 or image.ndim != 4 or image.shape[3] != 3 \
            or min(image.shape[1:3]) < 8:
        raise ValueError(f"{path}: image must be N x H x W x 3 uint8 RGB with H, W >= 8, "
                         f"got {image.dtype} {image.shape}")
    if label.ndim != 1 or label.dtype.kind not in "iu" or len(label) != len(image):
        raise ValueError(f"{path}: label must be {len(image)} integers (one per image), "
                         f"got {label.dtype} {label.shape}")
    if "class_names" in arrays:
        names = arrays["class_names"]
        if names.ndim != 1 or names.dtype.kind != "U" or len(set(names.tolist())) != len(names) \
                or not all(names.tolist()):
            raise ValueError(f"{path}: class_names must be unique non-empty strings")
        names = names.tolist()
    else:
        names = list(ASL_NAMES)
    if len(label) and (label.min() < 0 or label.max() >= len(names)):
        raise ValueError(f"{path}: label must be in 0..{len(names) - 1} (indices of "
                         f"class_names), got {int(label.min())}..{int(label.max())}")
    subject = arrays.get("subject")
    if subject is not None and (subject.ndim != 1 or subject.dtype.kind not in "iu"
                                or len(subject) != len(label)):
        raise ValueError(f"{path}: subject must be {len(label)} integers, got "
                         f"{subject.dtype} {subject.shape}")
    mask = arrays.get("mask")
    if mask is not None and (mask.dtype != bool or mask.shape != image.shape[:3]):
        raise ValueError(f"{path}: mask must be bool N x H x W like image {image.shape[:3]}, "
                         f"got {mask.dtype} {mask.shape}")
    features = arrays.get("features")
    if features is not None and (features.dtype.kind != "f" or features.shape != (len(label), FEATURES)
                                 or not np.isfinite(features).all()):
        raise ValueError(f"{path}: features must be {len(label)} x {FEATURES} finite floats "
                         f"(one row per image), got {features.dtype} {features.shape}")
    return PostureSet(image, label.astype(np.int64), names,
                      None if subject is None else subject.astype(np.int64), mask,
                      None if features is None else features.astype(float))


def picture_hand(image) -> np.ndarray:
    """The hand mask of an RGB picture as the pipeline makes it (skin AND an
    all-in band): bool H x W. An odd width loses its last column (4:2:2)."""
    from sim.footage import frame_to_422
    from sim.model.segmentation import skin_mask
    from sim.model.ycbcr import ycbcr422_to_444
    image = np.asarray(image)
    height, width = image.shape[0], image.shape[1] // 2 * 2
    bgr = np.ascontiguousarray(image[:, :width, ::-1])
    _, cb, cr = ycbcr422_to_444(frame_to_422(bgr, width, height))
    return skin_mask(cb, cr)


def picture_masks(data: PostureSet, name="DATA.npz") -> np.ndarray:
    """The hand mask of every picture (the file's ``mask`` if it has one);
    ``ValueError`` naming the file and the first picture without a
    skin-coloured pixel (nothing to describe)."""
    masks = data.mask if data.mask is not None else \
        np.array([picture_hand(image) for image in data.image], dtype=bool)
    empty = np.nonzero(~masks.any(axis=(1, 2)))[0]
    if len(empty):
        raise ValueError(f"{name}: image {int(empty[0])} has no skin-coloured pixel (Cb, Cr "
                         f"in the skin box): no hand to describe"
                         + (f" ({len(empty)} such images)" if len(empty) > 1 else ""))
    return masks


def still_features(masks) -> np.ndarray:
    """The features of each hand mask presented as a still picture (N x FEATURES)."""
    return np.array([describe_still(m)[1] for m in masks]).reshape(-1, FEATURES)


def picture_features(data: PostureSet, name="DATA.npz") -> np.ndarray:
    """The classifier's input for every picture: the file's ``features`` (the
    pipeline's own records) if it has them, else the masks' as still pictures."""
    if data.features is not None:
        return data.features
    return still_features(picture_masks(data, name))


def _forearm(mask, shrink: float) -> np.ndarray:
    import cv2
    h, w = mask.shape
    ys, xs = np.nonzero(mask)
    top, centre = (ys.min(), xs.mean()) if len(ys) else (0, w / 2)
    m = np.float32([[shrink, 0, centre * (1 - shrink)], [0, shrink, top * (1 - shrink)]])
    out = cv2.warpAffine(mask.astype(np.uint8), m, (w, h), flags=cv2.INTER_NEAREST) > 0
    rows = np.nonzero(out.any(axis=1))[0]
    if len(rows):
        out[rows[-1] + 1:] = out[rows[-1]]
    return out


def augment_masks(masks, copies: int, seed: int) -> np.ndarray:
    """``copies`` turned and scaled copies of each mask (copy-major order:
    all masks' first copy, then the second ...), a share with a longer forearm."""
    import cv2
    rng = np.random.default_rng(seed)
    out = []
    for _ in range(copies):
        for mask in masks:
            h, w = mask.shape
            ys, xs = np.nonzero(mask)
            centre = (float(xs.mean()), float(ys.mean())) if len(xs) else (w / 2, h / 2)
            turn = cv2.getRotationMatrix2D(centre, rng.uniform(-TURN_DEG, TURN_DEG),
                                           rng.uniform(1 - SCALE, 1 + SCALE))
            copy = cv2.warpAffine(mask.astype(np.uint8), turn, (w, h),
                                  flags=cv2.INTER_NEAREST) > 0
            if rng.random() < FOREARM_SHARE:
                copy = _forearm(copy, rng.uniform(*FOREARM_SHRINK))
            out.append(copy)
    return np.array(out, dtype=bool).reshape((-1,) + np.shape(masks)[1:])


def _fit(features, labels, c: float, n_classes: int):
    from sklearn.svm import SVC
    missing = sorted(set(range(n_classes)) - set(np.unique(labels).tolist()))
    if missing:
        raise ValueError(f"the training data has no example of class(es) {missing}")
    mean = features.mean(axis=0)
    scale = features.std(axis=0)
    scale[scale == 0] = 1.0
    gamma = GAMMA_PER_FEATURE / features.shape[1]
    svm = SVC(C=c, gamma=gamma, kernel="rbf").fit((features - mean) / scale, labels)
    return mean, scale, gamma, svm


def train_posture(features, labels, class_names, *, c: float,
                  augmented=None, augmented_labels=None) -> PostureModel:
    """The board's classifier fitted on ``features`` (N x F) and the
    ``augmented`` copies' features; every class must have examples."""
    x = np.asarray(features, float)
    y = np.asarray(labels, np.int64)
    if augmented is not None and len(augmented):
        x = np.vstack([x, augmented])
        y = np.concatenate([y, augmented_labels])
    mean, scale, gamma, svm = _fit(x, y, c, len(class_names))
    # scikit-learn keeps libsvm's signs except for two classes, where it flips
    # both the coefficients and the intercept
    sign = -1.0 if len(class_names) == 2 else 1.0
    return PostureModel(class_names, mean, scale, gamma, svm.support_vectors_,
                        svm.n_support_, sign * svm.dual_coef_, sign * svm.intercept_)


def _group_folds(groups, folds: int, shuffle: int | None = None):
    """``folds`` (train, test) index pairs, whole groups apart
    (:func:`recognition.recogniser.fold_of_groups`: dealt in sorted order of
    their ids, or in an order shuffled by the seed ``shuffle``)."""
    from recognition.recogniser import fold_of_groups
    distinct, inverse = np.unique(groups, return_inverse=True)
    if len(distinct) < folds:
        raise ValueError(f"cross-validation needs at least {folds} groups (subjects, or "
                         f"pictures without --groups), got {len(distinct)}")
    if shuffle is not None:     # the group order[k] dealt k-th
        order = np.random.default_rng(shuffle).permutation(len(distinct))
        inverse = np.argsort(order)[inverse]
    fold = fold_of_groups(None, inverse, folds)
    return [(np.flatnonzero(fold != k), np.flatnonzero(fold == k)) for k in range(folds)]


def choose_c(features, labels, groups, class_names, *, augmented, augmented_labels,
             augmented_of, folds: int = 4) -> float:
    """The ``C`` of :data:`C_CHOICES` with the most right answers over a
    ``folds``-fold cross-validation by ``groups`` (the augmented copies of a
    held-out picture, ``augmented_of`` its index, are left out with it)."""
    scores = {}
    for c in C_CHOICES:
        right = 0
        for k, (train, test) in enumerate(_group_folds(groups, folds)):
            missing = sorted(set(range(len(class_names))) - set(labels[train].tolist()))
            if missing:
                raise ValueError(
                    f"choosing C: fold {k + 1} of {folds} leaves no training example of "
                    f"{', '.join(class_names[m] for m in missing)} (each posture needs "
                    f"pictures of several subjects)")
            keep = np.isin(augmented_of, train)
            model = train_posture(features[train], labels[train], class_names, c=c,
                                  augmented=augmented[keep],
                                  augmented_labels=augmented_labels[keep])
            right += int((model.decide(features[test]) == labels[test]).sum())
        scores[c] = right
    return max(C_CHOICES, key=lambda c: (scores[c], -c))


def grouped_predictions(features, labels, groups, class_names, *, augmented,
                        augmented_labels, augmented_of, folds: int = 5, shuffle=None,
                        progress=None) -> tuple[np.ndarray, list]:
    """Each picture's class decided by a model trained without its subject:
    ``folds`` folds of whole subjects; inside each, ``C`` chosen by
    :func:`choose_c` on the training subjects only (nested); ``shuffle``
    deals the subjects to the folds in a seeded order. Returns the decisions
    and the ``C`` of each fold."""
    decided = np.full(len(labels), -1, np.int64)
    chosen = []
    for k, (train, test) in enumerate(_group_folds(groups, folds, shuffle)):
        keep = np.isin(augmented_of, train)
        aug, aug_labels, aug_of = augmented[keep], augmented_labels[keep], augmented_of[keep]
        # indices of the training part, as choose_c sees them
        local = np.full(len(labels), -1, np.int64)
        local[train] = np.arange(len(train))
        c = choose_c(features[train], labels[train], groups[train], class_names,
                     augmented=aug, augmented_labels=aug_labels,
                     augmented_of=local[aug_of])
        model = train_posture(features[train], labels[train], class_names, c=c,
                              augmented=aug, augmented_labels=aug_labels)
        decided[test] = model.decide(features[test])
        chosen.append(c)
        if progress:
            progress(f"fold {k + 1}/{folds}: C {c:g}, "
                     f"{np.mean(decided[test] == labels[test]) * 100:.2f} % right")
    return decided, chosen
