"""Continuous gesture streams (issue 28; thesis §10.1, its first limitation):
gestures one after another, joined by the movements a person makes between
them, with the truth of where each gesture lies.

A stream is built from any trajectory dataset (:class:`~recognition.datasets.
TrajectorySet`: the `$1` strokes of one subject, pendigits of one writer, the
synthetic corpus): each gesture keeps its own points; between two gestures the
hand holds still for a pause (0 = none: it flows on), then travels from the
end of one to the start of the next on a minimum-jerk path at the two
gestures' own pace (their median step), so neither the speed nor a rest marks
where a gesture begins. With ``distractors``, non-gesture motion
(:mod:`sim.distractors`: out of view and back, a face scratch, a reach, a
drift, a shapeless wave, a move in depth) comes before every gesture, scaled
to the stream's gestures (their median extent is one gesture amplitude; a
trajectory has no depth, so a move in depth is only its motion in the
picture, and while an ``out-of-view`` distractor has the hand below the
picture the stream's ``present`` is false: a camera would see no hand);
:func:`distractor_stream` makes streams of distractors alone.

File layout (``.npz``, loadable with ``allow_pickle=False``)::

    points       (P, 2) float   every stream's positions, concatenated
    offsets      (S+1,) int     stream s is points[offsets[s]:offsets[s+1]]
    subject      (S,) int       who made the stream's gestures
    span_stream  (K,) int       the stream of each gesture
    span_first   (K,) int       its first step, inside the stream
    span_last    (K,) int       its last step (inclusive)
    span_label   (K,) str       its class name
    present      (P,) bool      the hand in view at each position (optional:
                                absent = always)

Spans rise and never overlap within a stream.
"""
from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np

from sim.distractors import DISTRACTOR_KINDS, distractor_motion
from sim.gesture_shapes import minimum_jerk

from .datasets import TrajectorySet, save_npz

__all__ = ["GestureStream", "join_stream", "subject_streams", "save_streams", "load_streams",
           "check_range", "PAUSE_RANGE", "distractor_stream", "gesture_extent"]

#: Largest pause a stream may hold between two gestures, steps.
PAUSE_RANGE = (0, 10_000)


@dataclass(frozen=True)
class GestureStream:
    """One continuous stream: ``points`` (T, 2), the position at every step;
    ``spans`` (K, 2), the first and last step (inclusive) of each gesture,
    rising and disjoint; ``labels`` (K,), their class names; ``present`` (T,)
    bool, whether the hand is in view at each step (None: always)."""
    points: np.ndarray
    spans: np.ndarray
    labels: np.ndarray
    subject: int = 0
    present: np.ndarray | None = None

    def __post_init__(self):
        points = np.asarray(self.points, dtype=np.float64)
        spans = np.asarray(self.spans).reshape(-1, 2)
        labels = np.asarray(self.labels).reshape(-1)
        if points.ndim != 2 or points.shape[1] != 2 or not np.isfinite(points).all():
            raise ValueError(f"points must be a finite (T, 2) array, got shape {points.shape}")
        if spans.dtype.kind not in "iu":
            raise ValueError(f"spans must be integers, got dtype {spans.dtype}")
        if labels.shape != (len(spans),) or labels.dtype.kind not in "UO":
            raise ValueError(f"labels must be {len(spans)} strings (one per span), got shape "
                             f"{labels.shape}")
        _check_spans(spans, len(points), "spans")
        present = np.ones(len(points), bool) if self.present is None \
            else np.asarray(self.present)
        if present.shape != (len(points),) or present.dtype.kind not in "bui" \
                or not np.isin(present, (0, 1)).all():
            raise ValueError(f"present must be {len(points)} booleans (one per point), got "
                             f"shape {present.shape}")
        object.__setattr__(self, "present", present.astype(bool))
        object.__setattr__(self, "points", points)
        object.__setattr__(self, "spans", spans.astype(np.int64))
        object.__setattr__(self, "labels", labels.astype(str))
        object.__setattr__(self, "subject", int(self.subject))

    def __len__(self) -> int:
        return len(self.points)


