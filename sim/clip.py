"""The stereo clip: a directory holding a rendered (or captured) stereo gesture clip.

Layout of a clip directory::

    clip.json   metadata (see :data:`REQUIRED_FIELDS` and :data:`TRUTH_FIELDS`)
    left.npy    (frames, height, 2*width) uint8, the left camera's YCbCr 4:2:2 stream
    right.npy   (frames, height, 2*width) uint8, the right camera's stream
    truth.csv   frame,hand_x,hand_y,hand_area,moving[,posture] (rendered clips only)

A rendered clip (``stereogest render``) knows its truth: ``gesture``, the
:data:`TRUTH_FIELDS` and ``truth.csv``. A rendered sequence (``render
--sequence``) also holds ``sequence``: every gesture with its motion span, in
order; its ``gesture`` is the last one and ``motion_frames`` spans them all.
With ``--distractors`` it holds ``distractors`` too: every non-gesture motion
(:data:`sim.distractors.DISTRACTOR_KINDS`) with its span; a clip of
distractors only has an empty ``sequence``, no ``gesture``, and
``motion_frames`` spans the distractors. Footage (``stereogest clip``, from
video files or cameras) has none of them; ``gesture`` may still label it, and
``source`` says where the frames came from. Every command that reads clips
accepts both.

Each frame row of a ``.npy`` is the camera byte stream ``Y0 Cb0 Y1 Cr0 ...``
(thesis §5.4, Table 11). ``truth.csv`` gives, per frame, the exact centroid of
the hand's pixels in the LEFT image (two decimals; ``nan`` when no hand pixel is
visible), their count, and whether the frame lies in the motion span
``motion_frames = [first, last]`` (inclusive) of ``clip.json``.

:func:`save_clip` writes into a temporary sibling directory and renames it into
place, so a clip directory is never left half-written; :func:`load_clip`
validates every file and raises ``ValueError`` naming the file and the field.
"""
from __future__ import annotations

import csv
import io
import json
import math
import numbers
import os
import shutil
import tempfile
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from sim.distractors import DISTRACTOR_KINDS
from sim.hand_postures import HAND_SHAPE_NAMES
from sim.gesture_shapes import GESTURE_NAMES

__all__ = [
    "CLIP_FORMAT", "CLIP_VERSION", "PIXEL_FORMAT", "MAX_DISPARITY", "TRUTH_HEADER",
    "POSTURE_TRUTH_HEADER",
    "REQUIRED_FIELDS", "TRUTH_FIELDS", "Clip", "save_clip", "check_clip_target", "load_clip",
    "is_clip_dir",
    "round_truth",
]

CLIP_FORMAT = "stereogest-clip"
CLIP_VERSION = 1
PIXEL_FORMAT = "YCbCr 4:2:2, bytes Y0 Cb Y1 Cr"
#: Number of disparities of the matcher (d in 0..47).
MAX_DISPARITY = 48
TRUTH_HEADER = ("frame", "hand_x", "hand_y", "hand_area", "moving")
#: ``truth.csv``'s header when the clip records the hand's posture per frame.
POSTURE_TRUTH_HEADER = TRUTH_HEADER + ("posture",)
#: Keys every ``clip.json`` holds. Optional: ``gesture`` (required with the
#: truth), ``renderer`` and ``source`` (free-form objects).
REQUIRED_FIELDS = ("format", "version", "width", "height", "frames", "fps", "pixel_format")
#: Keys of a rendered clip's truth, present together (with ``gesture`` and
#: ``truth.csv``) or not at all (footage).
TRUTH_FIELDS = ("seed", "hand_disparity", "face_disparity", "motion_frames")

_JSON, _LEFT, _RIGHT, _TRUTH = "clip.json", "left.npy", "right.npy", "truth.csv"


def round_truth(values) -> np.ndarray:
    """Round hand coordinates to two decimals exactly as ``truth.csv`` stores them.

    Rounding through the decimal text makes a saved and reloaded clip compare
    equal to the in-memory one.
    """
    arr = np.asarray(values, dtype=float)
    return np.array([float(f"{v:.2f}") for v in arr.ravel()], dtype=float).reshape(arr.shape)


