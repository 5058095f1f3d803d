"""The hand's posture on the board: the descriptor's registers to features,
and the posture classifier (an RBF support-vector machine, one-vs-one) with its
versioned model file. Python 3.7 and numpy 1.16 (the board's floor).

The features are the golden model's (:mod:`sim.model.posture` calls
:func:`posture_features` here, so both sides share one definition): each polar
count over the squared hand width of the reference, then per crossing band the
mean run starts per row and the largest.

The model file is JSON: ``format`` ``"stereogest-posture"``, ``version`` 1,
``class_names``, the standardisation (``mean``, ``scale``), ``gamma``, and the
machine (``n_support`` per class, ``dual_coef``, ``intercept``, and the support
vectors as little-endian float32 in base64), the way libsvm keeps a one-vs-one
RBF machine; ``min_votes`` (a posture whose winner has fewer one-vs-one votes is
refused; 0 refuses none) and ``meta`` (how it was trained).
"""
from __future__ import annotations

import base64

import numpy as np

from soc.hps_interface import (FIFO_BASE, POSTURE_BASE, POSTURE_DATA, POSTURE_INDEX,
                               POSTURE_LAYOUT, POSTURE_STATUS, POSTURE_STATUS_SEQ,
                               POSTURE_WORD_COUNT, POSTURE_WORDS, posture_layout_word,
                               posture_word_offsets)

from .posture_commands import read_names

__all__ = ["POSTURE_FORMAT", "POSTURE_VERSION", "PostureModel", "posture_features",
           "read_posture_model", "decode_posture_words", "record_features", "PostureReader",
           "POSTURE_OFFSET", "BUS_ACCESSES_PER_RECORD", "held_posture", "PostureTracker",
           "record_posture"]

#: The posture slave's offset from the FIFO slave's (the application's window base).
POSTURE_OFFSET = POSTURE_BASE - FIFO_BASE
#: Bus accesses per record read: Status, the Index write, the words, Status.
BUS_ACCESSES_PER_RECORD = POSTURE_WORD_COUNT + 3

POSTURE_FORMAT = "stereogest-posture"
POSTURE_VERSION = 1


def posture_features(polar, band_sum, band_rows, band_max, width):
    """The classifier's input from one frame's descriptor registers about a
    reference of hand width ``width`` (all zero when ``width`` is 0: no hand)."""
    polar = np.asarray(polar, dtype=float)
    band_sum = np.asarray(band_sum, dtype=float)
    bands = len(band_sum)
    out = np.zeros(len(polar) + 2 * bands)
    if width <= 0:
        return out
    out[:len(polar)] = polar / float(width * width)
    out[len(polar)::2] = band_sum / np.maximum(np.asarray(band_rows, dtype=float), 1.0)
    out[len(polar) + 1::2] = np.asarray(band_max, dtype=float)
    return out


def decode_posture_words(words):
    """One frame's posture record (the ``POSTURE_WORD_COUNT`` 32-bit words of
    :data:`soc.hps_interface.POSTURE_WORDS`) as a dict: ``reference`` (x, top,
    width), ``area``, the five sums, ``box`` (x_min, x_max, y_min, y_max),
    ``band_sum``, ``band_rows``, ``band_max`` and ``polar`` (ints).

    Raises ValueError for a record of another length or with a word outside
    32 bits (a torn or garbled read)."""
    words = [int(w) for w in words]
    if len(words) != POSTURE_WORD_COUNT:
        raise ValueError("a posture record has {} words, got {}".format(
            POSTURE_WORD_COUNT, len(words)))
    if any(not 0 <= w < 1 << 32 for w in words):
        raise ValueError("posture record words must lie in [0, 2**32)")
    at = posture_word_offsets()
    count = {name: n for name, n, _ in POSTURE_WORDS}

    def pair(word):
        return word & 0xFFFF, word >> 16

    def block(name):
        return words[at[name]:at[name] + count[name]]

    ref_x, top = pair(words[at["reference"]])
    out = {"reference": (ref_x, top, words[at["reference_width"]]),
           "area": words[at["area"]],
           "box": pair(words[at["box_x"]]) + pair(words[at["box_y"]]),
           "band_sum": block("band_sum"),
           "band_rows": [pair(w)[0] for w in block("band_rows_max")],
           "band_max": [pair(w)[1] for w in block("band_rows_max")],
           "polar": block("polar")}
    for name in ("sum_x", "sum_y", "sum_xx", "sum_yy", "sum_xy"):
        low, high = block(name)
        out[name] = low | high << 32
    return out


def record_features(record):
    """The classifier's input from a decoded record (:func:`decode_posture_words`)."""
    return posture_features(record["polar"], record["band_sum"], record["band_rows"],
                            record["band_max"], record["reference"][2])


