"""Training of the Gaussian left-right gesture HMMs (:mod:`sw_hps.gaussian_hmm`).

Per class:

1. The samples' feature vectors (:func:`sw_hps.stroke.stroke_features`, all of
   the same length T) are split into ``components`` clusters by k-means on
   their position features (the ways people draw one gesture: stroke order,
   proportions); clusters smaller than :data:`MIN_CLUSTER` are dropped.
2. Each cluster trains one left-right HMM by Baum-Welch (weighted emissions,
   the forward-backward pass in log space over the two-diagonal chain),
   started from an even split of every sequence over the N states
   (eq. 29-33's banded start: ``stay = 1 - N/T``).
3. The samples are re-assigned to their best component and the components
   re-trained (``rounds`` times): k-means with HMMs as centres.

Variances are floored (``var_floor``), which keeps a state fitted to few,
nearly identical vectors from scoring unseen people's variations as
impossible.
"""
from __future__ import annotations

import math

import numpy as np

from sw_hps.gaussian_hmm import (GaussianGestureModels, GaussianHMM, forward_log_lattice,
                                 log_emissions)
from sw_hps.stroke import FEATURE_NAMES

__all__ = ["DEFAULT_STATES", "DEFAULT_WEIGHTS", "DEFAULT_VAR_FLOOR", "DEFAULT_ITERATIONS",
           "DEFAULT_RESAMPLE", "MIN_CLUSTER", "default_components", "baum_welch_gaussian",
           "train_gaussian_models"]

#: States per component.
DEFAULT_STATES = 16
#: Log-density weights of FEATURE_NAMES (direction and position 1, arc and turn 0.5).
DEFAULT_WEIGHTS = (1.0, 1.0, 1.0, 1.0, 0.5, 0.5)
#: Smallest variance of any state and feature.
DEFAULT_VAR_FLOOR = 1e-2
#: Baum-Welch re-estimations per training.
DEFAULT_ITERATIONS = 10
#: Points per gesture after resampling.
DEFAULT_RESAMPLE = 64
#: Fewest samples a component is trained on.
MIN_CLUSTER = 8
#: Training samples per component of the automatic choice (at most MAX_AUTO_COMPONENTS).
SAMPLES_PER_COMPONENT = 120
MAX_AUTO_COMPONENTS = 5