def _check_spans(spans: np.ndarray, length: int, name: str) -> None:
    if len(spans) == 0:
        return
    if (spans[:, 0] < 0).any() or (spans[:, 1] >= length).any() \
            or (spans[:, 1] < spans[:, 0]).any():
        raise ValueError(f"{name} must lie in [0, {length - 1}] with first <= last")
    if (spans[1:, 0] <= spans[:-1, 1]).any():
        raise ValueError(f"{name} must rise and must not overlap")


def check_range(name: str, value, lo: int, hi: int) -> tuple[int, int]:
    """``value`` (two integers, or the text ``"MIN-MAX"``) as two integers
    MIN <= MAX in [lo, hi]; ``ValueError`` naming ``name``."""
    try:
        a, b = (int(v) for v in (value.split("-") if isinstance(value, str) else value))
    except (TypeError, ValueError):
        raise ValueError(f"{name} must be two integers MIN, MAX (or MIN-MAX) in [{lo}, {hi}], "
                         f"got {value!r}") from None
    if not lo <= a <= b <= hi:
        raise ValueError(f"{name} must satisfy {lo} <= MIN <= MAX <= {hi}, got {a}, {b}")
    return a, b


def _pace(path: np.ndarray) -> float:
    steps = np.linalg.norm(np.diff(path, axis=0), axis=1)
    steps = steps[steps > 0]
    return float(np.median(steps)) if steps.size else 1.0


def _transit(start: np.ndarray, end: np.ndarray, pace: float) -> np.ndarray:
    """The steps strictly between ``start`` and ``end`` on a minimum-jerk path
    whose mean step is about ``pace``."""
    distance = float(np.linalg.norm(end - start))
    # (a minimum-jerk path peaks at 1.875 times its mean speed)
    steps = int(np.ceil(distance / max(pace, 1e-9)))
    if steps <= 1:
        return np.zeros((0, 2))
    s = minimum_jerk(np.arange(1, steps) / steps)
    return start + s[:, None] * (end - start)


def gesture_extent(parts) -> float:
    """The median over ``parts`` of the larger side of each one's bounding box:
    the unit :mod:`sim.distractors` paths are drawn in."""
    sides = [np.ptp(np.asarray(p, dtype=np.float64).reshape(-1, 2), axis=0).max()
             for p in parts]
    extent = float(np.median(sides)) if sides else 0.0
    return extent if extent > 0 else 1.0


