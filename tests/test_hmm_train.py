"""HMM training (recognition.hmm_train): the initial model of eq. 29-33,
Baum-Welch against hmmlearn as an oracle, left-right structure, monotone
log-likelihood, long sequences, skipped sequences, emission floor, and the
sw_hps forward algorithm against hmmlearn's score()."""
import warnings

import numpy as np
import pytest
from hmmlearn.hmm import CategoricalHMM

from recognition.hmm_train import (TrainingReport, baum_welch, initial_model,
                                   train_models)
from sw_hps.hmm import DiscreteHMM, GestureModels

M = 8


def random_left_right(rng, n, m=M, skip=False, zero_emissions=False):
    """Random banded model: self loop, next state (and the one after if skip)."""
    a = np.zeros((n, n))
    for i in range(n - 1):
        width = min(3 if skip else 2, n - i)
        a[i, i:i + width] = rng.dirichlet(np.ones(width))
    a[n - 1, n - 1] = 1.0
    b = rng.dirichlet(np.ones(m), size=n)
    if zero_emissions:
        b[rng.random((n, m)) < 0.2] = 0.0
        b[:, 0] += 1e-3                          # every row keeps a non-zero entry
        b /= b.sum(axis=1, keepdims=True)
    pi = np.zeros(n)
    pi[0] = 1.0
    return DiscreteHMM(pi, a, b)


def oracle(model, params="", n_iter=1):
    h = CategoricalHMM(n_components=model.num_states, n_features=model.num_symbols,
                       init_params="", params=params, n_iter=n_iter, tol=-np.inf)
    h.startprob_, h.transmat_, h.emissionprob_ = model.pi.copy(), model.A.copy(), model.B.copy()
    return h


def oracle_score(model, seq):
    with warnings.catch_warnings(), np.errstate(divide="ignore"):
        warnings.simplefilter("ignore")
        return oracle(model).score(np.asarray(seq, dtype=np.int64).reshape(-1, 1))


def oracle_fit(model, seqs, n_iter):
    h = oracle(model, params="te", n_iter=n_iter)
    with warnings.catch_warnings(), np.errstate(divide="ignore"):
        warnings.simplefilter("ignore")
        h.fit(np.concatenate(seqs).reshape(-1, 1).astype(np.int64), [len(s) for s in seqs])
    return h


def random_sequences(rng, count, lo, hi, m=M):
    return [rng.integers(0, m, size=int(rng.integers(lo, hi + 1))) for _ in range(count)]


# ------------------------------------------------------------ initial model


@pytest.mark.parametrize("n, t", [(1, 60), (2, 60), (5, 60), (7, 60), (12, 30), (4, 4)])
def test_initial_model_is_eq_29_to_33(n, t):
    model = initial_model(n, num_symbols=M, expected_length=t)
    d = t / n
    expected = np.zeros((n, n))
    for i in range(n - 1):
        expected[i, i] = 1 - 1 / d
        expected[i, i + 1] = 1 / d
    expected[n - 1, n - 1] = 1.0
    assert np.array_equal(model.A, expected)
    assert np.array_equal(model.B, np.full((n, M), 1 / M))
    assert np.array_equal(model.pi, np.eye(n)[0])


def test_initial_model_defaults_and_symbols():
    model = initial_model(5)
    assert model.A[0, 0] == 1 - 5 / 60 and model.A[0, 1] == 5 / 60
    assert model.B.shape == (5, 8)
    assert initial_model(3, num_symbols=4).B.shape == (3, 4)


@pytest.mark.parametrize("kwargs, name", [
    (dict(num_states=0), "num_states"), (dict(num_states=65), "num_states"),
    (dict(num_states=True), "num_states"), (dict(num_states=2.0), "num_states"),
    (dict(num_states=61), "num_states"),                     # d = T/N < 1
    (dict(num_states=3, expected_length=2), "num_states"),
    (dict(num_states=3, expected_length=0), "expected_length"),
    (dict(num_states=3, num_symbols=0), "num_symbols"),
])
def test_initial_model_validates(kwargs, name):
    with pytest.raises(ValueError, match=name):
        initial_model(**kwargs)


