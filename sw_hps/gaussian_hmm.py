"""Left-right HMMs with diagonal Gaussian emissions over whole-gesture
features (:mod:`sw_hps.stroke`): the continuous alternative to the thesis'
discrete orientation-symbol models (§7.4), scored by the forward algorithm.

Runs on the board's ARM: Python 3 and numpy only, nothing else from this
project. Training lives in :mod:`recognition.gaussian_train`.

Each class has one or more *components* (left-right HMMs trained on
clusters of its samples, like several templates per gesture); a class
scores the best of its components. A component of N states has

* ``stay`` (N,): ``a_ii``; the chain moves to ``i+1`` with ``1 - a_ii``; the
  last state is absorbing (``stay[-1] = 1``); it starts in state 0;
* ``mean``, ``var`` (N, F): per state and feature, a Gaussian.

The log-emission of a feature vector is the per-feature Gaussian
log-density times the feature's weight (``weights``, one per feature),
summed over the features. A gesture must end in the last state (the whole
gesture has been made), so its log-likelihood is the log forward variable of
the last state after the last vector.
"""
from __future__ import annotations

from dataclasses import dataclass, field, replace

import numpy as np

from .class_commands import check_commands, command_of
from .hmm import MODEL_FORMAT, MODEL_VERSION, check_thresholds, decide
from .posture_commands import check_posture_commands
from .stroke import FEATURE_NAMES, RESAMPLE_RANGE, stroke_features

__all__ = ["GaussianHMM", "GaussianGestureModels", "log_emissions", "forward_log_lattice",
           "forward_log_likelihood"]

_LOG_2PI = float(np.log(2 * np.pi))


def _array(name: str, value, ndim: int) -> np.ndarray:
    try:
        arr = np.array(value, dtype=np.float64)
    except (TypeError, ValueError):
        raise ValueError(f"{name} must be a numeric array") from None
    if arr.ndim != ndim or arr.size == 0:
        raise ValueError(f"{name} must be a non-empty {ndim}-D array, got shape {arr.shape}")
    if not np.isfinite(arr).all():
        raise ValueError(f"{name} must be finite (no NaN or infinity)")
    return arr


@dataclass(frozen=True, eq=False)
class GaussianHMM:
    """One left-right component: ``stay`` (N,), ``mean`` and ``var`` (N, F); validated."""
    stay: np.ndarray
    mean: np.ndarray
    var: np.ndarray

    def __post_init__(self):
        stay = _array("stay", self.stay, 1)
        mean = _array("mean", self.mean, 2)
        var = _array("var", self.var, 2)
        n = stay.size
        if mean.shape[0] != n or var.shape != mean.shape:
            raise ValueError(f"mean and var must have shape ({n}, F) for {n} states, got "
                             f"{mean.shape} and {var.shape}")
        if (stay < 0).any() or (stay > 1).any():
            raise ValueError("stay must hold probabilities in [0, 1]")
        if stay[-1] != 1.0:
            raise ValueError(f"stay of the last state must be 1 (absorbing), got {stay[-1]!r}")
        if not (var > 0).all():
            raise ValueError("var must be > 0")
        object.__setattr__(self, "stay", stay)
        object.__setattr__(self, "mean", mean)
        object.__setattr__(self, "var", var)

    @property
    def num_states(self) -> int:
        return self.stay.size

    @property
    def num_features(self) -> int:
        return self.mean.shape[1]

    def to_dict(self) -> dict:
        return {"stay": self.stay.tolist(), "mean": self.mean.tolist(),
                "var": self.var.tolist()}


def log_emissions(features: np.ndarray, mean: np.ndarray, var: np.ndarray,
                  weights: np.ndarray) -> np.ndarray:
    """Weighted diagonal-Gaussian log-densities.

    ``features`` (..., T, F), ``mean``/``var`` (K, N, F), ``weights`` (F,)
    give (..., K, T, N): ``-1/2 sum_f w_f ((x_f - m_f)^2 / v_f + log v_f + log 2 pi)``,
    expanded into two matrix products (x^2 and x against per-state factors)
    so that no (K, T, N, F) temporary is built.
    """
    k, n, f = mean.shape
    x = np.asarray(features, dtype=np.float64)
    precision = weights / var                                        # (K, N, F)
    linear = precision * mean
    constant = (weights * (mean * mean / var + np.log(var) + _LOG_2PI)).sum(axis=-1)
    quad = (x * x) @ precision.reshape(k * n, f).T                   # (..., T, K*N)
    quad -= 2.0 * (x @ linear.reshape(k * n, f).T)
    quad += constant.reshape(k * n)
    out = (-0.5 * quad).reshape(x.shape[:-1] + (k, n))
    return np.moveaxis(out, -2, -3)


