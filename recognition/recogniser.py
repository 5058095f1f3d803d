"""The recogniser as one object: front end, emission model, training,
rejection calibration and evaluation, for both emission models.

* ``emission="discrete"``: the thesis' 8 orientation symbols and discrete
  left-right HMMs (§7.4; :mod:`recognition.hmm_train`); with 5 states and no
  emission floor it is §9.4's recogniser.
* ``emission="gaussian"``: whole-gesture features (:mod:`sw_hps.stroke`)
  and left-right HMMs with diagonal Gaussian emissions, several components
  per class (:mod:`recognition.gaussian_train`).

Both score by the forward algorithm and decide with the rule the model file
carries (:func:`sw_hps.hmm.decide`): the best class, refused when its
log-likelihood per step is below the class' threshold.

Rejection thresholds are calibrated on people the models did not see:
the training data is split into ``calibration_folds`` groups of subjects
(or stratified folds without subjects), each group is scored by models
trained on the others, and a class' threshold is the ``reject_quantile``
quantile of the per-step scores of its correctly classified held-out
samples, less a margin: new people score lower than the held-out groups of
the calibration, and every refused gesture is an error. The margin
(``reject_margin``, or chosen when it is None) is the smallest of
:data:`MARGIN_GRID` with which thresholds from all groups but one refuse at
most ``reject_budget`` of that group's gestures, for every group: it grows
with how far apart the training subjects are, which is what a new person's
distance is estimated from.
"""
from __future__ import annotations

from dataclasses import asdict, dataclass, replace

import numpy as np

from recognition.crossval import fold_assignment
from recognition.datasets import TrajectorySet
from recognition.features import RESAMPLE_RANGE, feature_sets, sequences
from recognition.gaussian_train import (DEFAULT_RESAMPLE, DEFAULT_STATES, DEFAULT_VAR_FLOOR,
                                        DEFAULT_WEIGHTS, train_gaussian_models)
from recognition.hmm_train import (DEFAULT_EXPECTED_LENGTH, DEFAULT_MAX_ITER, DEFAULT_TOL,
                                   train_models)
from sw_hps.hmm import EMISSIONS
from sw_hps.stroke import RESAMPLE_RANGE as STROKE_RESAMPLE_RANGE

__all__ = ["EMISSIONS", "DEFAULT_EMISSION", "DEFAULT_REJECT_QUANTILE", "DEFAULT_REJECT_MARGIN",
           "DEFAULT_REJECT_BUDGET",
           "MARGIN_GRID", "Recogniser", "fold_of_groups"]

#: The best emission model (docs/figures/recognition.md): what ``stereogest train`` uses.
DEFAULT_EMISSION = "gaussian"
#: Quantile of held-out in-vocabulary per-step scores below which a gesture is refused...
DEFAULT_REJECT_QUANTILE = 0.005
#: ...less this margin (per-step log-likelihood); None: chosen from the
#: calibration groups (module docstring; docs/figures/recognition.md has both measured).
DEFAULT_REJECT_MARGIN = 1.5
#: Share of a held-out calibration group's gestures the chosen margin may refuse.
DEFAULT_REJECT_BUDGET = 0.005
#: Margins tried when the margin is chosen (per-step log-likelihood).
MARGIN_GRID = tuple(0.25 * k for k in range(25))
#: Groups of subjects used to calibrate the thresholds.
DEFAULT_CALIBRATION_FOLDS = 3
#: States of the discrete models when not given (thesis §9.4).
DISCRETE_STATES = 5


def fold_of_groups(labels, groups, folds: int, seed: int = 0) -> np.ndarray:
    """Fold of each sample: whole groups (subjects) dealt to ``folds`` folds in
    sorted order, or, without groups, a stratified deal of each class."""
    if groups is not None:
        distinct, inverse = np.unique(np.asarray(groups), return_inverse=True)
        return (inverse % min(folds, distinct.size)).astype(np.int64)
    return fold_assignment(labels, min(folds, max(len(labels), 2)), seed)