# ------------------------------------------------------------ forward oracle


@pytest.mark.parametrize("seed", range(6))
def test_forward_log_likelihood_equals_hmmlearn_score(seed):
    rng = np.random.default_rng(seed)
    model = random_left_right(rng, int(rng.integers(1, 9)), skip=seed % 2 == 1)
    for length in (1, 2, 7, 60, 333, 1000):
        seq = rng.integers(0, M, size=length)
        ours = model.log_likelihood(seq)
        assert np.isfinite(ours)
        assert abs(ours - oracle_score(model, seq)) <= 1e-9

def forbidding(model, symbol):
    """``model`` with ``symbol`` made impossible in every state (B renormalised)."""
    b = model.B.copy()
    b[:, symbol] = 0.0
    b /= b.sum(axis=1, keepdims=True)
    return DiscreteHMM(model.pi, model.A, b)


def test_forward_impossible_sequence_is_minus_infinity_in_both():
    model = forbidding(initial_model(3), 5)
    seq = np.array([0, 1, 5, 2])
    assert model.log_likelihood(seq) == -np.inf == oracle_score(model, seq)


def test_gesture_models_scores_equal_hmmlearn_for_mixed_state_counts():
    rng = np.random.default_rng(7)
    models = [random_left_right(rng, n) for n in (2, 5, 8)]
    gm = GestureModels(("a", "b", "c"), tuple(models))
    seq = rng.integers(0, M, size=60)
    expected = [oracle_score(m, seq) for m in models]
    assert np.allclose(gm.scores(seq), expected, rtol=0, atol=1e-9)


# ------------------------------------------------------------ Baum-Welch vs hmmlearn


@pytest.mark.parametrize("seed, n_iter", [(0, 1), (1, 1), (2, 4)])
def test_baum_welch_steps_equal_hmmlearn_fit(seed, n_iter):
    """hmmlearn's fit does one E-step and one M-step per iteration (pi fixed:
    params="te"), like one re-estimation here."""
    rng = np.random.default_rng(seed)
    model = random_left_right(rng, 5, skip=seed == 1)
    seqs = random_sequences(rng, 30, 20, 80)
    ours, report = baum_welch(model, seqs, tol=0.0, max_iter=n_iter)
    theirs = oracle_fit(model, seqs, n_iter)
    assert report.iterations == n_iter
    assert np.allclose(ours.A, theirs.transmat_, rtol=0, atol=1e-9)
    assert np.allclose(ours.B, theirs.emissionprob_, rtol=0, atol=1e-9)
    assert np.array_equal(ours.pi, model.pi)
    # hmmlearn records the log-likelihood before each M-step.
    assert np.allclose(report.log_likelihood[:n_iter], list(theirs.monitor_.history),
                       rtol=1e-12, atol=1e-9)
    assert report.log_likelihood[-1] == pytest.approx(
        sum(oracle_score(ours, s) for s in seqs), abs=1e-8)


# ------------------------------------------------------------ structure and convergence


@pytest.mark.parametrize("seed", range(4))
def test_zero_transitions_stay_zero_and_likelihood_never_decreases(seed):
    rng = np.random.default_rng(100 + seed)
    n = int(rng.integers(2, 8))
    model = initial_model(n) if seed % 2 == 0 else random_left_right(rng, n, skip=True)
    seqs = random_sequences(rng, 25, 10, 70)
    trained, report = baum_welch(model, seqs, tol=1e-6, max_iter=200)
    assert not trained.A[model.A == 0].any()            # exactly zero, not tiny
    assert np.array_equal(trained.pi, model.pi)
    history = np.array(report.log_likelihood)
    assert len(history) == report.iterations + 1
    assert (np.diff(history) >= -1e-9 * np.abs(history[1:])).all()
    assert history[-1] > history[0]
    assert np.allclose(trained.A.sum(axis=1), 1) and np.allclose(trained.B.sum(axis=1), 1)