def _is_int(value) -> bool:
    return isinstance(value, numbers.Integral) and not isinstance(value, bool)


@dataclass(eq=False)
class Clip:
    """A stereo gesture clip in memory (see the module docstring for the files).

    Attributes
    ----------
    fps : int, 1..1000
        Nominal frame rate.
    left, right : (frames, height, 2*width) uint8
        Camera byte streams (YCbCr 4:2:2, ``Y0 Cb Y1 Cr``).
    gesture : str or None
        One of :data:`sim.gesture_shapes.GESTURE_NAMES`; None for unlabelled footage.

    The truth of a rendered clip (all None for footage, see :attr:`has_truth`):

    seed : int, >= 0
        Seed the clip was rendered with.
    hand_disparity, face_disparity : int, 0..47
        Disparities (pixels) of the hand and face layers.
    motion_frames : (int, int)
        First and last (inclusive) frame of the gesture motion.
    hand_xy : (frames, 2) float64
        Centroid ``(x, y)`` of the hand pixels of the left image, two decimals;
        NaN where ``hand_area`` is 0.
    hand_area : (frames,) int64
        Number of hand pixels in the left image.
    sequence : tuple of (str, int, int), optional
        A rendered sequence: every gesture and its motion span (first, last),
        in order, inside ``motion_frames``, the last one being ``gesture``;
        empty in a clip of distractors only.
    distractors : tuple of (str, int, int), optional
        A rendered sequence with non-gesture motion: every distractor's kind
        and span (first, last), in order, none overlapping a gesture.
    postures : tuple of str, optional
        The hand's posture in each frame (:data:`sim.hand_postures.HAND_SHAPE_NAMES`);
        ``clip.json`` keeps it as runs (``postures``: ``{"posture", "frames"}``),
        ``truth.csv`` per frame.
    renderer : dict
        Extra JSON-serialisable metadata (renderer parameters).
    source : dict
        Where footage came from (the inputs, the conversion); empty when rendered.
    """

    fps: int
    left: np.ndarray
    right: np.ndarray
    gesture: str | None = None
    seed: int | None = None
    hand_disparity: int | None = None
    face_disparity: int | None = None
    motion_frames: tuple[int, int] | None = None
    hand_xy: np.ndarray | None = None
    hand_area: np.ndarray | None = None
    sequence: tuple | None = None
    distractors: tuple | None = None
    postures: tuple | None = None
    renderer: dict = field(default_factory=dict)
    source: dict = field(default_factory=dict)

    @property
    def has_truth(self) -> bool:
        """True for a rendered clip (hand positions and motion span known)."""
        return self.hand_xy is not None

    @property
    def frames(self) -> int:
        return int(self.left.shape[0])

    @property
    def height(self) -> int:
        return int(self.left.shape[1])

    @property
    def width(self) -> int:
        return int(self.left.shape[2]) // 2

    @property
    def moving(self) -> np.ndarray | None:
        """(frames,) bool: True inside the motion span ``motion_frames`` (of a
        sequence: inside each gesture's span; None without truth)."""
        if self.motion_frames is None:
            return None
        index = np.arange(self.frames)
        spans = [self.motion_frames] if self.sequence is None else \
            [(a, b) for _, a, b in self.sequence]
        moving = np.zeros(self.frames, bool)
        for first, last in spans:
            moving |= (index >= first) & (index <= last)
        return moving

    def metadata(self) -> dict:
        """The ``clip.json`` content of this clip."""
        meta = {
            "format": CLIP_FORMAT, "version": CLIP_VERSION,
            "width": self.width, "height": self.height, "frames": self.frames,
            "fps": int(self.fps), "pixel_format": PIXEL_FORMAT,
        }
        if self.gesture is not None:
            meta["gesture"] = self.gesture
        for key in TRUTH_FIELDS:
            value = getattr(self, key)
            if value is not None:
                meta[key] = ([_plain(v) for v in value] if key == "motion_frames"
                             else _plain(value))
        if self.sequence is not None:
            meta["sequence"] = [{"gesture": g, "motion_frames": [int(a), int(b)]}
                                for g, a, b in self.sequence]
        if self.distractors is not None:
            meta["distractors"] = [{"kind": k, "frames": [int(a), int(b)]}
                                   for k, a, b in self.distractors]
        if self.postures is not None:
            meta["postures"] = _posture_runs(self.postures)
        if self.renderer:
            meta["renderer"] = self.renderer
        if self.source:
            meta["source"] = self.source
        return meta

    def validate(self) -> None:
        """Raise ``ValueError`` (naming the attribute) unless the clip is consistent."""
        _check_metadata(self.metadata(), "Clip")
        for name in ("left", "right"):
            arr = getattr(self, name)
            if not isinstance(arr, np.ndarray) or arr.dtype != np.uint8 or arr.ndim != 3:
                raise ValueError(f"Clip.{name} must be a 3-D uint8 array "
                                 f"(frames, height, 2*width)")
        if self.right.shape != self.left.shape:
            raise ValueError(f"Clip.right shape {self.right.shape} differs from "
                             f"Clip.left shape {self.left.shape}")
        if (self.hand_xy is None) != (self.hand_area is None) or \
                (self.hand_xy is None) != (self.motion_frames is None):
            raise ValueError("Clip.hand_xy, Clip.hand_area and Clip.motion_frames are given "
                             "together (a rendered clip) or not at all (footage)")
        if self.has_truth:
            _check_truth_arrays(np.asarray(self.hand_xy), np.asarray(self.hand_area),
                                self.frames, "Clip")


