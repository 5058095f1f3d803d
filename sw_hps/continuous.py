"""Continuous gesture recognition with a threshold model (issue 28; thesis
§10.1, its first limitation: gestures one after another, no rest between them,
and motion that is no gesture in between).

Runs on the board's ARM: Python 3 and numpy only.

The threshold model (Lee and Kim, IEEE PAMI 21(10), 1999) is an ergodic HMM
built from the gesture models' own states: every state of every class keeps
its emission probabilities and its self-transition, and leaves to each other
state with equal probability. It explains any sequence of gesture pieces in
any order, so its likelihood is an adaptive threshold: a class whose final
state scores above it has explained the recent symbols better than any
patchwork of pieces. Nothing is trained for it; its one option is
``threshold_bias``, log-likelihood per symbol added to the threshold model
(> 0 refuses more, < 0 accepts more: with many classes the threshold model
can follow nearly any sequence, and a small negative bias, calibrated on
held-out people, lets true gestures through).

Decoding is a causal Viterbi pass over one network: the class models and the
threshold model side by side, each entered from the best end score of the
step before (a loop, so gestures follow each other with or without motion
between them). Each gesture state carries the step its path entered the class
model (its start). A step whose best end is a class' final state (and whose
path is at least ``min_symbols`` long) is a candidate; the best candidate of
a run is named once ``end_delay`` frames pass without a better one, or when
the source says the hand left or stopped (:meth:`ContinuousRecogniser.flush`).
A named gesture's symbols cannot start another: every path that entered a
class model at or before its last step is dropped, so nothing is named twice.
An optional ``confirm`` callable has the last word on each gesture about to be
named: one it refuses is forgotten without dropping any path, so its symbols
may still end or start the gesture that follows (a wave joined to the
gesture after it, refused, leaves that gesture to be named).

A gesture is one motion: with ``max_gap`` > 0, a symbol that comes more than
``max_gap`` frames after the one before (the hand held still, or crept,
in between) ends every path inside a class model, so no gesture spans such a
pause. Left-right HMMs do not model time (a state's duration is geometric),
and motion that is no gesture (a reach for a cup and back, a slow drift)
often traces a gesture's shape with a hold in it; ``max_gap`` is learned from
the training gestures (:func:`recognition.continuous.symbol_gap`), the
longest wait between two symbols of any of them.

A pause a gesture does not have is also a matter of share: a gesture flows,
its longest wait between two symbols a small part of its time (about a
fifth of its span in the development corpus, at most 0.38 in 99.5 % of its
gestures), while a reach for a cup waits at the cup and a face scratch at
the face about as long as the moves there and back took. With
``max_gap_share`` > 0 a class' end whose path waited longer than that share
of its span (frames from its first symbol to its last) between two of its
symbols is no candidate. Unlike ``max_gap`` it does not depend on the speed:
a slow gesture's waits grow with its span. It is learned from the training
gestures too (:func:`recognition.continuous.symbol_gap_share`).
"""
from __future__ import annotations

from dataclasses import dataclass
from typing import NamedTuple

import numpy as np

__all__ = ["Detection", "ContinuousRecogniser", "threshold_model", "SPOTTING_DEFAULTS",
           "STEP_WIDTH", "check_spotting", "step_pixels"]

#: Options of the continuous recogniser and their defaults; a model file's
#: ``spotting`` entry may set each (validated by :func:`check_spotting`).
#: ``step`` is the travel per symbol (:class:`sw_hps.orientation.DistanceSymbols`)
#: in pixels of a :data:`STEP_WIDTH`-pixel-wide frame, scaled to the frame's width.
#: ``max_gap`` (frames; 0 = no limit) is the longest wait between two symbols
#: of one gesture, ``max_gap_share`` (0 = no limit) that wait's largest share
#: of the gesture's span (module docstring). ``end_delay`` 2 was chosen on the
#: development data (synthetic corpus seed 11; rendered sessions with
#: distractors, seeds 300-309 and hard scene 300-304): from 8 down to 1 frame
#: F1 and false commands did not move, the median latency fell from 11 to -5
#: frames (the last symbol comes before the hand settles); 2 keeps a frame of
#: margin against noise.
SPOTTING_DEFAULTS = {"threshold_bias": 0.0, "end_delay": 2, "min_symbols": 4, "step": 20,
                     "max_gap": 0, "max_gap_share": 0.0}