def test_convergence_rule_and_iteration_cap():
    rng = np.random.default_rng(3)
    seqs = random_sequences(rng, 20, 30, 50)
    model, report = baum_welch(initial_model(4), seqs, tol=1e-4)
    assert report.converged
    assert report.log_likelihood[-1] - report.log_likelihood[-2] < 1e-4
    assert all(np.diff(report.log_likelihood[:-1]) >= 1e-4)
    capped, short = baum_welch(initial_model(4), seqs, tol=1e-4, max_iter=3)
    assert not short.converged and short.iterations == 3 and len(short.log_likelihood) == 4
    same, none = baum_welch(initial_model(4), seqs, max_iter=0)
    assert none.iterations == 0 and np.array_equal(same.A, initial_model(4).A)


def test_long_sequences_do_not_underflow():
    rng = np.random.default_rng(11)
    seqs = random_sequences(rng, 6, 1000, 2500)
    model, report = baum_welch(initial_model(6, expected_length=2000), seqs, tol=1e-3,
                               max_iter=50)
    assert np.isfinite(report.log_likelihood).all()
    assert report.log_likelihood[-1] < -5000            # far below the double range of P
    assert np.isfinite(model.A).all() and np.isfinite(model.B).all()
    total = sum(oracle_score(model, s) for s in seqs)
    assert report.log_likelihood[-1] == pytest.approx(total, rel=1e-12)


def sample(model, length, rng):
    state, out = 0, np.empty(length, dtype=np.int64)
    for t in range(length):
        out[t] = rng.choice(model.num_symbols, p=model.B[state])
        state = rng.choice(model.num_states, p=model.A[state])
    return out


def test_recovers_a_known_left_right_model():
    rng = np.random.default_rng(5)
    truth_b = np.full((3, M), 0.02)
    for state, symbol in enumerate((0, 2, 5)):
        truth_b[state, symbol] = 1 - 0.02 * (M - 1)
    truth = DiscreteHMM([1, 0, 0], [[0.9, 0.1, 0], [0, 0.9, 0.1], [0, 0, 1]], truth_b)
    seqs = [sample(truth, 40, rng) for _ in range(150)]
    model, report = baum_welch(initial_model(3, expected_length=40), seqs)
    assert report.converged
    assert list(model.B.argmax(axis=1)) == [0, 2, 5]
    assert np.abs(model.B - truth.B).max() < 0.05
    assert np.abs(model.A - truth.A).max() < 0.05
    truth_ll = sum(truth.log_likelihood(s) for s in seqs)
    assert report.log_likelihood[-1] >= truth_ll - 1.0      # maximum likelihood


# ------------------------------------------------------------ skipped sequences, floor


def test_empty_and_impossible_sequences_are_skipped_and_counted():
    model = forbidding(initial_model(3), 7)
    rng = np.random.default_rng(2)
    good = [rng.integers(0, 7, size=30) for _ in range(8)]
    bad = [np.array([1, 2, 7, 3]), np.array([7])]
    mixed = [good[0], np.array([], dtype=np.int8), bad[0], *good[1:], bad[1], []]
    trained, report = baum_welch(model, mixed, max_iter=20)
    reference, _ = baum_welch(model, good, max_iter=20)
    assert (report.skipped_empty, report.skipped_impossible, report.sequences) == (2, 2, 8)
    assert report.symbols == sum(len(s) for s in good)
    assert np.allclose(trained.A, reference.A, atol=1e-12)
    assert np.allclose(trained.B, reference.B, atol=1e-12)
    assert not trained.B[:, 7].any()
    with pytest.raises(ValueError, match="non-empty"):
        baum_welch(model, [[], []])
    with pytest.raises(ValueError, match="non-zero probability"):
        baum_welch(model, bad)