def forward_log_lattice(log_emit: np.ndarray, log_stay: np.ndarray,
                        log_move: np.ndarray) -> np.ndarray:
    """Log forward variables of left-right chains that start in state 0.

    ``log_emit`` (..., T, N), ``log_stay`` (..., N) and ``log_move`` (..., N-1)
    (log of ``1 - stay``) give ``log alpha_t(j)`` (..., T, N).
    """
    alpha = np.full(log_emit.shape, -np.inf)
    alpha[..., 0, 0] = log_emit[..., 0, 0]
    with np.errstate(invalid="ignore"):
        for t in range(1, log_emit.shape[-2]):
            prev = alpha[..., t - 1, :]
            cur = prev + log_stay
            cur[..., 1:] = np.logaddexp(cur[..., 1:], prev[..., :-1] + log_move)
            alpha[..., t, :] = cur + log_emit[..., t, :]
    return alpha


def forward_log_likelihood(log_emit: np.ndarray, log_stay: np.ndarray,
                           log_move: np.ndarray) -> np.ndarray:
    """Log-likelihoods (...) of gestures that must end in the last state:
    the last state's entry of :func:`forward_log_lattice` after the last
    vector (``-inf`` if impossible)."""
    return forward_log_lattice(log_emit, log_stay, log_move)[..., -1, -1]