def _plain(value):
    """A numpy integer as a JSON-ready int (other values unchanged)."""
    return int(value) if _is_int(value) else value


def _check_metadata(meta, where: str) -> dict:
    """Validate a ``clip.json`` object; ``where`` prefixes every message."""
    if not isinstance(meta, dict):
        raise ValueError(f"{where}: must hold a JSON object")
    for key in REQUIRED_FIELDS:
        if key not in meta:
            raise ValueError(f"{where}: missing field '{key}'")
    truth = [key for key in TRUTH_FIELDS if key in meta]
    if truth:
        # a clip of distractors only (an empty sequence) names no gesture
        needed = TRUTH_FIELDS if meta.get("sequence") == [] else ("gesture",) + TRUTH_FIELDS
        for key in needed:
            if key not in meta:
                raise ValueError(f"{where}: missing field '{key}' (a rendered clip has "
                                 f"'gesture' and all of {', '.join(TRUTH_FIELDS)}; footage "
                                 f"none of the latter)")

    def bad(key: str, expected: str) -> ValueError:
        return ValueError(f"{where}: field '{key}' must be {expected}, got {meta[key]!r}")

    if meta["format"] != CLIP_FORMAT:
        raise bad("format", repr(CLIP_FORMAT))
    if not _is_int(meta["version"]) or meta["version"] != CLIP_VERSION:
        raise bad("version", str(CLIP_VERSION))
    if "gesture" in meta and meta["gesture"] not in GESTURE_NAMES:
        raise bad("gesture", "one of " + ", ".join(GESTURE_NAMES))
    if not _is_int(meta["width"]) or meta["width"] < 2 or meta["width"] % 2:
        raise bad("width", "an even integer >= 2 (pixels come in 4:2:2 pairs)")
    if not _is_int(meta["height"]) or meta["height"] < 1:
        raise bad("height", "a positive integer")
    if not _is_int(meta["frames"]) or meta["frames"] < 1:
        raise bad("frames", "a positive integer")
    if not _is_int(meta["fps"]) or not 1 <= meta["fps"] <= 1000:
        raise bad("fps", "an integer in [1, 1000]")
    if meta["pixel_format"] != PIXEL_FORMAT:
        raise bad("pixel_format", repr(PIXEL_FORMAT))
    if truth:
        if not _is_int(meta["seed"]) or meta["seed"] < 0:
            raise bad("seed", "a non-negative integer")
        for key in ("hand_disparity", "face_disparity"):
            if not _is_int(meta[key]) or not 0 <= meta[key] < MAX_DISPARITY:
                raise bad(key, f"an integer in [0, {MAX_DISPARITY - 1}]")
        span = meta["motion_frames"]
        if (not isinstance(span, (list, tuple)) or len(span) != 2
                or not all(_is_int(v) for v in span)
                or not 0 <= span[0] <= span[1] < meta["frames"]):
            raise bad("motion_frames", "[first, last] with 0 <= first <= last < frames")
    for key in ("renderer", "source"):
        if key in meta and not isinstance(meta[key], dict):
            raise bad(key, "a JSON object")
    if "sequence" in meta:
        _check_sequence(meta, bad)
    if "distractors" in meta:
        _check_distractors(meta, bad)
    if "postures" in meta:
        spans = _rising_spans(meta["postures"], "posture", HAND_SHAPE_NAMES, "frames", 0,
                              meta["frames"] - 1) \
            if isinstance(meta["postures"], list) and truth else None
        if not spans or spans[0][0] != 0 or spans[-1][1] != meta["frames"] - 1 or any(
                b[0] != a[1] + 1 for a, b in zip(spans, spans[1:])):
            raise bad("postures", "a list of {\"posture\": NAME, \"frames\": [first, last]} "
                                  "covering every frame in order (a rendered clip's); NAME "
                                  "one of " + ", ".join(HAND_SHAPE_NAMES))
    return meta