class _Distractors:
    """Distractor paths for one stream: the kinds in rounds of a random order
    (each as often as the others), scaled by ``unit``."""

    def __init__(self, rng: np.random.Generator, unit: float, kinds=DISTRACTOR_KINDS):
        self.rng, self.unit, self.choice, self.kinds = rng, unit, tuple(kinds), []

    def path(self, start: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """The next distractor from ``start`` (its first point dropped): its
        positions and whether the hand is in view at each."""
        if not self.kinds:
            self.kinds.extend(self.rng.permutation(len(self.choice)).tolist())
        kind = self.choice[self.kinds.pop(0)]
        motion = distractor_motion(kind, self.rng)
        return start + self.unit * motion.offset[1:], motion.in_view[1:]


def _present(steps: int, hidden) -> np.ndarray:
    """``steps`` flags, true but at the indices of the arrays ``hidden``."""
    present = np.ones(steps, bool)
    for indices in hidden:
        present[indices] = False
    return present


def join_stream(parts, labels, rng: np.random.Generator, *, pause=(0, 15),
                subject: int = 0, distractors: bool = False) -> GestureStream:
    """The gestures ``parts`` (each (T_i, 2)) in order, as one stream: after
    each but the last a pause of ``pause`` = (MIN, MAX) steps (uniform; the
    hand still at the gesture's end), then the transit to the next one's start
    at the pace of the two gestures (their median step). With
    ``distractors``, a distractor (module docstring) and another pause come
    before every gesture."""
    pause = check_range("pause", pause, *PAUSE_RANGE)
    parts = [np.asarray(p, dtype=np.float64).reshape(-1, 2) for p in parts]
    labels = [str(label) for label in labels]
    if not parts or len(parts) != len(labels):
        raise ValueError(f"parts and labels must be non-empty and as many, got {len(parts)} "
                         f"and {len(labels)}")
    pieces, spans, at = [], [], 0
    hidden = []                       # distractor steps with the hand out of view
    others = _Distractors(rng, gesture_extent(parts)) if distractors else None
    for k, part in enumerate(parts):
        if others is not None:
            before, in_view = others.path(part[0])
            hidden.append(at + np.flatnonzero(~in_view))
            hold = int(rng.integers(pause[0], pause[1] + 1))
            for piece in (before, np.repeat(part[:1], hold, axis=0)):
                pieces.append(piece)
                at += len(piece)
        pieces.append(part)
        spans.append((at, at + len(part) - 1))
        at += len(part)
        if k + 1 < len(parts):
            hold = int(rng.integers(pause[0], pause[1] + 1))
            between = [np.repeat(part[-1:], hold, axis=0),
                       _transit(part[-1], parts[k + 1][0],
                                0.5 * (_pace(part) + _pace(parts[k + 1])))]
            for piece in between:
                pieces.append(piece)
                at += len(piece)
    return GestureStream(np.concatenate(pieces), np.array(spans, np.int64),
                         np.array(labels), subject, _present(at, hidden))


def subject_streams(data: TrajectorySet, per_stream: int, seed: int = 0, *,
                    pause=(0, 15), distractors: bool = False) -> list[GestureStream]:
    """Every subject's trajectories in a random order, ``per_stream`` to a stream
    (the last one of a subject may be shorter), joined by :func:`join_stream`
    (with ``distractors``: a distractor before every gesture). ``data`` needs
    subjects."""
    if data.subject is None:
        raise ValueError("the dataset has no subject (or writer) key: streams are per person")
    if isinstance(per_stream, bool) or not isinstance(per_stream, (int, np.integer)) \
            or not 1 <= per_stream <= 10_000:
        raise ValueError(f"per_stream must be an integer in [1, 10000], got {per_stream!r}")
    rng = np.random.default_rng(seed)
    streams = []
    for subject in np.unique(data.subject):
        order = rng.permutation(np.flatnonzero(data.subject == subject))
        for start in range(0, len(order), per_stream):
            chosen = order[start:start + per_stream]
            streams.append(join_stream([data.trajectory(i) for i in chosen],
                                       data.label[chosen], rng, pause=pause,
                                       subject=int(subject), distractors=distractors))
    return streams


def distractor_stream(start, unit: float, steps: int, rng: np.random.Generator, *,
                      pause=(0, 15), subject: int = 0,
                      kinds=DISTRACTOR_KINDS) -> GestureStream:
    """A stream of ``steps`` steps of distractors alone from ``start`` (x, y),
    one after another with a pause of ``pause`` steps after each, drawn in
    units of ``unit`` (a gesture's extent, :func:`gesture_extent`): no
    gesture, so anything named in it is a false command. ``kinds``: the
    distractor kinds it draws from (each as often as the others)."""
    pause = check_range("pause", pause, *PAUSE_RANGE)
    kinds = tuple(kinds)
    if not kinds or any(k not in DISTRACTOR_KINDS for k in kinds):
        raise ValueError(f"kinds must name one or more of {', '.join(DISTRACTOR_KINDS)}, "
                         f"got {kinds!r}")
    if isinstance(steps, bool) or not isinstance(steps, (int, np.integer)) \
            or not 1 <= steps <= 10_000_000:
        raise ValueError(f"steps must be an integer in [1, 10000000], got {steps!r}")
    if not (np.isfinite(unit) and unit > 0):
        raise ValueError(f"unit must be a positive number, got {unit!r}")
    start = np.asarray(start, dtype=np.float64).reshape(1, 2)
    others = _Distractors(rng, float(unit), kinds)
    pieces, hidden, at = [start], [], 1
    while at < steps:
        path, in_view = others.path(start[0])
        hidden.append(at + np.flatnonzero(~in_view))
        for piece in (path, np.repeat(start, int(rng.integers(pause[0], pause[1] + 1)), axis=0)):
            pieces.append(piece)
            at += len(piece)
    return GestureStream(np.concatenate(pieces)[:steps], np.zeros((0, 2), np.int64),
                         np.zeros(0, str), subject, _present(at, hidden)[:steps])


def save_streams(streams, path) -> None:
    """Write ``streams`` atomically (the layout of the module docstring)."""
    streams = list(streams)

    def joined(parts, empty):
        return np.concatenate(parts) if parts else empty

    spans = joined([s.spans for s in streams], np.zeros((0, 2), np.int64))
    arrays = {
        "points": joined([s.points for s in streams], np.zeros((0, 2))).astype(np.float32),
        "offsets": np.concatenate([[0], np.cumsum([len(s) for s in streams])]).astype(np.int64),
        "subject": np.array([s.subject for s in streams], np.int64),
        "span_stream": np.repeat(np.arange(len(streams)), [len(s.spans) for s in streams]),
        "span_first": spans[:, 0], "span_last": spans[:, 1],
        "span_label": joined([s.labels for s in streams], np.zeros(0, str)),
        "present": joined([s.present for s in streams], np.zeros(0, bool)),
    }
    save_npz(path, arrays)


_KEYS = ("points", "offsets", "subject", "span_stream", "span_first", "span_last", "span_label")


def load_streams(path) -> list[GestureStream]:
    """Read and validate a stream file; ``ValueError`` (one line) names the key."""
    path = Path(path)
    if not path.is_file():
        raise FileNotFoundError(f"no such stream file: {path}")
    import zipfile
    try:
        with np.load(path, allow_pickle=False) as data:
            missing = [k for k in _KEYS if k not in data.files]
            if missing:
                raise ValueError(f"missing key(s) {', '.join(missing)} (need "
                                 f"{', '.join(_KEYS)})")
            a = {k: data[k] for k in _KEYS}
            a["present"] = data["present"] if "present" in data.files else None
    except (OSError, EOFError, zipfile.BadZipFile, AttributeError) as exc:
        raise ValueError(f"{path}: not a readable stream file ({exc})") from None
    except ValueError as exc:
        raise ValueError(f"{path}: {exc}") from None
    offsets = a["offsets"]
    n = len(offsets) - 1
    try:
        if offsets.ndim != 1 or n < 0 or offsets.dtype.kind not in "iu" or offsets[0] != 0 \
                or offsets[-1] != len(a["points"]) or (np.diff(offsets) < 1).any():
            raise ValueError(f"offsets must rise strictly from 0 to len(points) = "
                             f"{len(a['points'])}")
        if a["subject"].shape != (n,) or a["subject"].dtype.kind not in "iu":
            raise ValueError(f"subject must be {n} integers, one per stream")
        k = len(a["span_label"])
        for key in ("span_stream", "span_first", "span_last"):
            if a[key].shape != (k,) or a[key].dtype.kind not in "iu":
                raise ValueError(f"{key} must be {k} integers, one per span_label")
        if k and (a["span_stream"].min() < 0 or a["span_stream"].max() >= n):
            raise ValueError(f"span_stream must be in [0, {n - 1}]")
        streams = []
        for s in range(n):
            mine = a["span_stream"] == s
            spans = np.stack([a["span_first"][mine], a["span_last"][mine]], axis=1)
            try:
                present = None if a["present"] is None \
                    else a["present"][offsets[s]:offsets[s + 1]]
                streams.append(GestureStream(a["points"][offsets[s]:offsets[s + 1]], spans,
                                             a["span_label"][mine], int(a["subject"][s]),
                                             present))
            except ValueError as exc:
                raise ValueError(f"stream {s}: {exc}".replace("spans", "span_first/span_last")
                                 ) from None
        return streams
    except ValueError as exc:
        raise ValueError(f"{path}: {exc}") from None
