"""Gesture HMMs: the model file, the thesis' discrete left-right HMMs and
their forward algorithm (thesis §7.4, chapter 8; Rabiner's scaled forward
recursion), and the rejection rule every model file may carry.

Runs on the board's ARM: Python 3 and numpy only, nothing else from this
project. Training lives in :mod:`recognition`; both read and write the same
JSON model file through :func:`load_models` / :func:`save_models`.

Model file (JSON), version 6::

    {"format": "stereogest-hmm", "version": 6,
     "emission": "discrete" | "gaussian",
     "class_names": ["forward", ...],
     "rejection": null | {"statistic": "...", "thresholds": [t_0, ...]},
     "spotting": null | {"threshold_bias": b, "end_delay": n, "min_symbols": k,
                          "step": s, "max_gap": g, "max_gap_share": r},
                                         # max_gap, max_gap_share optional (0)
     "postures": null | {"command": [...], "share": s, "stop": "fist",
                         "stop_frames": n, "release_frames": n, "neutral": [...],
                         "power": {...}},
                                         # sw_hps.posture_commands; optional
     "commands": null | {"class": "robot command", ...},
                                         # sw_hps.class_commands; optional
     "verifier": null | {...},           # a gaussian model file's object with
                                         # rejection, the same classes; optional
     "meta": {...},                      # free-form: training options, accuracy
     # discrete (this module):
     "num_symbols": 8,
     "models": [{"pi": [...], "A": [[...]], "B": [[...]]}, ...],
     # gaussian (sw_hps.gaussian_hmm):
     "features": {"names": [...], "resample": 64, "weights": [...]},
     "models": [{"components": [{"stay": [...], "mean": [[...]], "var": [[...]]}, ...]}, ...]}

Version 1 files (discrete, no ``emission`` and no ``rejection``), version 2
files (no ``spotting``), version 3 files (no ``postures``), version 4
files (no ``commands``) and version 5 files (no ``verifier``) still load. ``spotting`` holds the options of the
continuous recogniser (:mod:`sw_hps.continuous`, discrete models only; null:
its defaults).
Discrete: one model per class; each has N states (N may differ between
classes), A is N x N, B is N x num_symbols, pi has N entries; every row sums
to 1.

``verifier`` (discrete models with ``spotting`` only): the isolated
recogniser that confirms each gesture the continuous recogniser spots
(:class:`sw_hps.streaming.StreamSpotter`): the spotted span's points must be
named the same class and not refused by its own thresholds. It is a whole
Gaussian model file's object, of the same class names, with rejection.

Rejection: the best class c is refused when the gesture's log-likelihood
under c divided by its length (symbols, or feature vectors) is below
``thresholds[c]`` (the decision is then "none").
"""
from __future__ import annotations

import json
import os
from dataclasses import dataclass, field, replace
from pathlib import Path

import numpy as np

from .continuous import check_spotting
from .class_commands import check_commands, command_of
from .posture_commands import check_posture_commands
# The file's identity lives in a standard-library module: the bundle checks it
# on a machine without numpy.
from .model_format import (EMISSIONS, MODEL_FORMAT, MODEL_VERSION, MODEL_VERSIONS, check_header,
                           read_json)

__all__ = ["MODEL_FORMAT", "MODEL_VERSION", "MODEL_VERSIONS", "EMISSIONS", "DiscreteHMM",
           "check_verifier",
           "GestureModels", "ForwardStream", "best_class", "check_thresholds", "decide", "load_models",
           "save_models"]
_ROW_TOLERANCE = 1e-6
#: Symbols between rescalings of the forward vector in ForwardStream.feed.
_RESCALE_EVERY = 4


def _matrix(name: str, value, shape: tuple[int, ...]) -> np.ndarray:
    try:
        arr = np.array(value, dtype=np.float64)
    except (TypeError, ValueError):
        raise ValueError(f"{name} must be a numeric array of shape {shape}") from None
    if arr.shape != shape:
        raise ValueError(f"{name} must have shape {shape}, got {arr.shape}")
    if not np.isfinite(arr).all():
        raise ValueError(f"{name} must be finite (no NaN or infinity)")
    if (arr < 0).any():
        raise ValueError(f"{name} must be non-negative")
    sums = arr.sum(axis=-1)
    if np.abs(sums - 1.0).max(initial=0.0) > _ROW_TOLERANCE:
        worst = float(sums.flat[np.abs(sums - 1.0).argmax()])
        raise ValueError(f"{name} rows must sum to 1 (within {_ROW_TOLERANCE}), found {worst!r}")
    return arr