_RANGES = {"threshold_bias": (-10.0, 10.0), "end_delay": (1, 1000), "min_symbols": (1, 1000),
           "step": (1, 640), "max_gap": (0, 10000), "max_gap_share": (0.0, 1.0)}
#: Symbol frames kept for ``max_gap_share`` (a longer gesture is judged on its
#: last ones).
_GAP_HISTORY = 1024
#: The frame width ``step`` is given at (the board's 640 x 480).
STEP_WIDTH = 640
_NEG = -np.inf


def check_spotting(options) -> dict:
    """The defaults updated by ``options`` (a dict or None); ``ValueError``
    names the option and its allowed range."""
    if options is None:
        return dict(SPOTTING_DEFAULTS)
    if not isinstance(options, dict):
        raise ValueError("spotting must be null or an object")
    unknown = sorted(set(options) - set(SPOTTING_DEFAULTS))
    if unknown:
        raise ValueError(f"spotting: unknown option(s) {', '.join(unknown)} (allowed: "
                         f"{', '.join(SPOTTING_DEFAULTS)})")
    out = dict(SPOTTING_DEFAULTS)
    for key, value in options.items():
        lo, hi = _RANGES[key]
        integer = isinstance(SPOTTING_DEFAULTS[key], int)
        ok = not isinstance(value, bool) and (
            isinstance(value, int) if integer else isinstance(value, (int, float)))
        if not ok or not lo <= value <= hi or value != value:
            kind = "an integer" if integer else "a number"
            raise ValueError(f"spotting {key} must be {kind} in [{lo}, {hi}], got {value!r}")
        out[key] = int(value) if integer else float(value)
    return out


def step_pixels(step: int, frame_width: int) -> int:
    """The spotting option ``step`` (pixels at :data:`STEP_WIDTH`) at a frame
    ``frame_width`` pixels wide (at least 1)."""
    return max(1, round(step * frame_width / STEP_WIDTH))


def threshold_model(models):
    """``(log_a, log_b)`` of the threshold model of discrete ``models``
    (:class:`sw_hps.hmm.DiscreteHMM`): S states (all of theirs), ``log_a``
    (S, S), ``log_b`` (S, symbols). State i keeps its model's a_ii and goes to
    each other state with (1 - a_ii) / (S - 1)."""
    stay = np.concatenate([np.diag(m.A) for m in models])
    b = np.concatenate([m.B for m in models])
    s = len(stay)
    if s == 1:
        a = np.ones((1, 1))
    else:
        a = np.repeat(((1.0 - stay) / (s - 1))[:, None], s, axis=1)
        np.fill_diagonal(a, stay)
    with np.errstate(divide="ignore"):
        return np.log(a), np.log(b)


@dataclass(frozen=True)
class Detection:
    """A gesture named in a stream: its class, the frames of its first and last
    symbol (inclusive), its score (the class' log-likelihood above the threshold
    model's at its end) and the frame at which it was named."""
    class_index: int
    name: str
    first: int
    last: int
    score: float
    named_at: int


class _Candidate(NamedTuple):
    """The best gesture end seen and not yet named."""
    class_index: int
    first_symbol: int       # symbols are counted from the last reset
    last_symbol: int
    first_frame: int
    last_frame: int
    score: float
    found_at: int           # the frame it was last improved