def _posture_runs(postures) -> list:
    """Per-frame posture names as runs ``{"posture", "frames": [first, last]}``."""
    runs = []
    for frame, name in enumerate(postures):
        if runs and runs[-1]["posture"] == name:
            runs[-1]["frames"][1] = frame
        else:
            runs.append({"posture": str(name), "frames": [frame, frame]})
    return runs


def _posture_frames(runs) -> tuple:
    return tuple(run["posture"] for run in runs
                 for _ in range(run["frames"][1] - run["frames"][0] + 1))


def _rising_spans(entries, name_key: str, names, span_key: str, lo: int, hi: int):
    """The ``[first, last]`` of each entry of a truth list (objects of exactly
    ``name_key`` in ``names`` and ``span_key``), rising, disjoint and inside
    [lo, hi]; None if any entry is not so."""
    spans, previous = [], lo - 1
    for entry in entries:
        if not isinstance(entry, dict) or set(entry) != {name_key, span_key} \
                or entry[name_key] not in names:
            return None
        span = entry[span_key]
        if (not isinstance(span, list) or len(span) != 2 or not all(_is_int(v) for v in span)
                or not previous < span[0] <= span[1] <= hi):
            return None
        spans.append(span)
        previous = span[1]
    return spans


def _check_distractors(meta, bad) -> None:
    expected = ("a list of {\"kind\": KIND, \"frames\": [first, last]} in order, inside the "
                f"clip, none overlapping a gesture; KIND one of {', '.join(DISTRACTOR_KINDS)}")
    entries = meta["distractors"]
    if "sequence" not in meta or not isinstance(entries, list):
        raise bad("distractors", expected)
    gestures = [e["motion_frames"] for e in meta["sequence"]]
    spans = _rising_spans(entries, "kind", DISTRACTOR_KINDS, "frames", 0, meta["frames"] - 1)
    if spans is None or any(first <= b and a <= last for first, last in spans
                            for a, b in gestures):
        raise bad("distractors", expected)
    if not meta["sequence"] and (not spans or [spans[0][0], spans[-1][1]]
                                 != list(meta["motion_frames"])):
        raise bad("distractors", expected + " (without gestures: spanning motion_frames)")


