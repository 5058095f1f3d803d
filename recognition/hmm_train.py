"""Training of the discrete left-right gesture HMMs (thesis §7.4, eq. 29-33).

Each gesture class gets one HMM, trained by multi-sequence Baum-Welch
re-estimation from the left-right initial model of eq. 29-33:

* :func:`initial_model` builds the banded starting point: with ``d = T/N``
  (``T`` the expected sequence length, ``N`` the number of states) the state
  stays with probability ``1 - 1/d`` and moves one state right with ``1/d``;
  the last state is absorbing; the emissions are uniform and the model starts
  in the first state.
* :func:`baum_welch` re-estimates ``A`` and ``B`` with Rabiner's scaled
  forward-backward recursion over all sequences at once. The updates are
  multiplicative, so every transition that starts at zero stays exactly zero:
  the model stays left-right. ``pi`` is held on the first state.
* :func:`train_models` trains one model per class and returns the
  :class:`sw_hps.hmm.GestureModels` the board application loads.

Scoring (the forward algorithm on its own) belongs to :mod:`sw_hps.hmm`; the
forward-backward pass here exists only for re-estimation.
"""
from __future__ import annotations

import math
from dataclasses import dataclass, replace

import numpy as np

from sim.model.validation import check_int
from sw_hps.hmm import DiscreteHMM, GestureModels

__all__ = ["MAX_STATES", "TrainingReport", "initial_model", "baum_welch", "train_models",
           "DEFAULT_TOL", "DEFAULT_MAX_ITER", "DEFAULT_EXPECTED_LENGTH"]

#: Largest number of states per model.
MAX_STATES = 64
#: Convergence threshold on the total log-likelihood (thesis).
DEFAULT_TOL = 1e-4
#: Iteration cap (thesis).
DEFAULT_MAX_ITER = 5000
#: Expected sequence length T of eq. 29-33.
DEFAULT_EXPECTED_LENGTH = 60


def initial_model(num_states: int, num_symbols: int = 8,
                  expected_length: int = DEFAULT_EXPECTED_LENGTH) -> DiscreteHMM:
    """Left-right initial model of thesis eq. 29-33.

    Parameters
    ----------
    num_states : int
        N, in [1, 64] and at most ``expected_length`` (so that d >= 1).
    num_symbols : int
        M, the number of observation symbols (8 orientation sectors).
    expected_length : int
        T, the expected number of symbols of a gesture.

    Returns
    -------
    DiscreteHMM
        With ``d = T / N``: ``a_ii = 1 - 1/d`` and ``a_i,i+1 = 1/d`` for
        ``i < N-1``, ``a_N-1,N-1 = 1``, every other ``a_ij = 0``;
        ``b_jk = 1/M``; ``pi = (1, 0, ..., 0)``.

    Raises
    ------
    ValueError
        Naming the parameter out of range.
    """
    n = check_int("num_states", num_states, 1, MAX_STATES)
    m = check_int("num_symbols", num_symbols, 1)
    t = check_int("expected_length", expected_length, 1)
    if n > t:
        raise ValueError(f"num_states must be <= expected_length = {t} (d = T/N >= 1), "
                         f"got {n}")
    d = t / n
    a = np.zeros((n, n))
    idx = np.arange(n - 1)
    a[idx, idx] = 1.0 - 1.0 / d
    a[idx, idx + 1] = 1.0 / d
    a[n - 1, n - 1] = 1.0
    b = np.full((n, m), 1.0 / m)
    pi = np.zeros(n)
    pi[0] = 1.0
    return DiscreteHMM(pi, a, b)


@dataclass(frozen=True)
class TrainingReport:
    """What :func:`baum_welch` did.

    Attributes
    ----------
    log_likelihood : tuple of float
        Total log-likelihood of the used sequences under each successive
        model: ``[0]`` the initial model, ``[-1]`` the returned one.
    iterations : int
        Number of re-estimations performed (``len(log_likelihood) - 1``).
    converged : bool
        True if the last re-estimation improved the log-likelihood by less
        than ``tol``; False if ``max_iter`` stopped the training.
    sequences : int
        Sequences used for training.
    symbols : int
        Symbols in those sequences.
    skipped_empty : int
        Empty sequences (ignored).
    skipped_impossible : int
        Sequences with zero probability under the initial model (ignored:
        they carry no information for re-estimation).
    """
    log_likelihood: tuple[float, ...]
    iterations: int
    converged: bool
    sequences: int
    symbols: int
    skipped_empty: int
    skipped_impossible: int

    @property
    def final_log_likelihood(self) -> float:
        return self.log_likelihood[-1]

    def to_dict(self) -> dict:
        return {"iterations": self.iterations, "converged": self.converged,
                "sequences": self.sequences, "symbols": self.symbols,
                "skipped_empty": self.skipped_empty,
                "skipped_impossible": self.skipped_impossible,
                "log_likelihood": self.final_log_likelihood}


