"""Measuring a recogniser on people it has never seen.

* :func:`grouped_cross_validation`: every group of subjects (or writers) is
  held out once; the models (and their rejection thresholds, calibrated on
  the remaining subjects only) are trained on the rest.
* :func:`open_set_rejection`: the classes are split into a vocabulary and
  held-out "non-gestures" (rotating the split); models trained on the
  vocabulary of the other subjects must refuse the non-gestures and accept
  the held-out subjects' gestures.
* :func:`confusion_matrix`, :func:`confusion_png`: the confusion matrix, and
  as a picture.
"""
from __future__ import annotations

import os
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from recognition.recogniser import Recogniser, fold_of_groups

__all__ = ["CVOutcome", "class_rotations", "confusion_matrix", "grouped_cross_validation",
           "open_set_rejection", "confusion_png"]


def confusion_matrix(truth, decided, num_classes: int) -> np.ndarray:
    """(C, C + 1) counts: rows the true class index, columns the decision
    (class index, or the last column "none" for -1)."""
    truth = np.asarray(truth, dtype=np.int64)
    decided = np.asarray(decided, dtype=np.int64)
    out = np.zeros((num_classes, num_classes + 1), dtype=np.int64)
    np.add.at(out, (truth, np.where(decided >= 0, decided, num_classes)), 1)
    return out


@dataclass(frozen=True)
class CVOutcome:
    """Held-out decisions of :func:`grouped_cross_validation`.

    ``decided`` (-1 = refused) and ``best`` (the best class, whatever its
    score) per sample; ``truth`` the class index; ``fold`` per sample.
    """
    class_names: tuple[str, ...]
    truth: np.ndarray
    decided: np.ndarray
    best: np.ndarray
    fold: np.ndarray

    @property
    def accuracy(self) -> float:
        """Correct / samples; refused samples are errors."""
        return float((self.decided == self.truth).mean())

    @property
    def accuracy_without_rejection(self) -> float:
        return float((self.best == self.truth).mean())

    @property
    def rejection_rate(self) -> float:
        return float((self.decided < 0).mean())

    def refused_by(self, groups) -> dict:
        """Share of each group's (subject's, writer's) true gestures refused:
        {group: share}."""
        groups = np.asarray(groups)
        return {str(g): float((self.decided[groups == g] < 0).mean())
                for g in np.unique(groups)}

    def refused_right_by(self, groups) -> dict:
        """Share of each group's true gestures refused that the best class
        would have named right (what rejection costs that group; the rest of
        its refused gestures would have been misnamed): {group: share}."""
        groups = np.asarray(groups)
        lost = (self.decided < 0) & (self.best == self.truth)
        return {str(g): float(lost[groups == g].mean()) for g in np.unique(groups)}

    @property
    def fold_accuracy(self) -> list[float]:
        return [float((self.decided[self.fold == f] == self.truth[self.fold == f]).mean())
                for f in np.unique(self.fold)]

    def confusion(self) -> np.ndarray:
        """(C, C + 1): rows true class, columns decision, the last "none"."""
        return confusion_matrix(self.truth, self.decided, len(self.class_names))

    def summary(self) -> dict:
        return {"samples": int(self.truth.size), "folds": int(self.fold.max()) + 1,
                "accuracy": self.accuracy,
                "accuracy_without_rejection": self.accuracy_without_rejection,
                "rejection_rate_in": self.rejection_rate,
                "fold_accuracy": self.fold_accuracy}


def grouped_cross_validation(recogniser: Recogniser, data, groups, folds: int | None = None,
                             progress=None) -> CVOutcome:
    """Hold out each group of subjects in turn (``folds`` groups of whole
    subjects, or one fold per subject when None)."""
    names = data.class_names
    labels = data.label
    groups = np.asarray(groups)
    if folds is None:
        fold = np.unique(groups, return_inverse=True)[1].astype(np.int64)
    else:
        fold = fold_of_groups(labels, groups, folds)
    samples = recogniser.samples(data)
    truth = np.array([names.index(x) for x in labels])
    decided = np.full(len(samples), -1, dtype=np.int64)
    best = np.full(len(samples), -1, dtype=np.int64)
    for f in np.unique(fold):
        train = np.flatnonzero(fold != f)
        test = np.flatnonzero(fold == f)
        if progress is not None:
            progress(f"fold {f + 1} of {fold.max() + 1}: training on {train.size} samples")
        models = recogniser.fit([samples[i] for i in train], labels[train], names,
                                groups=groups[train])
        decided[test], best[test] = recogniser.decisions(models, [samples[i] for i in test])
    return CVOutcome(tuple(names), truth, decided, best, fold)