class PostureReader:
    """The latest frame's posture record from the posture slave
    (:data:`soc.hps_interface.POSTURE_REGISTERS`) at ``offset`` of ``bus``.

    :meth:`read` takes a record at most once (by Status.SEQ), in
    :data:`BUS_ACCESSES_PER_RECORD` accesses; a record that two newer ones
    may have overwritten while it was read (SEQ advanced by 2 or more) is read
    again, up to ``retries`` times.

    Attributes
    ----------
    records, torn : int
        Records read, and reads given up or repeated because they may be torn.
    frame : int or None
        The last record read, counted in records since the first one read
        (SEQ without its wrap; None before the first).
    """

    def __init__(self, bus, offset=POSTURE_OFFSET, retries=2):
        self.bus, self.offset, self.retries = bus, int(offset), int(retries)
        self.last_seq = None
        self.frame = None
        self.records = 0
        self.torn = 0

    def _read(self, register):
        return self.bus.read32(self.offset + register)

    def layout_ok(self):
        """Whether the slave's record has this application's layout (Layout)."""
        return self._read(POSTURE_LAYOUT) == posture_layout_word()

    def read(self):
        """``(seq, words)`` of a record not read before, or None (none new, or
        one torn ``retries + 1`` times)."""
        for _ in range(self.retries + 1):
            seq = self._read(POSTURE_STATUS) & POSTURE_STATUS_SEQ
            if seq == self.last_seq or (seq == 0 and self.last_seq is None):
                return None           # none new (0 before the first: none yet)
            self.bus.write32(self.offset + POSTURE_INDEX, 0)
            words = [self._read(POSTURE_DATA) for _ in range(POSTURE_WORD_COUNT)]
            after = self._read(POSTURE_STATUS) & POSTURE_STATUS_SEQ
            if (after - seq) & POSTURE_STATUS_SEQ < 2:
                self.frame = 0 if self.frame is None else \
                    self.frame + ((seq - self.last_seq) & POSTURE_STATUS_SEQ)
                self.last_seq = seq
                self.records += 1
                return seq, words
            self.torn += 1
        return None


def record_posture(model, words):
    """The posture ``model`` names for one record (its words), or None: no
    hand in the record's reference (nothing to describe), or refused."""
    if not words[posture_word_offsets()["reference_width"]]:
        return None
    return model.classify(record_features(decode_posture_words(words)))


def held_posture(names):
    """The posture held over most of a gesture's frames (``names``: each
    frame's posture, None where refused or unknown) and the share of the
    frames in it: ``(name, share)``; a tie goes to a named posture; ``(None,
    None)`` for no frames."""
    names = list(names)
    if not names:
        return None, None
    counts = {}
    for name in names:
        counts[name] = counts.get(name, 0) + 1
    best = max(counts, key=lambda n: (counts[n], n is not None))
    return best, round(counts[best] / len(names), 3)


class PostureTracker:
    """Each frame's posture while the board application runs: at each poll
    the latest record (:class:`PostureReader`) is classified by ``model`` and
    kept for the frame the poll reached (the last ``keep`` frames); a
    gesture's posture is then :meth:`held` over its frames. A fault of the
    reader or the model costs that frame's posture, never the loop.

    The streaming loop numbers frames by the FIFO's records; the thesis loop,
    which sees no frames outside gestures, by the posture records themselves
    (``frame`` None: the reader's :attr:`PostureReader.frame`).

    Attributes
    ----------
    errors : int
        Polls that raised (the frame's posture is unknown).
    """

    def __init__(self, reader, model, keep=1024):
        self.reader, self.model, self.keep = reader, model, int(keep)
        self.names = {}
        self.errors = 0
        self.last = None         # the latest frame's posture

    def reset(self):
        """A new stream: frames count from 0 again."""
        self.names.clear()

    def poll(self, frame=None):
        """Read the latest record, if new, as frame ``frame``'s posture (None:
        the record's own number). Returns the frame it was kept for, or None
        (no new record, or a fault)."""
        try:
            record = self.reader.read()
            if record is None:
                return None
            if frame is None:
                frame = self.reader.frame
            name = record_posture(self.model, record[1])
        except Exception:
            self.errors += 1
            return None
        self.last = self.names[frame] = name
        for old in [f for f in self.names if f <= frame - self.keep]:
            del self.names[old]
        return frame

    def held(self, first, last):
        """``(name, share)`` over the frames ``first`` .. ``last`` whose record
        was read (at most the last ``keep``); ``(None, None)`` if either is
        None or none was read."""
        if first is None or last is None:
            return None, None
        return held_posture(self.read_names(first, last))

    def read_names(self, first, last):
        """The postures of the frames ``first`` .. ``last`` whose record was read
        (at most the last ``keep``; none if either is None)."""
        if first is None or last is None:
            return []
        return read_names(self.names, first, last, self.keep)