class _Stack:
    """The training sequences of C models, padded into arrays.

    ``obs[t, c, s]`` is symbol t of sequence s of model c, or M (a padding
    symbol every state emits with probability 1) after that sequence's end;
    models with fewer sequences get empty ones. ``valid`` marks real symbols.
    """

    def __init__(self, groups: list[list[np.ndarray]], num_symbols: int):
        c = len(groups)
        s = max(len(g) for g in groups)
        t = max(len(x) for g in groups for x in g)
        self.obs = np.full((t, c, s), num_symbols, dtype=np.int64)
        for ci, group in enumerate(groups):
            for si, seq in enumerate(group):
                self.obs[:len(seq), ci, si] = seq
        self.valid = self.obs < num_symbols
        self.num_symbols = num_symbols
        self._emit_index = {}
        # One-hot of the real symbols, (C, T*S, M), rows in (t, s) order.
        onehot = np.zeros((c, t, s, num_symbols + 1))
        np.put_along_axis(onehot, self.obs.transpose(1, 0, 2)[..., None], 1.0, axis=-1)
        self.onehot = onehot[..., :num_symbols].reshape(c, t * s, num_symbols)

    def emissions(self, b_padded: np.ndarray) -> np.ndarray:
        """``emit[t, c, j, s] = b_j(o_t)`` of model c, from its (N, M+1) rows."""
        t, c, s = self.obs.shape
        n = b_padded.shape[1]
        index = self._emit_index.get(n)
        if index is None:
            # Flat position of b[c, j, o[t, c, s]] in a contiguous (C, N, M+1) array.
            rows = np.arange(c)[:, None] * n + np.arange(n)[None, :]          # (C, N)
            index = rows[None, :, :, None] * (self.num_symbols + 1) \
                + self.obs[:, :, None, :]
            self._emit_index[n] = index
        return np.ascontiguousarray(b_padded).reshape(-1).take(index)


def _forward(stack: _Stack, pi, a, b_padded):
    """Scaled forward pass (Rabiner) for every model and sequence at once.

    Returns the emission probabilities ``emit[t, c, j, s] = b_j(o_t)``, the
    normalised forward variables alpha-hat (T, C, N, S) and the scale factors
    c_t (T, C, S); alpha-hat_t sums to 1 over the states.
    """
    t_max, c, s = stack.obs.shape
    n = pi.shape[1]
    emit = stack.emissions(b_padded)
    a_t = np.ascontiguousarray(a.transpose(0, 2, 1))
    alpha = np.empty((t_max, c, n, s))
    scale = np.empty((t_max, c, 1, s))
    matmul, add, multiply, divide = np.matmul, np.add.reduce, np.multiply, np.divide
    with np.errstate(divide="ignore", invalid="ignore"):
        multiply(pi[:, :, None], emit[0], out=alpha[0])
        add(alpha[0], axis=1, out=scale[0], keepdims=True)
        divide(alpha[0], scale[0], out=alpha[0])
        previous = alpha[0]
        # alpha-hat_t = normalise((alpha-hat_t-1 A) * b(o_t)); the loop only
        # walks over views, one step per symbol, all models and sequences at once.
        for step, emission, factor in zip(alpha[1:], emit[1:], scale[1:]):
            matmul(a_t, previous, out=step)
            multiply(step, emission, out=step)
            add(step, axis=1, out=factor, keepdims=True)
            divide(step, factor, out=step)
            previous = step
    return emit, alpha, scale[:, :, 0, :]