@dataclass(frozen=True, eq=False)
class DiscreteHMM:
    """One discrete HMM: ``pi`` (N,), ``A`` (N, N), ``B`` (N, M); validated."""
    pi: np.ndarray
    A: np.ndarray
    B: np.ndarray

    def __post_init__(self):
        pi = np.asarray(self.pi, dtype=np.float64)
        if pi.ndim != 1 or pi.size == 0:
            raise ValueError(f"pi must be a non-empty vector, got shape {pi.shape}")
        n = pi.size
        b = np.asarray(self.B)
        if b.ndim != 2:
            raise ValueError(f"B must be a matrix (states x symbols), got shape {b.shape}")
        object.__setattr__(self, "pi", _matrix("pi", self.pi, (n,)))
        object.__setattr__(self, "A", _matrix("A", self.A, (n, n)))
        object.__setattr__(self, "B", _matrix("B", self.B, (n, b.shape[1])))

    @property
    def num_states(self) -> int:
        return self.pi.size

    @property
    def num_symbols(self) -> int:
        return self.B.shape[1]

    def log_likelihood(self, symbols) -> float:
        """log P(symbols | model) by the scaled forward algorithm (-inf if impossible)."""
        return float(ForwardStream([self]).feed(symbols)[0])


class ForwardStream:
    """Forward algorithm for several models at once, one symbol at a time.

    Keeps, per model, the normalised forward vector and the running
    log-likelihood (the sum of the logs of the scale factors), so sequences of
    any length neither underflow nor overflow. Models with fewer states are
    padded with unreachable states, which leaves their likelihoods unchanged.
    """

    def __init__(self, models):
        models = list(models)
        if not models:
            raise ValueError("models must hold at least one HMM")
        symbols = {m.num_symbols for m in models}
        if len(symbols) != 1:
            raise ValueError(f"all models must have the same number of symbols, got {sorted(symbols)}")
        self.num_symbols = symbols.pop()
        n = max(m.num_states for m in models)
        k = len(models)
        self._pi = np.zeros((k, n))
        self._a = np.zeros((k, n, n))
        self._b = np.full((k, self.num_symbols, n), 1.0 / self.num_symbols)
        for i, m in enumerate(models):
            s = m.num_states
            self._pi[i, :s] = m.pi
            self._a[i, :s, :s] = m.A
            self._a[i, s:, s:] = np.eye(n - s)
            self._b[i, :, :s] = m.B.T
        # The same models as one block-diagonal chain, for whole sequences (feed).
        self._pi_flat = self._pi.reshape(-1)
        self._a_block = np.zeros((k * n, k * n))
        for i in range(k):
            self._a_block[i * n:(i + 1) * n, i * n:(i + 1) * n] = self._a[i]
        self._b_flat = self._b.transpose(1, 0, 2).reshape(self.num_symbols, k * n)
        self.reset()

    def reset(self) -> None:
        """Forget every symbol seen so far."""
        self._alpha = None
        self._log = np.zeros(len(self._pi))
        self.length = 0

    def update(self, symbol: int) -> np.ndarray:
        """Take one symbol; return the log-likelihoods so far, one per model."""
        if isinstance(symbol, bool) or not isinstance(symbol, (int, np.integer)) \
                or not 0 <= symbol < self.num_symbols:
            raise ValueError(f"symbol must be an integer in [0, {self.num_symbols - 1}], "
                             f"got {symbol!r}")
        emit = self._b[:, int(symbol), :]
        if self._alpha is None:
            alpha = self._pi * emit
        else:
            alpha = np.einsum("kn,knm->km", self._alpha, self._a) * emit
        scale = alpha.sum(axis=1)
        alive = scale > 0
        with np.errstate(divide="ignore"):
            self._log = np.where(alive, self._log + np.log(np.where(alive, scale, 1.0)), -np.inf)
        self._alpha = np.where(alive[:, None], alpha / np.where(alive, scale, 1.0)[:, None], 0.0)
        self.length += 1
        return self._log.copy()

    def feed(self, symbols) -> np.ndarray:
        """Take a whole sequence; return the log-likelihoods so far.

        Same result as one :meth:`update` per symbol, computed on the
        block-diagonal chain of all models with the logs taken once at the end.
        """
        seq = np.asarray(symbols).reshape(-1)
        if seq.size == 0:
            return self.log_likelihoods()
        if seq.dtype.kind not in "iu" or seq.min() < 0 or seq.max() >= self.num_symbols:
            raise ValueError(f"symbols must be integers in [0, {self.num_symbols - 1}]")
        k, n = self._pi.shape
        emissions = self._b_flat[seq]
        scales = []
        alpha = None if self._alpha is None else self._alpha.reshape(-1)
        last = seq.size - 1
        for t in range(seq.size):
            if alpha is None:
                alpha = self._pi_flat * emissions[t]
            else:
                alpha = (alpha @ self._a_block) * emissions[t]
            # Rescale every _RESCALE_EVERY symbols: each symbol shrinks the
            # forward vector by at most its emission probabilities, far from
            # float64's underflow in so few steps, and saves most of the calls.
            if t % _RESCALE_EVERY == _RESCALE_EVERY - 1 or t == last:
                per_model = alpha.reshape(k, n)
                scale = per_model.sum(axis=1)
                scales.append(scale)
                alpha = (per_model / np.where(scale > 0, scale, 1.0)[:, None]).reshape(-1)
        with np.errstate(divide="ignore"):
            self._log = self._log + np.log(scales).sum(axis=0)
        self._alpha = alpha.reshape(k, n)
        self.length += seq.size
        return self.log_likelihoods()

    def log_likelihoods(self) -> np.ndarray:
        """Log-likelihood per model of the symbols fed since the last reset
        (0 for the empty sequence)."""
        return self._log.copy()