@dataclass(frozen=True, eq=False)
class GaussianGestureModels:
    """One class = one or more :class:`GaussianHMM` components, as stored in a
    model file (``"emission": "gaussian"``; :mod:`sw_hps.hmm` has the layout).

    Attributes
    ----------
    class_names : tuple of str
    components : tuple of tuple of GaussianHMM
        Per class, its components; every component has the same number of
        states and features.
    resample : int
        Points the gesture is resampled to (:func:`sw_hps.stroke.stroke_features`).
    weights : (F,) float array
        Weight of each feature's log-density, each in (0, 10].
    thresholds : tuple of float, or None
        Per class, the lowest mean log-likelihood per feature vector a gesture
        given that class may have; lower is refused (``None``: never refuse).
    meta : dict
        Free-form: training options, accuracy.
    """
    class_names: tuple[str, ...]
    components: tuple[tuple[GaussianHMM, ...], ...]
    resample: int
    weights: np.ndarray
    thresholds: tuple[float, ...] | None = None
    meta: dict = field(default_factory=dict, compare=False)
    #: The posture commands (:mod:`sw_hps.posture_commands`; None: none).
    postures: dict | None = None
    #: Robot command per class (:mod:`sw_hps.class_commands`; None: by name).
    commands: dict | None = None

    emission = "gaussian"

    def __post_init__(self):
        names = tuple(str(n) for n in self.class_names)
        if not names or len(set(names)) != len(names):
            raise ValueError(f"class_names must be unique and non-empty, got {list(names)}")
        groups = tuple(tuple(g) for g in self.components)
        if len(groups) != len(names):
            raise ValueError(f"{len(names)} class_names but {len(groups)} models")
        for name, group in zip(names, groups):
            if not group or not all(isinstance(c, GaussianHMM) for c in group):
                raise ValueError(f"model of class {name!r} must hold at least one component")
        flat = [c for g in groups for c in g]
        shapes = {c.mean.shape for c in flat}
        if len(shapes) != 1:
            raise ValueError(f"every component must have the same (states, features), got "
                             f"{sorted(shapes)}")
        (n, f), = shapes
        if f != len(FEATURE_NAMES):
            raise ValueError(f"components must have {len(FEATURE_NAMES)} features "
                             f"{list(FEATURE_NAMES)}, got {f}")
        lo, hi = RESAMPLE_RANGE
        if isinstance(self.resample, bool) or not isinstance(self.resample, (int, np.integer)) \
                or not lo <= self.resample <= hi:
            raise ValueError(f"resample must be an integer in [{lo}, {hi}], got {self.resample!r}")
        weights = _array("weights", self.weights, 1)
        if weights.shape != (f,) or (weights <= 0).any() or (weights > 10).any():
            raise ValueError(f"weights must be {f} numbers in (0, 10], got {weights.tolist()}")
        object.__setattr__(self, "class_names", names)
        object.__setattr__(self, "components", groups)
        object.__setattr__(self, "resample", int(self.resample))
        object.__setattr__(self, "weights", weights)
        object.__setattr__(self, "thresholds", check_thresholds(self.thresholds, len(names)))
        object.__setattr__(self, "postures", check_posture_commands(self.postures))
        object.__setattr__(self, "commands", check_commands(self.commands, names))
        # All components stacked once, for one vectorised forward pass.
        stay = np.stack([c.stay for c in flat])
        with np.errstate(divide="ignore"):
            stacked = {"_owner": np.array([i for i, g in enumerate(groups) for _ in g]),
                       "_mean": np.stack([c.mean for c in flat]),
                       "_var": np.stack([c.var for c in flat]),
                       "_log_stay": np.log(stay), "_log_move": np.log1p(-stay[:, :-1])}
        for key, value in stacked.items():
            object.__setattr__(self, key, value)

    @property
    def num_states(self) -> int:
        return self._mean.shape[1]

    @property
    def steps(self) -> int:
        """Feature vectors per gesture (``resample - 1``)."""
        return self.resample - 1

    def features(self, points) -> np.ndarray | None:
        """The gesture's feature vectors (None for a gesture without motion)."""
        return stroke_features(points, self.resample)

    def component_scores(self, features) -> np.ndarray:
        """Log-likelihood of (T, F) or (S, T, F) features under every component."""
        x = np.asarray(features, dtype=np.float64)
        emit = log_emissions(x, self._mean, self._var, self.weights)
        return forward_log_likelihood(emit, self._log_stay, self._log_move)

    def scores_of_features(self, features) -> np.ndarray:
        """Per class, the best component's log-likelihood ((C,) or (S, C))."""
        comp = self.component_scores(features)
        out = np.full(comp.shape[:-1] + (len(self.class_names),), -np.inf)
        for k, owner in enumerate(self._owner):
            out[..., owner] = np.maximum(out[..., owner], comp[..., k])
        return out

    def scores_of_points(self, points) -> np.ndarray | None:
        """Per-class log-likelihoods of a gesture's points (None: no motion)."""
        x = self.features(points)
        return None if x is None else self.scores_of_features(x)

    def decide(self, scores, steps: int | None = None) -> tuple[int, str | None]:
        """``(class, None)`` or ``(-1, reason)`` for one gesture's scores
        (``steps`` is always :attr:`steps`; accepted for the discrete API)."""
        return decide(scores, self.steps, self.thresholds, self.class_names)

    def command_of(self, class_name: str) -> str | None:
        """The robot command a class sends (None: none)."""
        return command_of(self.commands, class_name)

    def with_thresholds(self, thresholds) -> "GaussianGestureModels":
        return replace(self, thresholds=thresholds, meta=dict(self.meta))

    def to_dict(self) -> dict:
        return {"format": MODEL_FORMAT, "version": MODEL_VERSION, "emission": self.emission,
                "class_names": list(self.class_names),
                "features": {"names": list(FEATURE_NAMES), "resample": self.resample,
                             "weights": self.weights.tolist()},
                "models": [{"components": [c.to_dict() for c in g]} for g in self.components],
                "rejection": None if self.thresholds is None else
                {"statistic": "mean log-likelihood per feature vector",
                 "thresholds": list(self.thresholds)},
                "spotting": None, "postures": self.postures,
                "commands": self.commands, "meta": self.meta}

    @classmethod
    def from_dict(cls, data: dict) -> "GaussianGestureModels":
        names = data.get("class_names")
        entries = data.get("models")
        feats = data.get("features")
        if not isinstance(names, list) or not isinstance(entries, list):
            raise ValueError("class_names and models must be lists")
        if not isinstance(feats, dict):
            raise ValueError("features must be an object with names, resample and weights")
        if len(names) != len(entries):
            raise ValueError(f"{len(names)} class_names but {len(entries)} models")
        if feats.get("names") != list(FEATURE_NAMES):
            raise ValueError(f"features names must be {list(FEATURE_NAMES)}, got "
                             f"{feats.get('names')!r}")
        groups = []
        for name, entry in zip(names, entries):
            comps = entry.get("components") if isinstance(entry, dict) else None
            if not isinstance(comps, list) or not comps:
                raise ValueError(f"model of class {name!r} must have a non-empty components list")
            group = []
            for k, comp in enumerate(comps):
                if not isinstance(comp, dict) or not {"stay", "mean", "var"} <= comp.keys():
                    raise ValueError(f"model of class {name!r} component {k} must have stay, "
                                     "mean and var")
                try:
                    group.append(GaussianHMM(comp["stay"], comp["mean"], comp["var"]))
                except ValueError as exc:
                    raise ValueError(f"model of class {name!r} component {k}: {exc}") from None
            groups.append(tuple(group))
        rejection = data.get("rejection")
        if rejection is not None and (not isinstance(rejection, dict)
                                      or "thresholds" not in rejection):
            raise ValueError("rejection must be null or an object with thresholds")
        return cls(tuple(names), tuple(groups), feats.get("resample"), feats.get("weights"),
                   None if rejection is None else rejection["thresholds"],
                   dict(data.get("meta") or {}),
                   data.get("postures") if data.get("version", 0) >= 4 else None,
                   data.get("commands") if data.get("version", 0) >= 5 else None)