def _backward_terms(stack: _Stack, a, emit, scale):
    """Scaled backward pass with the forward pass's scale factors.

    Returns beta-hat (T, C, N, S) and ``e[t, c, j, s] = b_j(o_t) beta-hat_t(j) /
    c_t``, zero where there is no symbol. After a sequence's end the padding
    symbol keeps beta-hat at 1 (to rounding), so its last real beta-hat is 1.
    """
    e = emit / scale[:, :, None, :]
    beta = np.empty_like(emit)
    beta[-1] = 1.0
    matmul, multiply = np.matmul, np.multiply
    # beta-hat_t-1 = A (b(o_t) beta-hat_t / c_t), from the end backwards.
    for term, after, before in zip(e[:0:-1], beta[:0:-1], beta[-2::-1]):
        multiply(term, after, out=term)
        matmul(a, term, out=before)
    e *= stack.valid[:, :, None, :]
    return beta, e


def _fit(models: list[DiscreteHMM], groups: list[list[np.ndarray]], tol: float,
         max_iter: int, emission_floor: float) -> list[tuple[DiscreteHMM, TrainingReport]]:
    """Baum-Welch for several independent models, advanced in lock step (one
    numpy pass per time step serves every model); each stops on its own.

    Memory is O(T * C * N * S) floats per array (longest sequence, models,
    most states, most sequences of one model), a few arrays at a time.
    """
    m = models[0].num_symbols
    n_max = max(x.num_states for x in models)
    k = len(models)
    # Models padded to n_max states with unreachable ones (pi 0, no way in).
    pi = np.zeros((k, n_max))
    a = np.zeros((k, n_max, n_max))
    b = np.full((k, n_max, m + 1), 1.0 / m)
    b[:, :, m] = 1.0                               # the padding symbol
    for i, model in enumerate(models):
        n = model.num_states
        pi[i, :n] = model.pi
        a[i] = np.eye(n_max)
        a[i, :n, :n] = model.A
        b[i, :n, :m] = model.B
    histories: list[list[float]] = [[] for _ in models]
    impossible = [0] * k
    results: list = [None] * k
    live = list(range(k))                          # models still training
    groups = [list(g) for g in groups]
    stack = _Stack(groups, m)
    iteration = 0
    while live:
        emit, alpha, scale = _forward(stack, pi[live], a[live], b[live])
        dead = (stack.valid & ~(scale > 0)).any(axis=0)          # (C, S)
        if dead.any():
            # Zero probability under the model: drop and redo the pass.
            for ci, model_index in enumerate(live):
                group = groups[model_index]
                drop = dead[ci, :len(group)]
                if drop.any():
                    impossible[model_index] += int(drop.sum())
                    groups[model_index] = [x for x, d in zip(group, drop) if not d]
                    if not groups[model_index]:
                        raise ValueError("no sequence has non-zero probability under the "
                                         f"model ({impossible[model_index]} impossible)")
            stack = _Stack([groups[i] for i in live], m)
            continue
        log_scale = np.log(scale, out=np.zeros_like(scale), where=stack.valid)
        totals = log_scale.sum(axis=(0, 2))
        finished = []
        for ci, model_index in enumerate(live):
            history = histories[model_index]
            history.append(float(totals[ci]))
            converged = iteration > 0 and history[-1] - history[-2] < tol
            if converged or iteration == max_iter:
                finished.append(ci)
                results[model_index] = converged
        if len(finished) == len(live):
            break
        beta, e = _backward_terms(stack, a[live], emit, scale)
        c, t_max, s = len(live), emit.shape[0], emit.shape[3]
        # sum over t, s of alpha-hat_t(i) e_t+1(j): expected transitions / a_ij.
        forward_part = alpha[:-1].transpose(1, 2, 0, 3).reshape(c, n_max, -1)
        backward_part = e[1:].transpose(1, 2, 0, 3).reshape(c, n_max, -1)
        a_live = a[live]
        trans = a_live * (forward_part @ backward_part.transpose(0, 2, 1))
        gamma = np.multiply(alpha, beta, out=beta).transpose(1, 2, 0, 3).reshape(
            c, n_max, t_max * s)
        counts = gamma @ stack.onehot                                  # (C, N, M)
        a_new = _normalise_rows(trans, a_live)
        assert not a_new[a_live == 0].any(), "a zero transition became non-zero"
        b_new = _normalise_rows(counts, b[live][:, :, :m])
        if emission_floor > 0:
            b_new = np.maximum(b_new, emission_floor)
            b_new /= b_new.sum(axis=-1, keepdims=True)
        keep = [ci for ci in range(c) if ci not in finished]
        keep_index = [live[ci] for ci in keep]
        a[keep_index] = a_new[keep]
        b[keep_index, :, :m] = b_new[keep]
        if finished:
            live = keep_index
            stack = _Stack([groups[i] for i in live], m)
        iteration += 1

    out = []
    for i, model in enumerate(models):
        n = model.num_states
        fitted = DiscreteHMM(model.pi, a[i, :n, :n], b[i, :n, :m])
        report = TrainingReport(tuple(histories[i]), len(histories[i]) - 1, bool(results[i]),
                                len(groups[i]), int(sum(len(x) for x in groups[i])),
                                0, impossible[i])
        out.append((fitted, report))
    return out