@dataclass(frozen=True, eq=False)
class GestureModels:
    """One HMM per gesture class, as stored in a model file."""
    class_names: tuple[str, ...]
    models: tuple[DiscreteHMM, ...]
    meta: dict = field(default_factory=dict, compare=False)
    #: Per class, the lowest log-likelihood per symbol accepted (None: never refuse).
    thresholds: tuple[float, ...] | None = None
    #: Options of the continuous recogniser (None: its defaults).
    spotting: dict | None = None
    #: The posture commands (:mod:`sw_hps.posture_commands`; None: none).
    postures: dict | None = None
    #: Robot command per class (:mod:`sw_hps.class_commands`; None: by name).
    commands: dict | None = None
    #: The isolated recogniser that confirms spotted gestures (module
    #: docstring; :class:`sw_hps.gaussian_hmm.GaussianGestureModels` or None).
    verifier: object = None

    emission = "discrete"

    def __post_init__(self):
        names = tuple(str(n) for n in self.class_names)
        if not names or len(set(names)) != len(names):
            raise ValueError(f"class_names must be unique and non-empty, got {list(names)}")
        if len(self.models) != len(names):
            raise ValueError(f"{len(names)} class_names but {len(self.models)} models")
        object.__setattr__(self, "class_names", names)
        object.__setattr__(self, "models", tuple(self.models))
        object.__setattr__(self, "thresholds", check_thresholds(self.thresholds, len(names)))
        if self.spotting is not None:
            object.__setattr__(self, "spotting", check_spotting(self.spotting))
        object.__setattr__(self, "postures", check_posture_commands(self.postures))
        object.__setattr__(self, "commands", check_commands(self.commands, names))
        ForwardStream(self.models)  # checks the symbol counts agree
        check_verifier(self.verifier, names)
        if self.verifier is not None and self.spotting is None:
            raise ValueError("verifier needs a spotting entry (it confirms spotted gestures)")

    def command_of(self, class_name: str) -> str | None:
        """The robot command a class sends (None: none)."""
        return command_of(self.commands, class_name)

    @property
    def num_symbols(self) -> int:
        return self.models[0].num_symbols

    def stream(self) -> ForwardStream:
        """A fresh streaming forward pass over every class model."""
        return ForwardStream(self.models)

    def scores(self, symbols) -> np.ndarray:
        """Log-likelihood of ``symbols`` under every class model."""
        return self.stream().feed(symbols)

    def classify(self, symbols) -> int:
        """Index of the most likely class (the first on ties); -1 if every model
        gives the sequence zero probability."""
        return best_class(self.scores(symbols))

    def decide(self, scores, steps: int) -> tuple[int, str | None]:
        """``(class, None)`` or ``(-1, reason)`` for the scores of ``steps`` symbols."""
        return decide(scores, steps, self.thresholds, self.class_names)

    def with_thresholds(self, thresholds) -> "GestureModels":
        return replace(self, thresholds=thresholds, meta=dict(self.meta))

    def to_dict(self) -> dict:
        return {"format": MODEL_FORMAT, "version": MODEL_VERSION, "emission": self.emission,
                "num_symbols": self.num_symbols, "class_names": list(self.class_names),
                "models": [{"pi": m.pi.tolist(), "A": m.A.tolist(), "B": m.B.tolist()}
                           for m in self.models],
                "rejection": None if self.thresholds is None else
                {"statistic": "mean log-likelihood per symbol",
                 "thresholds": list(self.thresholds)},
                "spotting": self.spotting, "postures": self.postures,
                "commands": self.commands,
                "verifier": None if self.verifier is None else self.verifier.to_dict(),
                "meta": self.meta}

    @classmethod
    def from_dict(cls, data) -> "GestureModels":
        """A discrete or a Gaussian model set (:class:`sw_hps.gaussian_hmm.
        GaussianGestureModels`), as the file's ``emission`` says."""
        version, emission = check_header(data)
        spotting = data.get("spotting") if version >= 3 else None
        if emission == "gaussian":
            if spotting is not None:
                raise ValueError("spotting must be null for gaussian models (the continuous "
                                 "recogniser runs discrete models)")
            from .gaussian_hmm import GaussianGestureModels
            return GaussianGestureModels.from_dict(data)
        names = data.get("class_names")
        entries = data.get("models")
        if not isinstance(names, list) or not isinstance(entries, list):
            raise ValueError("class_names and models must be lists")
        models = []
        for name, entry in zip(names, entries):
            if not isinstance(entry, dict) or not {"pi", "A", "B"} <= entry.keys():
                raise ValueError(f"model of class {name!r} must have pi, A and B")
            try:
                models.append(DiscreteHMM(entry["pi"], entry["A"], entry["B"]))
            except ValueError as exc:
                raise ValueError(f"model of class {name!r}: {exc}") from None
        if len(names) != len(entries):
            raise ValueError(f"{len(names)} class_names but {len(entries)} models")
        rejection = data.get("rejection")
        if rejection is not None and (not isinstance(rejection, dict)
                                      or "thresholds" not in rejection):
            raise ValueError("rejection must be null or an object with thresholds")
        verifier = data.get("verifier") if version >= 6 else None
        if verifier is not None:
            from .gaussian_hmm import GaussianGestureModels
            try:
                if not isinstance(verifier, dict) or check_header(verifier)[1] != "gaussian":
                    raise ValueError("must be a gaussian model file's object")
                verifier = GaussianGestureModels.from_dict(verifier)
            except ValueError as exc:
                raise ValueError(f"verifier: {exc}") from None
        result = cls(tuple(names), tuple(models), dict(data.get("meta") or {}),
                     None if rejection is None else rejection["thresholds"], spotting,
                     data.get("postures") if version >= 4 else None,
                     data.get("commands") if version >= 5 else None, verifier)
        if "num_symbols" in data and data["num_symbols"] != result.num_symbols:
            raise ValueError(f"num_symbols is {data['num_symbols']} but B has "
                             f"{result.num_symbols} columns")
        return result