def default_components(samples: int) -> int:
    """Components of a class with ``samples`` training samples when not given:
    one per :data:`SAMPLES_PER_COMPONENT`, 1 to :data:`MAX_AUTO_COMPONENTS`."""
    return int(min(MAX_AUTO_COMPONENTS, max(1, samples // SAMPLES_PER_COMPONENT)))


def _log_backward(log_emit, log_stay, log_move):
    s, t_max, n = log_emit.shape
    beta = np.full((s, t_max, n), -np.inf)
    beta[:, -1, -1] = 0.0
    with np.errstate(invalid="ignore"):
        for t in range(t_max - 2, -1, -1):
            nxt = log_emit[:, t + 1] + beta[:, t + 1]
            cur = nxt + log_stay
            cur[:, :-1] = np.logaddexp(cur[:, :-1], nxt[:, 1:] + log_move)
            beta[:, t] = cur
    return beta


def baum_welch_gaussian(features: np.ndarray, num_states: int, weights, *,
                        iterations: int = DEFAULT_ITERATIONS,
                        var_floor: float = DEFAULT_VAR_FLOOR) -> GaussianHMM:
    """One left-right Gaussian HMM trained on ``features`` (S, T, F).

    Starts from an even split of each sequence over the states (means and
    variances of each part, ``stay = 1 - N/T``), then ``iterations``
    re-estimations of ``stay``, ``mean`` and ``var`` from the posteriors of
    the weighted model (every sequence ends in the last state).
    """
    x = np.asarray(features, dtype=np.float64)
    s, t_max, f = x.shape
    n = int(num_states)
    if not 1 <= n <= t_max:
        raise ValueError(f"states must be in [1, {t_max}] (feature vectors per gesture), got {n}")
    w = np.asarray(weights, dtype=np.float64)
    part = np.minimum((np.arange(t_max) * n) // t_max, n - 1)
    mean = np.stack([x[:, part == j].reshape(-1, f).mean(axis=0) for j in range(n)])
    var = np.maximum(np.stack([x[:, part == j].reshape(-1, f).var(axis=0) for j in range(n)]),
                     var_floor)
    stay = np.full(n, 1.0 - n / t_max)
    stay[-1] = 1.0
    for _ in range(iterations):
        with np.errstate(divide="ignore"):
            log_stay, log_move = np.log(stay), np.log1p(-stay[:-1])
        emit = log_emissions(x, mean[None], var[None], w)[:, 0]          # (S, T, N)
        alpha = forward_log_lattice(emit, log_stay, log_move)
        beta = _log_backward(emit, log_stay, log_move)
        total = alpha[:, -1, -1]
        ok = np.isfinite(total)
        if not ok.any():
            break
        alpha, beta, emit, total = alpha[ok], beta[ok], emit[ok], total[ok]
        gamma = np.exp(alpha + beta - total[:, None, None])                # (S, T, N)
        after = emit[:, 1:] + beta[:, 1:] - total[:, None, None]
        stays = np.exp(alpha[:, :-1] + log_stay + after).sum(axis=(0, 1))
        moves = np.exp(alpha[:, :-1, :-1] + log_move + after[:, :, 1:]).sum(axis=(0, 1))
        leave = stays[:-1] + moves
        stay[:-1] = np.where(leave > 0, stays[:-1] / np.where(leave > 0, leave, 1.0), stay[:-1])
        occupancy = gamma.sum(axis=(0, 1))
        used = occupancy > 0
        xs = x[ok]
        new_mean = np.einsum("stn,stf->nf", gamma, xs) / np.where(used, occupancy, 1.0)[:, None]
        new_var = np.einsum("stn,stf->nf", gamma, xs * xs) / np.where(used, occupancy, 1.0)[:, None] \
            - new_mean ** 2
        mean = np.where(used[:, None], new_mean, mean)
        var = np.maximum(np.where(used[:, None], new_var, var), var_floor)
    return GaussianHMM(stay, mean, var)


def _kmeans(points: np.ndarray, k: int, seed: int, iterations: int = 20) -> np.ndarray:
    rng = np.random.default_rng(seed)
    centres = points[rng.choice(len(points), k, replace=False)]
    assign = np.zeros(len(points), dtype=np.int64)
    for _ in range(iterations):
        assign = ((points[:, None] - centres[None]) ** 2).sum(axis=-1).argmin(axis=1)
        centres = np.stack([points[assign == j].mean(axis=0) if (assign == j).any()
                            else centres[j] for j in range(k)])
    return assign


def _train_class(x: np.ndarray, num_states: int, weights, components: int, rounds: int,
                 iterations: int, var_floor: float, seed: int) -> tuple[GaussianHMM, ...]:
    k = min(components, len(x) // MIN_CLUSTER)
    if k <= 1:
        return (baum_welch_gaussian(x, num_states, weights, iterations=iterations,
                                    var_floor=var_floor),)
    position = [FEATURE_NAMES.index("x"), FEATURE_NAMES.index("y")]
    assign = _kmeans(x[:, :, position].reshape(len(x), -1), k, seed)
    models: list[GaussianHMM] = []
    for r in range(rounds + 1):
        kept = [j for j in range(k) if (assign == j).sum() >= MIN_CLUSTER]
        models = [baum_welch_gaussian(x[assign == j], num_states, weights,
                                      iterations=iterations, var_floor=var_floor)
                  for j in kept]
        if r == rounds or len(models) <= 1:
            break
        probe = GaussianGestureModels(tuple(str(j) for j in range(len(models))),
                                      tuple((m,) for m in models), x.shape[1] + 1, weights)
        assign = np.array(kept)[probe.scores_of_features(x).argmax(axis=1)]
    return tuple(models)


def train_gaussian_models(features, labels, class_names, *,
                          num_states: int = DEFAULT_STATES, components: int | None = None,
                          weights=DEFAULT_WEIGHTS, var_floor: float = DEFAULT_VAR_FLOOR,
                          iterations: int = DEFAULT_ITERATIONS, rounds: int = 2,
                          resample: int = DEFAULT_RESAMPLE, seed: int = 0,
                          meta: dict | None = None) -> GaussianGestureModels:
    """One Gaussian left-right model (of one or more components) per class.

    Parameters
    ----------
    features : (S, resample - 1, F) array or list of such arrays / None
        Feature vectors per sample (:func:`sw_hps.stroke.stroke_features`);
        None entries (gestures without motion) are skipped.
    labels : sequence of str
        Class of each sample.
    class_names : sequence of str
        Model order.
    num_states : int
        States per component, in [1, resample - 1].
    components : int, optional
        Most components per class, in [1, 16]; None: :func:`default_components`
        of each class' sample count.
    weights : (F,) floats in (0, 10]
        Feature weights of the emission log-densities.
    var_floor : float
        Smallest variance, > 0.
    iterations : int
        Baum-Welch re-estimations, >= 1.
    rounds : int
        Re-assignments of the samples to components, >= 0.
    resample : int
        Recorded in the model (the front end the features came from).
    seed : int
        Seeds the k-means.
    """
    names = tuple(str(c) for c in class_names)
    labels = [str(x) for x in labels]
    feats = list(features)
    if len(labels) != len(feats):
        raise ValueError(f"labels must have one entry per sample ({len(feats)}), got {len(labels)}")
    if isinstance(num_states, bool) or not isinstance(num_states, (int, np.integer)) \
            or not 1 <= num_states <= resample - 1:
        raise ValueError(f"states must be an integer in [1, {resample - 1}], got {num_states!r}")
    if components is not None and (isinstance(components, bool) or not isinstance(
            components, (int, np.integer)) or not 1 <= components <= 16):
        raise ValueError(f"components must be an integer in [1, 16], got {components!r}")
    if not (isinstance(var_floor, (int, float)) and math.isfinite(var_floor) and var_floor > 0):
        raise ValueError(f"var_floor must be a finite number > 0, got {var_floor!r}")
    if isinstance(iterations, bool) or not isinstance(iterations, int) or iterations < 1:
        raise ValueError(f"iterations must be an integer >= 1, got {iterations!r}")
    unknown = sorted(set(labels) - set(names))
    if unknown:
        raise ValueError(f"labels {unknown} are not in class_names {list(names)}")
    groups, used = [], {}
    for name in names:
        mine = [x for x, lab in zip(feats, labels) if lab == name and x is not None]
        if not mine:
            raise ValueError(f"class {name!r} has no training sample with motion")
        groups.append(np.stack(mine))
        used[name] = len(mine)
    counts = {}
    trained = []
    for name, x in zip(names, groups):
        k = default_components(len(x)) if components is None else int(components)
        comps = _train_class(x, int(num_states), weights, k, rounds, iterations,
                             float(var_floor), seed)
        trained.append(comps)
        counts[name] = len(comps)
    info = {"trainer": "baum-welch-gaussian", "emission": "gaussian", "states": int(num_states),
            "components": components, "weights": [float(w) for w in weights],
            "var_floor": float(var_floor), "iterations": iterations, "rounds": rounds,
            "seed": seed, "training": {n: {"samples": used[n], "components": counts[n]}
                                       for n in names}}
    info.update(meta or {})
    return GaussianGestureModels(names, tuple(trained), resample, weights, None, info)