def _normalise_rows(counts: np.ndarray, old: np.ndarray) -> np.ndarray:
    """Rows (last axis) of ``counts`` divided by their sums; a row with no
    counts (a state never reached) keeps ``old``."""
    sums = counts.sum(axis=-1, keepdims=True)
    with np.errstate(divide="ignore", invalid="ignore"):
        return np.where(sums > 0, counts / sums, old)


def _check_sequences(sequences, num_symbols: int) -> list[np.ndarray]:
    result = []
    for i, seq in enumerate(sequences):
        arr = np.asarray(seq)
        if arr.ndim != 1 or (arr.size and arr.dtype.kind not in "iu"):
            raise ValueError(f"sequences[{i}] must be a 1-D integer array, got shape "
                             f"{arr.shape} dtype {arr.dtype}")
        if arr.size and (arr.min() < 0 or arr.max() >= num_symbols):
            raise ValueError(f"sequences[{i}] holds symbols outside [0, {num_symbols - 1}]")
        result.append(arr.astype(np.int64))
    return result


def _check_options(tol, max_iter, emission_floor, num_symbols: int) -> None:
    if isinstance(tol, bool) or not isinstance(tol, (int, float, np.floating, np.integer)) \
            or not math.isfinite(tol) or tol < 0:
        raise ValueError(f"tol must be a finite number >= 0, got {tol!r}")
    check_int("max_iter", max_iter, 0)
    if isinstance(emission_floor, bool) \
            or not isinstance(emission_floor, (int, float, np.floating, np.integer)) \
            or not 0.0 <= emission_floor < 1.0 / num_symbols:
        raise ValueError(f"emission_floor must be a number in [0, 1/{num_symbols}), "
                         f"got {emission_floor!r}")


def baum_welch(model: DiscreteHMM, sequences, tol: float = DEFAULT_TOL,
               max_iter: int = DEFAULT_MAX_ITER,
               emission_floor: float = 0.0) -> tuple[DiscreteHMM, TrainingReport]:
    """Multi-sequence Baum-Welch re-estimation with Rabiner scaling (thesis §7.4).

    Parameters
    ----------
    model : DiscreteHMM
        Starting model, normally :func:`initial_model` (eq. 29-33).
    sequences : iterable of 1-D integer arrays
        Symbol sequences of one class. Empty sequences are skipped; so are
        sequences with zero probability under ``model`` (both counted in the
        report).
    tol : float
        Stop when one re-estimation raises the total log-likelihood of the
        sequences by less than ``tol`` (thesis 1e-4).
    max_iter : int
        Most re-estimations (thesis 5000).
    emission_floor : float
        After each re-estimation, raise every emission probability below this
        to it and renormalise the rows of ``B`` (0 = thesis: none). Without a
        floor an emission never seen in training becomes exactly 0, and one
        such symbol gives a gesture zero probability. In [0, 1/M).

    Returns
    -------
    (DiscreteHMM, TrainingReport)
        The re-estimated model and the log-likelihood history.

    Notes
    -----
    Rabiner's scaling: the forward variables are normalised at every step,
    ``alpha-hat_t = alpha_t / (c_1 ... c_t)``, which sum to 1; the backward
    variables ``beta-hat_t`` are divided by the same factors, and
    ``log P(O) = sum_t log c_t``, so no sequence length underflows. Summed over
    time and sequences, the expected counts

    * ``xi_t(i, j) = alpha-hat_t(i) a_ij b_j(o_t+1) beta-hat_t+1(j) / c_t+1``
    * ``gamma_t(j) = alpha-hat_t(j) beta-hat_t(j)``

    re-estimate ``a_ij = sum xi(i, j) / sum_j' xi(i, j')`` and
    ``b_jk = sum_{t: o_t = k} gamma_t(j) / sum_t gamma_t(j)``. Every xi carries
    the factor ``a_ij``, so a zero transition stays exactly zero and the model
    stays left-right; a state never reached keeps its rows; ``pi`` is not
    re-estimated (the model starts in its first state). Without a floor the
    log-likelihood never decreases (EM); the returned model is the last one,
    whose log-likelihood is ``report.log_likelihood[-1]``.
    """
    if not isinstance(model, DiscreteHMM):
        raise ValueError(f"model must be a DiscreteHMM, got {type(model).__name__}")
    _check_options(tol, max_iter, emission_floor, model.num_symbols)
    seqs = _check_sequences(sequences, model.num_symbols)
    nonempty = [s for s in seqs if s.size]
    if not nonempty:
        raise ValueError("sequences must hold at least one non-empty sequence")
    [(fitted, report)] = _fit([model], [nonempty], float(tol), int(max_iter),
                              float(emission_floor))
    return fitted, replace(report, skipped_empty=len(seqs) - len(nonempty))