def check_verifier(verifier, class_names) -> None:
    """A verifier must be Gaussian models of ``class_names`` (any order) with
    rejection thresholds; ``ValueError`` says which it is not."""
    if verifier is None:
        return
    if getattr(verifier, "emission", None) != "gaussian":
        raise ValueError("verifier must be gaussian models (they score a gesture's points)")
    if sorted(verifier.class_names) != sorted(class_names):
        raise ValueError(f"verifier classes {list(verifier.class_names)} must be the models' "
                         f"{list(class_names)}")
    if verifier.thresholds is None:
        raise ValueError("verifier must have rejection thresholds (trained without --no-reject)")


def check_thresholds(thresholds, num_classes: int) -> tuple[float, ...] | None:
    """``None`` or ``num_classes`` finite numbers (the rejection rule)."""
    if thresholds is None:
        return None
    try:
        arr = np.array(thresholds, dtype=np.float64)
    except (TypeError, ValueError):
        arr = None
    if arr is None or arr.shape != (num_classes,) or not np.isfinite(arr).all():
        raise ValueError(f"rejection thresholds must be {num_classes} finite numbers (one per "
                         f"class), got {thresholds!r}")
    return tuple(float(t) for t in arr)


def decide(scores, steps: int, thresholds, class_names) -> tuple[int, str | None]:
    """The best class, or -1 and the reason it was refused.

    Refused when no score is finite, or when the best class' log-likelihood
    per step (``score / steps``) is below its threshold.
    """
    best = best_class(scores)
    if best < 0:
        return -1, f"every model gives probability 0 to the {steps} steps"
    if thresholds is not None:
        per_step = float(scores[best]) / max(steps, 1)
        if per_step < thresholds[best]:
            return -1, (f"not a gesture: best class {class_names[best]!r} scores "
                        f"{per_step:.3f} per step, below its threshold {thresholds[best]:.3f}")
    return best, None


def best_class(scores) -> int:
    """Index of the largest finite score (first on ties), or -1 if none is finite."""
    scores = np.asarray(scores, dtype=np.float64)
    if not np.isfinite(scores).any():
        return -1
    return int(np.argmax(np.where(np.isfinite(scores), scores, -np.inf)))


def load_models(path) -> GestureModels:
    """Read and validate a model file; ``ValueError`` names what is wrong."""
    data = read_json(path)
    try:
        return GestureModels.from_dict(data)
    except ValueError as exc:
        raise ValueError(f"{path}: {exc}") from None


def save_models(models: GestureModels, path) -> None:
    """Write a model file through a temporary file (never half-written)."""
    path = Path(path)
    tmp = path.with_name(path.name + ".part")
    try:
        tmp.write_text(json.dumps(models.to_dict(), indent=1) + "\n")
        os.replace(tmp, path)
    finally:
        if tmp.exists():
            tmp.unlink()