def _check_sequence(meta, bad) -> None:
    expected = ("a non-empty list of {\"gesture\": NAME, \"motion_frames\": [first, last]} "
                "in order, inside motion_frames, the last gesture being 'gesture'")
    seq = meta["sequence"]
    if seq == [] and "gesture" not in meta and "distractors" in meta:
        return                            # distractors only (checked there)
    if "motion_frames" not in meta or not isinstance(seq, list) or not seq:
        raise bad("sequence", expected)
    lo, hi = meta["motion_frames"]
    spans = _rising_spans(seq, "gesture", GESTURE_NAMES, "motion_frames", lo, hi)
    if spans is None or seq[-1]["gesture"] != meta["gesture"] or spans[0][0] != lo \
            or spans[-1][1] != hi:
        raise bad("sequence", expected)


def _check_truth_arrays(hand_xy: np.ndarray, hand_area: np.ndarray, frames: int,
                        where: str) -> None:
    if hand_xy.shape != (frames, 2) or hand_xy.dtype.kind != "f":
        raise ValueError(f"{where}: hand_xy must be a ({frames}, 2) float array, "
                         f"got shape {hand_xy.shape} dtype {hand_xy.dtype}")
    if hand_area.shape != (frames,) or hand_area.dtype.kind not in "iu":
        raise ValueError(f"{where}: hand_area must be a ({frames},) integer array, "
                         f"got shape {hand_area.shape} dtype {hand_area.dtype}")
    if np.any(hand_area < 0):
        raise ValueError(f"{where}: hand_area must be >= 0")
    missing = np.isnan(hand_xy).any(axis=1)
    if np.any(missing != (hand_area == 0)) or np.any(np.isinf(hand_xy)):
        frame = int(np.flatnonzero((missing != (hand_area == 0))
                                   | np.isinf(hand_xy).any(axis=1))[0])
        raise ValueError(f"{where}: hand_x/hand_y must be finite exactly when hand_area > 0 "
                         f"(frame {frame})")


def is_clip_dir(path) -> bool:
    """True if ``path`` is a directory whose ``clip.json`` declares the clip format."""
    meta_path = Path(path) / _JSON
    try:
        with open(meta_path, encoding="utf-8") as fh:
            meta = json.load(fh)
    except (OSError, ValueError):
        return False
    return isinstance(meta, dict) and meta.get("format") == CLIP_FORMAT


def _truth_text(clip: Clip) -> str:
    out = io.StringIO()
    postures = clip.postures
    out.write(",".join(TRUTH_HEADER if postures is None else POSTURE_TRUTH_HEADER) + "\n")
    for frame, ((x, y), area, moving) in enumerate(
            zip(clip.hand_xy, clip.hand_area, clip.moving)):
        tail = "" if postures is None else f",{postures[frame]}"
        out.write(f"{frame},{x:.2f},{y:.2f},{int(area)},{int(moving)}{tail}\n")
    return out.getvalue()


def check_clip_target(path) -> Path:
    """The directory :func:`save_clip` may write ``path`` as, checked before any
    work: a new name in an existing folder, an empty directory or an old clip
    (which is replaced).

    Raises
    ------
    ValueError
        If ``path`` exists and is not a clip.
    FileNotFoundError
        If the parent directory of ``path`` does not exist.
    """
    target = Path(path)
    parent = target.parent if str(target.parent) else Path(".")
    if not target.name:
        raise ValueError(f"clip path must name a directory, got {str(path)!r}")
    if target.exists() or target.is_symlink():
        empty_dir = target.is_dir() and not target.is_symlink() and not any(target.iterdir())
        if not (empty_dir or (target.is_dir() and is_clip_dir(target))):
            raise ValueError(f"{target} exists and is not a stereogest clip; "
                             f"refusing to overwrite it")
    if not parent.is_dir():
        raise FileNotFoundError(f"parent directory of the clip does not exist: {parent}")
    return target