@dataclass(frozen=True)
class Recogniser:
    """Options of one recogniser variant (every field has the best default).

    Attributes
    ----------
    emission : str
        ``"gaussian"`` or ``"discrete"``.
    resample : int or None
        Pen front end with this many points (None: the camera front end,
        whose Gaussian features resample to :data:`DEFAULT_RESAMPLE`).
    states : int or None
        States per model (None: 16 Gaussian, 5 discrete).
    components : int or None
        Gaussian components per class (None: by sample count).
    var_floor : float
        Gaussian variance floor.
    emission_floor : float
        Discrete emission floor (0 = thesis).
    reject : bool
        Calibrate rejection thresholds.
    reject_quantile : float
        In [0, 0.5).
    reject_margin : float or None
        >= 0, subtracted from the quantile; None: the smallest of
        :data:`MARGIN_GRID` that refuses at most ``reject_budget`` of every
        held-out calibration group's gestures.
    reject_budget : float
        In [0, 0.5).
    calibration_folds : int
        >= 2.
    tol, max_iter, expected_length : float, int, int or None
        Discrete Baum-Welch options (:func:`recognition.hmm_train.train_models`;
        ``expected_length`` None: max(60, states)).
    """
    emission: str = DEFAULT_EMISSION
    resample: int | None = None
    states: int | None = None
    components: int | None = None
    var_floor: float = DEFAULT_VAR_FLOOR
    emission_floor: float = 0.0
    reject: bool = True
    reject_quantile: float = DEFAULT_REJECT_QUANTILE
    reject_margin: float | None = DEFAULT_REJECT_MARGIN
    reject_budget: float = DEFAULT_REJECT_BUDGET
    calibration_folds: int = DEFAULT_CALIBRATION_FOLDS
    tol: float = DEFAULT_TOL
    max_iter: int = DEFAULT_MAX_ITER
    expected_length: int | None = None

    def __post_init__(self):
        if self.emission not in EMISSIONS:
            raise ValueError(f"emission must be one of {list(EMISSIONS)}, got {self.emission!r}")
        lo, hi = RESAMPLE_RANGE
        if self.resample is not None and not lo <= self.resample <= hi:
            raise ValueError(f"resample must be in {lo}..{hi}, got {self.resample}")
        if self.emission == "gaussian" and self.resample is not None \
                and self.resample < STROKE_RESAMPLE_RANGE[0]:
            raise ValueError(f"resample must be >= {STROKE_RESAMPLE_RANGE[0]} for gaussian "
                             f"models, got {self.resample}")
        if not 0.0 <= self.reject_quantile < 0.5:
            raise ValueError(f"reject_quantile must be in [0, 0.5), got {self.reject_quantile}")
        if self.reject_margin is not None and not (self.reject_margin >= 0
                                                   and np.isfinite(self.reject_margin)):
            raise ValueError(f"reject_margin must be a finite number >= 0 or None, got "
                             f"{self.reject_margin}")
        if not 0.0 <= self.reject_budget < 0.5:
            raise ValueError(f"reject_budget must be in [0, 0.5), got {self.reject_budget}")
        if self.calibration_folds < 2:
            raise ValueError(f"calibration_folds must be >= 2, got {self.calibration_folds}")

    @property
    def num_states(self) -> int:
        if self.states is not None:
            return self.states
        return DEFAULT_STATES if self.emission == "gaussian" else DISCRETE_STATES

    @property
    def feature_points(self) -> int:
        """Points the Gaussian features resample to."""
        return DEFAULT_RESAMPLE if self.resample is None else self.resample

    def describe(self) -> dict:
        return dict(asdict(self), states=self.num_states)

    # ---- samples --------------------------------------------------------------------
    def samples(self, data: TrajectorySet) -> list:
        """Symbol sequences (discrete) or feature arrays / None (Gaussian)."""
        if self.emission == "discrete":
            return sequences(data, resample=self.resample)
        return feature_sets(data, self.feature_points, camera=self.resample is None)

    # ---- training -------------------------------------------------------------------
    def _fit(self, samples, labels, class_names, meta=None):
        if self.emission == "discrete":
            return train_models(samples, labels, class_names, self.num_states,
                                emission_floor=self.emission_floor, tol=self.tol,
                                max_iter=self.max_iter,
                                expected_length=self.expected_length
                                or max(DEFAULT_EXPECTED_LENGTH, self.num_states),
                                meta=meta)
        return train_gaussian_models(samples, labels, class_names, num_states=self.num_states,
                                     components=self.components, weights=DEFAULT_WEIGHTS,
                                     var_floor=self.var_floor, resample=self.feature_points,
                                     meta=meta)

    def fit(self, samples, labels, class_names, groups=None, meta=None, progress=None):
        """Models of every class, with calibrated thresholds if ``reject``."""
        labels = [str(x) for x in labels]
        info = {"recogniser": self.describe()}
        info.update(meta or {})
        models = self._fit(samples, labels, class_names, info)
        if not self.reject:
            return models
        thresholds, calibration = self.calibrate(samples, labels, class_names, groups,
                                                 progress=progress)
        models.meta["rejection"] = calibration
        return models.with_thresholds(thresholds)

    def calibrate(self, samples, labels, class_names, groups=None, progress=None):
        """Per-class thresholds from held-out groups (module docstring)."""
        names = tuple(class_names)
        labels = np.asarray([str(x) for x in labels])
        if groups is not None and np.unique(np.asarray(groups)).size < 2:
            raise ValueError("cannot calibrate rejection: the data has one subject, and the "
                             "thresholds are calibrated on subjects held out from the others "
                             "(give each person its subject, or use --no-reject)")
        fold = fold_of_groups(labels, groups, self.calibration_folds)
        # per held-out sample: its group, best class, that class' per-step score, right?
        held = []
        for f in np.unique(fold):
            train = fold != f
            present = set(labels[train].tolist())
            if not set(names) <= present:
                continue                          # a class only in this group: skip it
            if progress is not None:
                progress(f"calibrating rejection: fold {f + 1} of {fold.max() + 1}")
            models = replace(self, reject=False)._fit(
                [s for s, k in zip(samples, train) if k], labels[train], names)
            test = np.flatnonzero(~train)
            scores, steps = self.scores(models, [samples[i] for i in test])
            for i, row, n in zip(test, scores, steps):
                if n > 0 and np.isfinite(row).any():
                    best = int(np.argmax(row))
                    held.append((int(f), best, row[best] / n, best == names.index(labels[i])))
        group = np.array([h[0] for h in held], dtype=np.int64)
        best = np.array([h[1] for h in held], dtype=np.int64)
        score = np.array([h[2] for h in held], dtype=np.float64)
        right = np.array([h[3] for h in held], dtype=bool)
        quantiles = self._quantiles(best, score, right, len(names))
        for c, q in enumerate(quantiles):
            if q is None:
                raise ValueError(f"cannot calibrate rejection: class {names[c]!r} has no "
                                 "correctly classified held-out sample (use --no-reject)")
        if self.reject_margin is None:
            margin, worst = self._choose_margin(group, best, score, right, len(names))
        else:
            margin, worst = self.reject_margin, None
        thresholds = [q - margin for q in quantiles]
        info = {"statistic": "per-step log-likelihood", "quantile": self.reject_quantile,
                "margin": margin, "margin_chosen": self.reject_margin is None,
                "budget": self.reject_budget if self.reject_margin is None else None,
                "worst_group_refused": worst,
                "folds": int(fold.max()) + 1,
                "grouped": groups is not None,
                "held_out_samples": [int(((best == c) & right).sum())
                                     for c in range(len(names))]}
        return thresholds, info

    def _quantiles(self, best, score, right, classes: int) -> list:
        """Per class the ``reject_quantile`` of its correctly classified held-out
        scores (None: it has none)."""
        out = []
        for c in range(classes):
            values = score[(best == c) & right]
            out.append(float(np.quantile(values, self.reject_quantile)) if values.size else None)
        return out

    def _choose_margin(self, group, best, score, right, classes: int):
        """The smallest margin of :data:`MARGIN_GRID` with which the thresholds
        of every group but one refuse at most ``reject_budget`` of that
        group's held-out gestures; and the worst group's refused share with it
        (the largest margin when none is enough)."""
        margins = np.asarray(MARGIN_GRID)
        worst = np.zeros(margins.size)
        for f in np.unique(group):
            others = group != f
            quantiles = self._quantiles(best[others], score[others], right[others], classes)
            mine = np.flatnonzero(~others)
            usable = [i for i in mine if quantiles[best[i]] is not None]
            if not usable:
                continue
            level = np.array([quantiles[best[i]] for i in usable])
            refused = (score[usable][:, None] < level[:, None] - margins[None, :]).sum(axis=0)
            worst = np.maximum(worst, refused / mine.size)
        ok = np.flatnonzero(worst <= self.reject_budget)
        k = int(ok[0]) if ok.size else margins.size - 1
        return float(margins[k]), float(worst[k])

    # ---- scoring --------------------------------------------------------------------
    def scores(self, models, samples) -> tuple[np.ndarray, np.ndarray]:
        """(S, C) log-likelihoods and (S,) steps (0 = nothing to score)."""
        c = len(models.class_names)
        out = np.full((len(samples), c), -np.inf)
        steps = np.zeros(len(samples), dtype=np.int64)
        if models.emission == "discrete":
            for i, seq in enumerate(samples):
                if len(seq):
                    out[i] = models.scores(seq)
                    steps[i] = len(seq)
            return out, steps
        index = [i for i, x in enumerate(samples) if x is not None]
        if index:
            out[index] = models.scores_of_features(np.stack([samples[i] for i in index]))
            steps[index] = models.steps
        return out, steps

    def decisions(self, models, samples) -> tuple[np.ndarray, np.ndarray]:
        """Per sample the class index (-1 refused) and the unthresholded best
        class (-1 when nothing could be scored)."""
        scores, steps = self.scores(models, samples)
        decided = np.full(len(samples), -1, dtype=np.int64)
        best = np.full(len(samples), -1, dtype=np.int64)
        for i, (row, n) in enumerate(zip(scores, steps)):
            if n == 0:
                continue
            decided[i] = models.decide(row, int(n))[0]
            if np.isfinite(row).any():
                best[i] = int(np.argmax(row))
        return decided, best
