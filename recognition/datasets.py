"""Trajectory datasets: the ``.npz`` layout shared by every gesture corpus.

Layout (plain arrays, loadable with ``allow_pickle=False``)::

    points   (P, 2) float   x, y of every trajectory, concatenated
    offsets  (N+1,) int     trajectory i is points[offsets[i]:offsets[i+1]]
    label    (N,) str       class name of each trajectory
    subject  (N,) int       optional: who made it (person, writer)

Other keys are kept but not interpreted.
"""
from __future__ import annotations

import os
from dataclasses import dataclass
from pathlib import Path

import numpy as np

__all__ = ["TrajectorySet", "load_trajectories", "save_trajectories"]


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
        if label.shape != (n,) or label.dtype.kind not in "UO":
            raise ValueError(f"label must be ({n},) strings, one per trajectory, got shape "
                             f"{label.shape} dtype {label.dtype}")
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


def load_trajectories(path) -> TrajectorySet:
    """Read and validate a trajectory ``.npz``; ``ValueError`` names the key."""
    path = Path(path)
    if not path.is_file():
        raise FileNotFoundError(f"no such dataset file: {path}")
    try:
        with np.load(path, allow_pickle=False) as data:
            arrays = {}
            for key in data.files:
                try:
                    arrays[key] = data[key]
                except ValueError as exc:  # e.g. a pickled object array
                    raise ValueError(f"{path}: {key}: cannot be read ({exc})") from None
    except (OSError, EOFError) as exc:
        raise ValueError(f"{path}: not a readable .npz file ({exc})") from None
    except ValueError as exc:
        if str(exc).startswith(str(path)):
            raise
        raise ValueError(f"{path}: not a readable .npz file ({exc})") from None
    missing = [k for k in ("points", "offsets", "label") if k not in arrays]
    if missing:
        raise ValueError(f"{path}: missing key(s) {', '.join(missing)} "
                         "(need points, offsets, label; subject optional)")
    try:
        return TrajectorySet(arrays["points"], arrays["offsets"], arrays["label"],
                             arrays.get("subject"))
    except ValueError as exc:
        raise ValueError(f"{path}: {exc}") from None


def save_trajectories(data: TrajectorySet, path, **extra) -> None:
    """Write ``data`` (plus any ``extra`` arrays) atomically as ``.npz``."""
    path = Path(path)
    arrays = {"points": data.points.astype(np.float32), "offsets": data.offsets,
              "label": data.label}
    if data.subject is not None:
        arrays["subject"] = data.subject
    arrays.update(extra)
    tmp = path.with_name(path.name + ".part.npz")
    try:
        np.savez_compressed(tmp, **arrays)
        os.replace(tmp, path)
    finally:
        if tmp.exists():
            tmp.unlink()