def test_emission_floor_keeps_unseen_symbols_possible():
    rng = np.random.default_rng(8)
    seqs = [rng.integers(0, 4, size=40) for _ in range(10)]        # symbols 4..7 unseen
    plain, _ = baum_welch(initial_model(3), seqs, max_iter=30)
    floored, _ = baum_welch(initial_model(3), seqs, max_iter=30, emission_floor=1e-3)
    probe = np.array([0, 1, 6, 2])
    assert plain.log_likelihood(probe) == -np.inf
    assert np.isfinite(floored.log_likelihood(probe))
    assert floored.B.min() >= 1e-3 / (1 + M * 1e-3)
    assert np.allclose(floored.B.sum(axis=1), 1)
    assert not floored.A[initial_model(3).A == 0].any()


@pytest.mark.parametrize("kwargs, name", [
    (dict(tol=-1.0), "tol"), (dict(tol=float("nan")), "tol"),
    (dict(max_iter=-1), "max_iter"), (dict(max_iter=2.5), "max_iter"),
    (dict(emission_floor=0.125), "emission_floor"), (dict(emission_floor=-0.1), "emission_floor"),
])
def test_baum_welch_validates_options(kwargs, name):
    with pytest.raises(ValueError, match=name):
        baum_welch(initial_model(2), [[0, 1, 2]], **kwargs)


@pytest.mark.parametrize("seqs", [[[0, 8]], [[-1]], [[[0, 1]]], [[0.5, 1.0]]])
def test_baum_welch_rejects_bad_symbols(seqs):
    with pytest.raises(ValueError, match=r"sequences\[0\]"):
        baum_welch(initial_model(2), seqs)


# ------------------------------------------------------------ train_models


def test_train_models_equals_one_baum_welch_per_class():
    rng = np.random.default_rng(9)
    seqs = random_sequences(rng, 24, 20, 60)
    labels = ["b", "a", "c"] * 8
    gm = train_models(seqs, labels, ("c", "a", "b"), [3, 4, 2], tol=1e-3,
                      emission_floor=1e-3, expected_length=50, meta={"note": "x"})
    assert gm.class_names == ("c", "a", "b")
    assert [m.num_states for m in gm.models] == [3, 4, 2]
    for name, n, model in zip(gm.class_names, (3, 4, 2), gm.models):
        mine = [s for s, lab in zip(seqs, labels) if lab == name]
        alone, report = baum_welch(initial_model(n, expected_length=50), mine, tol=1e-3,
                                   emission_floor=1e-3)
        assert np.allclose(model.A, alone.A, atol=1e-10)
        assert np.allclose(model.B, alone.B, atol=1e-10)
        assert gm.meta["training"][name]["iterations"] == report.iterations
    meta = gm.meta
    assert (meta["states"], meta["tol"], meta["max_iter"], meta["emission_floor"],
            meta["expected_length"], meta["note"]) == ([3, 4, 2], 1e-3, 5000, 1e-3, 50, "x")
    assert GestureModels.from_dict(gm.to_dict()).to_dict() == gm.to_dict()


def test_train_models_errors():
    seqs = [np.array([0, 1, 2])] * 4
    with pytest.raises(ValueError, match="not in class_names"):
        train_models(seqs, ["a", "a", "b", "z"], ("a", "b"), 2)
    with pytest.raises(ValueError, match="'b' has no non-empty"):
        train_models([*seqs[:3], []], ["a", "a", "a", "b"], ("a", "b"), 2)
    with pytest.raises(ValueError, match="num_states"):
        train_models(seqs, ["a"] * 4, ("a",), 0)
    with pytest.raises(ValueError, match="one per class"):
        train_models(seqs, ["a"] * 4, ("a",), [2, 3])
    with pytest.raises(ValueError, match="labels"):
        train_models(seqs, ["a"] * 3, ("a",), 2)


def test_training_report_summary():
    _, report = baum_welch(initial_model(2), [[0, 1, 1, 2]], max_iter=2)
    assert isinstance(report, TrainingReport)
    summary = report.to_dict()
    assert summary["log_likelihood"] == report.final_log_likelihood
    assert set(summary) == {"iterations", "converged", "sequences", "symbols",
                            "skipped_empty", "skipped_impossible", "log_likelihood"}