def save_clip(clip: Clip, path) -> Path:
    """Write ``clip`` as a clip directory at ``path`` (atomically).

    The files are written into a temporary sibling directory which is renamed to
    ``path`` at the end; on any error the temporary directory is removed. An
    existing clip directory at ``path`` is replaced, an empty directory too;
    any other existing path is refused.

    Returns
    -------
    pathlib.Path
        The clip directory.

    Raises
    ------
    ValueError
        If the clip is inconsistent, or ``path`` exists and is not a clip.
    FileNotFoundError
        If the parent directory of ``path`` does not exist.
    """
    clip.validate()
    target = check_clip_target(path)
    parent = target.parent if str(target.parent) else Path(".")
    staging = Path(tempfile.mkdtemp(prefix=f".{target.name}.partial-", dir=parent))
    old = None
    try:
        with open(staging / _JSON, "w", encoding="utf-8") as fh:
            json.dump(clip.metadata(), fh, indent=2)
            fh.write("\n")
        np.save(staging / _LEFT, np.ascontiguousarray(clip.left), allow_pickle=False)
        np.save(staging / _RIGHT, np.ascontiguousarray(clip.right), allow_pickle=False)
        if clip.has_truth:
            with open(staging / _TRUTH, "w", encoding="utf-8", newline="") as fh:
                fh.write(_truth_text(clip))
        os.chmod(staging, 0o755)        # mkdtemp makes it private
        if target.exists():
            # Move the old clip aside first: a rename cannot replace a non-empty dir.
            old = Path(tempfile.mkdtemp(prefix=f".{target.name}.old-", dir=parent))
            os.rmdir(old)
            os.rename(target, old)
        os.rename(staging, target)
    except BaseException:
        shutil.rmtree(staging, ignore_errors=True)
        if old is not None and old.exists() and not target.exists():
            os.rename(old, target)
        raise
    if old is not None:
        shutil.rmtree(old, ignore_errors=True)
    return target


def _load_array(path: Path, expected_shape: tuple[int, ...], mmap: bool) -> np.ndarray:
    """Load a ``.npy`` after checking its header and its length against the json."""
    name = path.name
    if not path.is_file():
        raise ValueError(f"{name}: missing file in clip {path.parent}")
    try:
        with open(path, "rb") as fh:
            version = np.lib.format.read_magic(fh)
            if version == (1, 0):
                shape, fortran, dtype = np.lib.format.read_array_header_1_0(fh)
            elif version == (2, 0):
                shape, fortran, dtype = np.lib.format.read_array_header_2_0(fh)
            else:
                raise ValueError(f"unsupported .npy version {version}")
            data_offset = fh.tell()
    except ValueError as exc:
        raise ValueError(f"{name}: not a valid .npy file ({exc})") from None
    if dtype != np.uint8:
        raise ValueError(f"{name}: dtype must be uint8, got {dtype}")
    if fortran:
        raise ValueError(f"{name}: array must be stored in C order")
    if tuple(shape) != expected_shape:
        raise ValueError(f"{name}: shape {tuple(shape)} does not match clip.json "
                         f"(frames, height, 2*width) = {expected_shape}")
    expected_bytes = data_offset + math.prod(shape)
    actual_bytes = path.stat().st_size
    if actual_bytes != expected_bytes:
        raise ValueError(f"{name}: file is {actual_bytes} bytes, expected {expected_bytes} "
                         f"for shape {tuple(shape)} (truncated or padded)")
    return np.load(path, mmap_mode="r" if mmap else None, allow_pickle=False)