class ContinuousRecogniser:
    """Frame-by-frame spotting of discrete gesture models (module docstring).

    Parameters
    ----------
    models : sw_hps.hmm.GestureModels
        Discrete class models (one left-right HMM per class).
    confirm : callable, optional
        ``confirm(class_index, first_frame, last_frame) -> bool``, asked
        before a gesture is named (module docstring); None names every one.
    threshold_bias, end_delay, min_symbols, step, max_gap, max_gap_share
        :data:`SPOTTING_DEFAULTS`; ``end_delay`` and ``max_gap`` in frames;
        ``step`` is kept (:attr:`symbol_step`) for whoever makes the symbols.

    Call :meth:`step` once per frame with that frame's symbol (None when the
    hand did not move enough for one), :meth:`flush` when the hand leaves or
    the source ends; both return the gestures named then. The state is fixed
    in size: a stream of any length runs in constant memory.
    """

    def __init__(self, models, confirm=None, **options):
        if getattr(models, "emission", "discrete") != "discrete":
            raise ValueError("the continuous recogniser needs discrete models "
                             f"(emission 'discrete'), got {models.emission!r}")
        opts = check_spotting(options)
        self.confirm = confirm
        self.threshold_bias = opts["threshold_bias"]
        self.end_delay = opts["end_delay"]
        self.min_symbols = opts["min_symbols"]
        self.symbol_step = opts["step"]
        self.max_gap = opts["max_gap"]
        self.max_gap_share = opts["max_gap_share"]
        self.class_names = tuple(models.class_names)
        hmms = list(models.models)
        offsets = np.concatenate([[0], np.cumsum([m.num_states for m in hmms])])
        n = int(offsets[-1])
        self._last = offsets[1:] - 1                      # each class' final state
        with np.errstate(divide="ignore"):
            # the class models as one block-diagonal chain (-inf between classes)
            self._log_a = np.full((n, n), _NEG)
            for m, lo, hi in zip(hmms, offsets[:-1], offsets[1:]):
                self._log_a[lo:hi, lo:hi] = np.log(m.A)
            self._log_pi = np.concatenate([np.log(m.pi) for m in hmms])
            self._log_b = np.concatenate([np.log(m.B) for m in hmms]).T.copy()   # (M, n)
        t_a, t_b = threshold_model(hmms)
        self._t_log_a = t_a
        self._t_log_b = t_b.T.copy()
        self._t_enter = -np.log(len(t_a))
        self._inner = np.ones(n, bool)              # not a final state
        self._inner[self._last] = False
        self._frame = -1
        self.reset()

    def reset(self) -> None:
        """Forget every path and what is pending (a new stream, or the hand left)."""
        n = len(self._log_pi)
        self._v = np.full(n, _NEG)
        self._start = np.zeros(n, np.int64)         # each path's first symbol
        self._start_frame = np.zeros(n, np.int64)   # and its frame
        self._t = np.full(len(self._t_log_a), _NEG)
        self._loop = 0.0
        self._symbols = 0
        self._pending = None
        self._longer = False             # a longer gesture may hold the pending one
        self._symbol_frames = np.zeros(_GAP_HISTORY, np.int64)   # symbol k's at k % size

    @property
    def pending(self) -> bool:
        """A gesture end has been found and is not yet named."""
        return self._pending is not None

    def step(self, frame: int, symbol=None) -> list[Detection]:
        """Take frame ``frame`` (rising) and its symbol (0..M-1, or None)."""
        frame = int(frame)
        self._frame = frame
        named = self._take(int(symbol), frame) if symbol is not None else []
        if self._pending is not None:
            waited = frame - self._pending.found_at
            if waited >= self.end_delay and (not self._longer or waited >= 4 * self.end_delay):
                named += self._name(frame)
        return named

    def flush(self, frame: int | None = None) -> list[Detection]:
        """The hand left, stopped for good, or the source ended: name what is
        pending and start afresh (no path runs across)."""
        frame = self._frame if frame is None else int(frame)
        named = self._name(frame) if self._pending is not None else []
        self.reset()
        self._frame = frame
        return named

    def _take(self, symbol: int, frame: int) -> list[Detection]:
        if not 0 <= symbol < self._log_b.shape[0]:
            raise ValueError(f"symbol must be in [0, {self._log_b.shape[0] - 1}] or None, "
                             f"got {symbol}")
        k = self._symbols
        if self.max_gap and k \
                and frame - self._symbol_frames[(k - 1) % _GAP_HISTORY] > self.max_gap:
            self._v = np.full(len(self._v), _NEG)     # no gesture spans the pause
        self._symbol_frames[k % _GAP_HISTORY] = frame
        loop = self._loop
        # class models: stay on the chain, or enter from the loop
        moved = self._v[:, None] + self._log_a
        best_from = moved.argmax(axis=0)
        stay = moved[best_from, np.arange(len(best_from))]
        # entering costs what entering the threshold model costs, so a path
        # does not restart on every symbol its first state's copy explains
        enter = loop + self._t_enter + self._log_pi
        entering = enter > stay
        v = np.where(entering, enter, stay) + self._log_b[symbol]
        start = np.where(entering, k, self._start[best_from])
        start_frame = np.where(entering, frame, self._start_frame[best_from])
        # the threshold model
        t = np.maximum((self._t[:, None] + self._t_log_a).max(axis=0), loop + self._t_enter)
        t = t + self._t_log_b[symbol] + self.threshold_bias
        ends = v[self._last]
        t_best = t.max()
        best = int(ends.argmax())
        loop = max(float(ends[best]), float(t_best))
        if np.isfinite(loop):       # relative scores only: keep them near 0
            v, t = v - loop, t - loop
            ends = ends - loop
            t_best = t_best - loop
            loop = 0.0
        self._v, self._start, self._start_frame = v, start, start_frame
        self._t, self._loop = t, loop
        self._symbols = k + 1
        end = self._last[best]
        first = int(start[end])
        named = []
        if ends[best] > t_best and k - first + 1 >= self.min_symbols \
                and self._flows(first, k):
            found = _Candidate(best, first, k, int(start_frame[end]), frame,
                               float(ends[best] - t_best), frame)
            pending = self._pending
            if pending is not None and first > pending.last_symbol:
                # a gesture after the pending one: that one is over
                named += self._name(frame)
                pending = None
            # a better end; the same path on at no loss (the end state's run);
            # another class' gesture that holds the pending one
            if pending is None or found.score > pending.score \
                    or (best == pending.class_index and first == pending.first_symbol
                        and found.score >= pending.score) \
                    or (best != pending.class_index and first <= pending.first_symbol):
                self._pending = found
        pending = self._pending
        # a longer gesture still under way over the pending one's symbols,
        # explaining them better than the threshold model: wait for it
        self._longer = pending is not None and bool(
            ((v > t_best) & self._inner & (start <= pending.first_symbol)).any())
        return named

    def _flows(self, first: int, last: int) -> bool:
        """Symbols ``first``..``last`` wait no longer than ``max_gap_share`` of
        their span between two of them (always, with the option off)."""
        if not self.max_gap_share:
            return True
        first = max(first, last - _GAP_HISTORY + 1)
        frames = self._symbol_frames[np.arange(first, last + 1) % _GAP_HISTORY]
        span = int(frames[-1] - frames[0])
        return span == 0 or int(np.diff(frames).max()) <= self.max_gap_share * span

    def _name(self, frame: int) -> list[Detection]:
        """Name the pending gesture (a list of it, or empty if ``confirm``
        refuses it); every path that began within a named gesture's symbols
        ends here, so what it used starts nothing else."""
        p, self._pending = self._pending, None
        if self.confirm is not None \
                and not self.confirm(int(p.class_index), p.first_frame, p.last_frame):
            return []
        self._v[self._start <= p.last_symbol] = _NEG
        return [Detection(int(p.class_index), self.class_names[p.class_index], p.first_frame,
                          p.last_frame, p.score, frame)]
