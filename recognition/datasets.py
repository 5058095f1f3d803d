"""Trajectory datasets: the ``.npz`` layout shared by every gesture corpus.

Layout (plain arrays, loadable with ``allow_pickle=False``)::

    points       (P, 2) float   x, y of every trajectory, concatenated
    offsets      (N+1,) int     trajectory i is points[offsets[i]:offsets[i+1]]
    label        (N,) str       class name of each trajectory, or
                 (N,) int       index into class_names (label i means class_names[label[i]])
    class_names  (C,) str       needed with integer labels: C unique names, labels in 0..C-1
    subject      (N,) int       optional: who made it (person, writer)
    writer       (N,) int       optional: taken as subject when there is no subject key

:func:`load_trajectories` turns integer labels into their class names, so a
:class:`TrajectorySet` always holds string labels. With string labels,
``class_names`` (and ``writer`` next to ``subject``) is kept but not
interpreted, like every other key.
"""
from __future__ import annotations

import os
from dataclasses import dataclass
from pathlib import Path

import numpy as np

__all__ = ["TrajectorySet", "load_trajectories", "save_trajectories", "save_npz"]


@dataclass(frozen=True)
class TrajectorySet:
    """N labelled trajectories; ``trajectory(i)`` is an (T_i, 2) float array."""
    points: np.ndarray
    offsets: np.ndarray
    label: np.ndarray
    subject: np.ndarray | None = None

    def __post_init__(self):
        points = np.asarray(self.points)
        offsets = np.asarray(self.offsets)
        label = np.asarray(self.label)
        if points.ndim != 2 or points.shape[1] != 2 or points.dtype.kind not in "fiu":
            raise ValueError(f"points must be a numeric (P, 2) array, got shape {points.shape} "
                             f"dtype {points.dtype}")
        if not np.isfinite(points).all():
            raise ValueError("points must be finite (no NaN or infinity)")
        if offsets.ndim != 1 or offsets.size < 1 or offsets.dtype.kind not in "iu":
            raise ValueError(f"offsets must be an integer (N+1,) array, got shape {offsets.shape} "
                             f"dtype {offsets.dtype}")
        if offsets[0] != 0 or offsets[-1] != len(points) or (np.diff(offsets) < 1).any():
            raise ValueError(f"offsets must rise strictly from 0 to len(points) = {len(points)} "
                             "(every trajectory has at least one point)")
        n = offsets.size - 1
        if label.shape != (n,):
            raise ValueError(f"label must have shape ({n},), one per trajectory, got shape "
                             f"{label.shape}")
        if label.dtype.kind not in "UO":
            raise ValueError(f"label must be ({n},) strings, got dtype {label.dtype}")
        empty = np.flatnonzero(label.astype(str) == "")
        if empty.size:
            raise ValueError(f"label must not be empty (trajectory {int(empty[0])})")
        object.__setattr__(self, "points", points.astype(np.float64))
        object.__setattr__(self, "offsets", offsets.astype(np.int64))
        object.__setattr__(self, "label", label.astype(str))
        if self.subject is not None:
            subject = np.asarray(self.subject)
            if subject.shape != (n,) or subject.dtype.kind not in "iu":
                raise ValueError(f"subject must be ({n},) integers, got shape {subject.shape} "
                                 f"dtype {subject.dtype}")
            object.__setattr__(self, "subject", subject.astype(np.int64))

    def __len__(self) -> int:
        return self.offsets.size - 1

    def trajectory(self, i: int) -> np.ndarray:
        return self.points[self.offsets[i]:self.offsets[i + 1]]

    def trajectories(self) -> list[np.ndarray]:
        return [self.trajectory(i) for i in range(len(self))]

    @property
    def class_names(self) -> tuple[str, ...]:
        """Sorted distinct labels."""
        return tuple(sorted(set(self.label.tolist())))

    def subset(self, index) -> "TrajectorySet":
        """The trajectories at ``index`` (an index array or boolean mask)."""
        idx = np.arange(len(self))[index]
        parts = [self.trajectory(i) for i in idx]
        lengths = [len(p) for p in parts]
        return TrajectorySet(np.concatenate(parts) if parts else np.zeros((0, 2)),
                             np.concatenate([[0], np.cumsum(lengths)]).astype(np.int64),
                             self.label[idx],
                             None if self.subject is None else self.subject[idx])

    @classmethod
    def from_list(cls, trajectories, labels, subjects=None) -> "TrajectorySet":
        parts = [np.asarray(t, dtype=np.float64).reshape(-1, 2) for t in trajectories]
        lengths = [len(p) for p in parts]
        return cls(np.concatenate(parts) if parts else np.zeros((0, 2)),
                   np.concatenate([[0], np.cumsum(lengths)]).astype(np.int64),
                   np.asarray(list(labels), dtype=str),
                   None if subjects is None else np.asarray(list(subjects), dtype=np.int64))