def _numbers(value):
    """Whether ``value`` is a number or nested lists of numbers (no bool, no string)."""
    if isinstance(value, list):
        return all(_numbers(v) for v in value)
    return isinstance(value, (int, float)) and not isinstance(value, bool)


def _array(data, key, shape, dtype=float):
    if key not in data:
        raise ValueError("posture model has no {}".format(key))
    if not _numbers(data[key]):
        raise ValueError("{} must be numbers".format(key))
    try:
        value = np.asarray(data[key], dtype=dtype)
    except (TypeError, ValueError, OverflowError):
        raise ValueError("{} must be numbers of shape {}".format(key, shape)) from None
    if value.shape != shape or not np.all(np.isfinite(value)):
        raise ValueError("{} must be finite numbers of shape {}, got shape {}".format(
            key, shape, value.shape))
    return value


class PostureModel:
    """A one-vs-one RBF support-vector machine over standardised features.

    Parameters
    ----------
    class_names : list of str
        The postures, in the order of ``n_support``.
    mean, scale : (F,) floats
        Standardisation: ``(features - mean) / scale`` (``scale`` > 0).
    gamma : float > 0
        The kernel ``exp(-gamma * |a - b|^2)``.
    support_vectors : (S, F) float32
        Grouped by class, ``n_support[c]`` of class ``c`` in class order.
    n_support : (C,) ints
    dual_coef : (C - 1, S) floats
        libsvm's layout: for the pair (i, j), the coefficients of class i's
        vectors are in row j - 1, those of class j's in row i.
    intercept : (C (C - 1) / 2,) floats
        One per pair (0, 1), (0, 2) ... (1, 2) ...
    min_votes : int in [0, C - 1]
        A decision whose winner has fewer votes is refused (-1, ``None``).
    meta : dict
        How the model was made (data, picture size, augmentation, C).
    """

    def __init__(self, class_names, mean, scale, gamma, support_vectors, n_support,
                 dual_coef, intercept, min_votes=0, meta=None):
        self.class_names = list(class_names)
        self.mean = np.asarray(mean, dtype=float)
        self.scale = np.asarray(scale, dtype=float)
        self.gamma = float(gamma)
        self.support_vectors = np.asarray(support_vectors, dtype=np.float32)
        self.n_support = np.asarray(n_support, dtype=np.int64)
        self.dual_coef = np.asarray(dual_coef, dtype=float)
        self.intercept = np.asarray(intercept, dtype=float)
        self.min_votes = int(min_votes)
        self.meta = dict(meta or {})
        self._starts = np.concatenate([[0], np.cumsum(self.n_support)])
        self._sv = self.support_vectors.astype(float)
        self._sv_norms = (self._sv ** 2).sum(axis=1)

    @property
    def features(self) -> int:
        return len(self.mean)

    def decide(self, features):
        """The class index of each row of ``features`` (N x F): the most votes
        of the one-vs-one machines, the lowest index on a tie; -1 (refused)
        when the winner has fewer than ``min_votes``."""
        x = np.atleast_2d(np.asarray(features, dtype=float))
        if x.ndim != 2 or x.shape[1] != self.features:
            raise ValueError("features must be rows of {} numbers, got shape {}".format(
                self.features, x.shape))
        x = (x - self.mean) / self.scale
        d2 = (x ** 2).sum(axis=1)[:, None] + self._sv_norms[None, :] - 2.0 * x.dot(self._sv.T)
        kernel = np.exp(-self.gamma * np.maximum(d2, 0.0))
        n = len(self.class_names)
        votes = np.zeros((len(x), n), dtype=np.int64)
        s = self._starts
        pair = 0
        for i in range(n):
            for j in range(i + 1, n):
                value = (kernel[:, s[i]:s[i + 1]].dot(self.dual_coef[j - 1, s[i]:s[i + 1]])
                         + kernel[:, s[j]:s[j + 1]].dot(self.dual_coef[i, s[j]:s[j + 1]])
                         + self.intercept[pair])
                votes[:, i] += value > 0
                votes[:, j] += value <= 0
                pair += 1
        best = votes.argmax(axis=1)
        return np.where(votes.max(axis=1) >= self.min_votes, best, -1)

    def classify(self, features):
        """The posture's name for one feature vector, or None (refused)."""
        k = int(self.decide(features)[0])
        return self.class_names[k] if k >= 0 else None

    def to_dict(self) -> dict:
        sv = self.support_vectors.astype("<f4")
        return {"format": POSTURE_FORMAT, "version": POSTURE_VERSION,
                "class_names": self.class_names, "features": self.features,
                "mean": self.mean.tolist(), "scale": self.scale.tolist(), "gamma": self.gamma,
                "n_support": self.n_support.tolist(), "dual_coef": self.dual_coef.tolist(),
                "intercept": self.intercept.tolist(), "min_votes": self.min_votes,
                "meta": self.meta,
                "support_vectors": {"shape": list(sv.shape),
                                    "float32_base64": base64.b64encode(sv.tobytes()).decode()}}

    @classmethod
    def from_dict(cls, data) -> "PostureModel":
        """The model of a parsed model file; ``ValueError`` names the first
        field that is wrong."""
        if not isinstance(data, dict):
            raise ValueError("posture model must be a JSON object")
        if data.get("format") != POSTURE_FORMAT:
            raise ValueError("format must be {!r}, got {!r}".format(POSTURE_FORMAT,
                                                                    data.get("format")))
        if data.get("version") != POSTURE_VERSION or isinstance(data.get("version"), bool):
            raise ValueError("version must be {}, got {!r}".format(POSTURE_VERSION,
                                                                  data.get("version")))
        names = data.get("class_names")
        if not isinstance(names, list) or len(names) < 2 \
                or not all(isinstance(n, str) and n for n in names) \
                or len(set(names)) != len(names):
            raise ValueError("class_names must be at least 2 unique non-empty strings")
        features = data.get("features")
        if not isinstance(features, int) or isinstance(features, bool) \
                or not 1 <= features <= 4096:
            raise ValueError("features must be an integer in [1, 4096], got {!r}".format(
                features))
        mean = _array(data, "mean", (features,))
        scale = _array(data, "scale", (features,))
        if not np.all(scale > 0):
            raise ValueError("scale must be > 0")
        gamma = data.get("gamma")
        if not isinstance(gamma, (int, float)) or isinstance(gamma, bool) \
                or not 0 < gamma < 1e6:
            raise ValueError("gamma must be a number in (0, 1e6), got {!r}".format(gamma))
        n = len(names)
        counts = data.get("n_support")
        if not isinstance(counts, list) or len(counts) != n \
                or not all(isinstance(v, int) and not isinstance(v, bool)
                           and 1 <= v <= 10 ** 7 for v in counts):
            raise ValueError("n_support must be {} integers in [1, 1e7]".format(n))
        n_support = np.asarray(counts, dtype=np.int64)
        total = int(n_support.sum())
        block = data.get("support_vectors")
        if not isinstance(block, dict) or block.get("shape") != [total, features] \
                or not isinstance(block.get("float32_base64"), str):
            raise ValueError("support_vectors must hold shape [{}, {}] and float32_base64"
                             .format(total, features))
        try:
            raw = base64.b64decode(block["float32_base64"].encode(), validate=True)
        except ValueError:
            raise ValueError("support_vectors' float32_base64 is not base64") from None
        if len(raw) != 4 * total * features:
            raise ValueError("support_vectors' float32_base64 must hold {} float32".format(
                total * features))
        sv = np.frombuffer(raw, dtype="<f4").reshape(total, features)
        if not np.all(np.isfinite(sv)):
            raise ValueError("support_vectors must be finite")
        dual = _array(data, "dual_coef", (n - 1, total))
        intercept = _array(data, "intercept", (n * (n - 1) // 2,))
        min_votes = data.get("min_votes", 0)
        if not isinstance(min_votes, int) or isinstance(min_votes, bool) \
                or not 0 <= min_votes <= n - 1:
            raise ValueError("min_votes must be an integer in [0, {}], got {!r}".format(
                n - 1, min_votes))
        meta = data.get("meta", {})
        if not isinstance(meta, dict):
            raise ValueError("meta must be a JSON object")
        sizes = meta.get("picture_sizes")
        if sizes is not None and not (isinstance(sizes, list) and sizes and all(
                isinstance(size, list) and len(size) == 2 and all(
                    isinstance(v, int) and not isinstance(v, bool) and 8 <= v <= 8192
                    for v in size) for size in sizes)):
            raise ValueError("meta picture_sizes must be a list of [height, width], each an "
                             "integer in [8, 8192], got {!r}".format(sizes))
        return cls(names, mean, scale, gamma, sv, n_support, dual, intercept, min_votes, meta)


def read_posture_model(path) -> PostureModel:
    """The model in the file ``path``; ``ValueError`` with one line naming the
    file and the field."""
    from sw_hps.model_format import read_json
    data = read_json(path)
    try:
        return PostureModel.from_dict(data)
    except ValueError as error:
        raise ValueError("{}: {}".format(path, error)) from None