def class_rotations(class_names, held_classes: int, seed: int = 0) -> list[set]:
    """The open-set protocol's splits: the class names shuffled by ``seed`` and
    dealt in runs of ``held_classes``; each run is held out once (the other
    classes are the vocabulary)."""
    names = list(class_names)
    order = np.random.default_rng(seed).permutation(len(names))
    return [{names[i] for i in order[k:k + held_classes]}
            for k in range(0, len(names), held_classes)]


def open_set_rejection(recogniser: Recogniser, data, groups, held_classes: int = 4,
                       folds: int | None = None, seed: int = 0, progress=None) -> dict:
    """Non-gesture rejection: for each rotation of the class split, train on
    the vocabulary (all but ``held_classes`` classes, shuffled by ``seed``) of
    all subjects but one group, and present that group's vocabulary gestures
    (they should be accepted and right) and every subject's held-out-class
    gestures (they should be refused).

    Returns rates over all rotations and groups: ``refused_out`` (held-out
    classes refused), ``refused_in`` and ``accuracy_in`` (vocabulary).
    """
    names = list(data.class_names)
    labels = data.label
    groups = np.asarray(groups)
    fold = (np.unique(groups, return_inverse=True)[1] if folds is None
            else fold_of_groups(labels, groups, folds))
    samples = recogniser.samples(data)
    refused_out = total_out = refused_in = total_in = correct_in = 0
    per_rotation = []
    rotations = class_rotations(names, held_classes, seed)
    for r, out_names in enumerate(rotations):
        vocab = [n for n in names if n not in out_names]
        outside = np.flatnonzero(np.isin(labels, list(out_names)))
        row = {"held_out_classes": sorted(out_names), "refused_out": 0, "out": 0,
               "refused_in": 0, "in": 0, "correct_in": 0}
        for f in np.unique(fold):
            train = np.flatnonzero((fold != f) & np.isin(labels, vocab))
            test_in = np.flatnonzero((fold == f) & np.isin(labels, vocab))
            test_out = outside[fold[outside] == f]
            if progress is not None:
                progress(f"rotation {r + 1} of {len(rotations)}, fold {f + 1}")
            models = recogniser.fit([samples[i] for i in train], labels[train], vocab,
                                    groups=groups[train])
            d_in, _ = recogniser.decisions(models, [samples[i] for i in test_in])
            d_out, _ = recogniser.decisions(models, [samples[i] for i in test_out])
            truth = np.array([vocab.index(x) for x in labels[test_in]])
            row["refused_out"] += int((d_out < 0).sum())
            row["out"] += int(test_out.size)
            row["refused_in"] += int((d_in < 0).sum())
            row["in"] += int(test_in.size)
            row["correct_in"] += int((d_in == truth).sum())
        per_rotation.append(row)
        refused_out += row["refused_out"]
        total_out += row["out"]
        refused_in += row["refused_in"]
        total_in += row["in"]
        correct_in += row["correct_in"]
    return {"refused_out": refused_out / total_out, "refused_in": refused_in / total_in,
            "accuracy_in": correct_in / total_in, "samples_out": total_out,
            "samples_in": total_in, "rotations": per_rotation}


def confusion_png(confusion, class_names, path, title: str = "") -> None:
    """Draw a (C, C) or (C, C + 1) confusion matrix (the last column "none")
    to a PNG, through a temporary file."""
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from matplotlib.figure import Figure

    confusion = np.asarray(confusion)
    c = len(class_names)
    columns = list(class_names) + (["none"] if confusion.shape[1] == c + 1 else [])
    size = max(4.0, 0.45 * len(columns) + 2.0)
    fig = Figure(figsize=(size + 1.0, size), dpi=100)
    FigureCanvasAgg(fig)
    ax = fig.add_subplot()
    rates = confusion / np.maximum(confusion.sum(axis=1, keepdims=True), 1)
    ax.imshow(rates, cmap="Blues", vmin=0, vmax=1)
    for i in range(confusion.shape[0]):
        for j in range(confusion.shape[1]):
            if confusion[i, j]:
                ax.text(j, i, str(confusion[i, j]), ha="center", va="center", fontsize=7,
                        color="white" if rates[i, j] > 0.5 else "black")
    ax.set_xticks(range(len(columns)), columns, rotation=90, fontsize=7)
    ax.set_yticks(range(c), class_names, fontsize=7)
    ax.set_xlabel("decision")
    ax.set_ylabel("true class")
    if title:
        ax.set_title(title, fontsize=9)
    fig.tight_layout()
    path = Path(path)
    tmp = path.with_name(path.name + ".part")
    try:
        fig.savefig(tmp, format="png")
        os.replace(tmp, path)
    finally:
        if tmp.exists():
            tmp.unlink()