def read_npz(path) -> dict:
    """The named arrays of an ``.npz`` file (``allow_pickle=False``);
    ``ValueError`` (one line) names the file, or the key that cannot be read,
    for a .npy named .npz, a broken archive or a pickled array."""
    import zipfile
    import zlib
    path = Path(path)
    try:
        data = np.load(path, allow_pickle=False)
        if not isinstance(data, np.lib.npyio.NpzFile):      # a .npy named .npz
            raise ValueError("it holds one array (.npy), not a set of named arrays (.npz)")
        with data:
            arrays = {}
            for key in data.files:
                try:
                    arrays[key] = data[key]
                except ValueError as exc:  # e.g. a pickled object array
                    raise ValueError(f"{path}: {key}: cannot be read ({exc})") from None
    except (OSError, EOFError, zipfile.BadZipFile, zlib.error) as exc:
        raise ValueError(f"{path}: not a readable .npz file ({exc})") from None
    except ValueError as exc:
        if str(exc).startswith(str(path)):
            raise
        raise ValueError(f"{path}: not a readable .npz file ({exc})") from None
    return arrays


def load_trajectories(path) -> TrajectorySet:
    """Read and validate a trajectory ``.npz``; ``ValueError`` (one line) names the key.

    Integer labels become ``class_names[label]``; ``writer`` is the subject of a
    file without ``subject`` (UCI pendigits)."""
    path = Path(path)
    if not path.is_file():
        raise FileNotFoundError(f"no such dataset file: {path}")
    arrays = read_npz(path)
    missing = [k for k in ("points", "offsets", "label") if k not in arrays]
    if missing:
        raise ValueError(f"{path}: missing key(s) {', '.join(missing)} "
                         "(need points, offsets, label; class_names with integer labels; "
                         "subject or writer optional)")
    subject_key = "subject" if "subject" in arrays else "writer" if "writer" in arrays else None
    try:
        label = _string_labels(arrays["label"], arrays.get("class_names"))
        return TrajectorySet(arrays["points"], arrays["offsets"], label,
                             None if subject_key is None else arrays[subject_key])
    except ValueError as exc:
        message = str(exc)
        if subject_key == "writer" and message.startswith("subject "):
            message = "writer (read as subject) " + message[len("subject "):]
        raise ValueError(f"{path}: {message}") from None


def _string_labels(label: np.ndarray, class_names: np.ndarray | None) -> np.ndarray:
    """String labels as stored, or integer labels mapped through ``class_names``."""
    if label.dtype.kind == "U":
        return label                      # class_names, if any, is not interpreted
    if label.dtype.kind not in "iu":
        raise ValueError(f"label must be strings, or integers indexing class_names, "
                         f"got dtype {label.dtype}")
    if class_names is None:
        raise ValueError(f"label holds integers (dtype {label.dtype}): class_names is needed "
                         "to name the classes (label i means class_names[label[i]])")
    if class_names.ndim != 1 or class_names.size < 1 or class_names.dtype.kind != "U":
        raise ValueError(f"class_names must be a 1-D array of at least one string, got shape "
                         f"{class_names.shape} dtype {class_names.dtype}")
    names, counts = np.unique(class_names, return_counts=True)
    if (counts > 1).any():
        repeated = ", ".join(repr(str(n)) for n in names[counts > 1][:5])
        raise ValueError(f"class_names must be unique, got {repeated} more than once")
    if label.ndim != 1:
        raise ValueError(f"label must be a 1-D array, one per trajectory, got shape "
                         f"{label.shape}")
    top = class_names.size - 1
    outside = (label < 0) | (label > top)
    if outside.any():
        bad = label[outside]
        raise ValueError(f"label must be in 0..{top} (indices into the {top + 1} class_names), "
                         f"got {bad.size} label(s) outside, e.g. {int(bad[0])}")
    return class_names[label.astype(np.int64)]


def save_trajectories(data: TrajectorySet, path, **extra) -> None:
    """Write ``data`` (plus any ``extra`` arrays) atomically as ``.npz``."""
    path = Path(path)
    arrays = {"points": data.points.astype(np.float32), "offsets": data.offsets,
              "label": data.label}
    if data.subject is not None:
        arrays["subject"] = data.subject
    arrays.update(extra)
    save_npz(path, arrays)


def save_npz(path, arrays: dict) -> None:
    """Write ``arrays`` as a compressed ``.npz`` atomically: a partial file
    never stands where ``path`` was."""
    path = Path(path)
    tmp = path.with_name(path.name + ".part.npz")
    try:
        np.savez_compressed(tmp, **arrays)
        os.replace(tmp, path)
    finally:
        if tmp.exists():
            tmp.unlink()