def _load_truth(path: Path, frames: int, postures: tuple | None):
    name = path.name
    if not path.is_file():
        raise ValueError(f"{name}: missing file in clip {path.parent}")
    with open(path, encoding="utf-8", newline="") as fh:
        rows = list(csv.reader(fh))
    header = TRUTH_HEADER if postures is None else POSTURE_TRUTH_HEADER
    if not rows or tuple(cell.strip() for cell in rows[0]) != header:
        raise ValueError(f"{name}: header must be {','.join(header)}"
                         + ("" if postures is None else " (clip.json has postures)"))
    rows = [row for row in rows[1:] if row]
    if len(rows) != frames:
        raise ValueError(f"{name}: has {len(rows)} rows, clip.json field 'frames' is {frames}")
    hand_xy = np.empty((frames, 2))
    hand_area = np.empty(frames, dtype=np.int64)
    moving = np.empty(frames, dtype=bool)
    for index, row in enumerate(rows):
        line = index + 2
        if len(row) != len(header):
            raise ValueError(f"{name}: line {line} has {len(row)} fields, expected "
                             f"{len(header)}")
        column = "frame"
        try:
            if int(row[0]) != index:
                raise ValueError(f"{name}: line {line}: field 'frame' must be {index}, "
                                 f"got {row[0]}")
            column = "hand_x"
            hand_xy[index, 0] = float(row[1])
            column = "hand_y"
            hand_xy[index, 1] = float(row[2])
            column = "hand_area"
            hand_area[index] = int(row[3])
            column = "moving"
            if row[4].strip() not in ("0", "1"):
                raise ValueError("not 0 or 1")
            moving[index] = row[4].strip() == "1"
            if postures is not None:
                column = "posture"
                if row[5].strip() != postures[index]:
                    raise ValueError(f"{name}: line {line}: field 'posture' must be "
                                     f"{postures[index]} (clip.json's postures), got {row[5]!r}")
        except ValueError as exc:
            if str(exc).startswith(name):
                raise
            raise ValueError(f"{name}: line {line}: bad field '{column}': "
                             f"{row[header.index(column)]!r}") from None
    return hand_xy, hand_area, moving


def load_clip(path, mmap: bool = True) -> Clip:
    """Read and validate a clip directory.

    Parameters
    ----------
    path : str or path-like
        The clip directory.
    mmap : bool
        Memory-map ``left.npy`` and ``right.npy`` read-only instead of reading them.

    Returns
    -------
    Clip

    Raises
    ------
    ValueError
        If the directory, a file or a field is missing or inconsistent; the
        message names the file and the field.
    """
    root = Path(path)
    if not root.is_dir():
        raise ValueError(f"{root}: not a clip directory")
    meta_path = root / _JSON
    if not meta_path.is_file():
        raise ValueError(f"{_JSON}: missing file in clip {root}")
    try:
        with open(meta_path, encoding="utf-8") as fh:
            meta = json.load(fh)
    except (ValueError, UnicodeDecodeError) as exc:
        raise ValueError(f"{_JSON}: not valid JSON ({exc})") from None
    _check_metadata(meta, _JSON)

    shape = (meta["frames"], meta["height"], 2 * meta["width"])
    left = _load_array(root / _LEFT, shape, mmap)
    right = _load_array(root / _RIGHT, shape, mmap)
    if "motion_frames" not in meta:             # footage
        if (root / _TRUTH).exists():
            raise ValueError(f"{_TRUTH}: present, but {_JSON} has no truth fields "
                             f"({', '.join(TRUTH_FIELDS)})")
        return Clip(fps=meta["fps"], left=left, right=right, gesture=meta.get("gesture"),
                    renderer=meta.get("renderer", {}), source=meta.get("source", {}))
    postures = _posture_frames(meta["postures"]) if "postures" in meta else None
    hand_xy, hand_area, moving = _load_truth(root / _TRUTH, meta["frames"], postures)

    clip = Clip(gesture=meta.get("gesture"), seed=meta["seed"], fps=meta["fps"],
                hand_disparity=meta["hand_disparity"],
                face_disparity=meta["face_disparity"],
                motion_frames=(meta["motion_frames"][0], meta["motion_frames"][1]),
                left=left, right=right, hand_xy=hand_xy, hand_area=hand_area,
                sequence=tuple((e["gesture"], *e["motion_frames"]) for e in meta["sequence"])
                if "sequence" in meta else None,
                distractors=tuple((e["kind"], *e["frames"]) for e in meta["distractors"])
                if "distractors" in meta else None, postures=postures,
                renderer=meta.get("renderer", {}), source=meta.get("source", {}))
    _check_truth_arrays(hand_xy, hand_area, clip.frames, _TRUTH)
    mismatch = np.flatnonzero(moving != clip.moving)
    if mismatch.size:
        raise ValueError(f"{_TRUTH}: field 'moving' at frame {int(mismatch[0])} disagrees "
                         f"with clip.json field 'motion_frames' {list(clip.motion_frames)}")
    return clip