def train_models(sequences, labels, class_names, num_states, *,
                 tol: float = DEFAULT_TOL, max_iter: int = DEFAULT_MAX_ITER,
                 emission_floor: float = 0.0,
                 expected_length: int = DEFAULT_EXPECTED_LENGTH,
                 num_symbols: int = 8, meta: dict | None = None) -> GestureModels:
    """One Baum-Welch-trained HMM per class (thesis §7.4).

    Parameters
    ----------
    sequences : list of 1-D integer arrays
        Symbol sequences (e.g. :func:`recognition.features.sequences`).
    labels : sequence of str
        Class name of each sequence; each must be in ``class_names``.
    class_names : sequence of str
        Order of the models in the result.
    num_states : int or sequence of int
        States per model (one for all, or one per class), each in [1, 64].
    tol, max_iter, emission_floor
        As in :func:`baum_welch`.
    expected_length : int
        T of the initial model (eq. 29-33).
    num_symbols : int
        M.
    meta : dict, optional
        Extra entries for the model file's ``meta``.

    Returns
    -------
    GestureModels
        ``meta`` records the options (``states``, ``tol``, ``max_iter``,
        ``emission_floor``, ``expected_length``) and, under ``training``, the
        :class:`TrainingReport` summary of each class.

    Raises
    ------
    ValueError
        A label not in ``class_names``, a class without a usable sequence, or
        an option out of range.
    """
    names = tuple(str(c) for c in class_names)
    if not names:
        raise ValueError("class_names must name at least one class")
    seqs = list(sequences)
    labels = [str(x) for x in labels]
    if len(labels) != len(seqs):
        raise ValueError(f"labels must have one entry per sequence ({len(seqs)}), "
                         f"got {len(labels)}")
    unknown = sorted(set(labels) - set(names))
    if unknown:
        raise ValueError(f"labels {unknown} are not in class_names {list(names)}")
    if isinstance(num_states, (int, np.integer)) and not isinstance(num_states, bool):
        states = [num_states] * len(names)
    else:
        states = list(num_states)
        if len(states) != len(names):
            raise ValueError(f"num_states must be one integer or one per class "
                             f"({len(names)}), got {len(states)}")
    initial = [initial_model(n, num_symbols, expected_length) for n in states]
    _check_options(tol, max_iter, emission_floor, num_symbols)
    checked = _check_sequences(seqs, num_symbols)
    groups, empty = [], []
    for name in names:
        mine = [s for s, lab in zip(checked, labels) if lab == name]
        nonempty = [s for s in mine if s.size]
        if not nonempty:
            raise ValueError(f"class {name!r} has no non-empty training sequence")
        groups.append(nonempty)
        empty.append(len(mine) - len(nonempty))
    try:
        fitted = _fit(initial, groups, float(tol), int(max_iter), float(emission_floor))
    except ValueError as exc:
        raise ValueError(f"training failed: {exc}") from None
    models, reports = [], {}
    for name, (model, report), skipped in zip(names, fitted, empty):
        models.append(model)
        reports[name] = replace(report, skipped_empty=skipped).to_dict()
    states = [int(n) for n in states]
    info = {"trainer": "baum-welch",
            "states": states[0] if len(set(states)) == 1 else states,
            "tol": float(tol), "max_iter": int(max_iter),
            "emission_floor": float(emission_floor),
            "expected_length": int(expected_length)}
    info.update(meta or {})
    info["training"] = reports
    return GestureModels(names, tuple(models), info)
