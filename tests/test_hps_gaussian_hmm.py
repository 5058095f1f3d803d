"""Gaussian left-right gesture HMMs (sw_hps.gaussian_hmm) and the version 2
model file (sw_hps.hmm): the forward algorithm against hmmlearn's diagonal
GaussianHMM and against a brute-force sum over every state path, feature
weights, validation (one-line ValueErrors naming the field), the model file
round trip, version 1 files, and the rejection rule (sw_hps.hmm.decide)."""
import itertools
import json
import math
import warnings

import numpy as np
import pytest
from hmmlearn.hmm import GaussianHMM as OracleHMM

from sw_hps.gaussian_hmm import (GaussianGestureModels, GaussianHMM, forward_log_likelihood,
                                 log_emissions)
from sw_hps.hmm import (DiscreteHMM, GestureModels, check_thresholds, decide, load_models,
                        save_models)
from sw_hps.stroke import FEATURE_NAMES

F = len(FEATURE_NAMES)


def random_component(rng, n, f=F, low_stay=0.2):
    stay = rng.uniform(low_stay, 0.9, n)
    stay[-1] = 1.0
    return GaussianHMM(stay, rng.normal(0, 1, (n, f)), rng.uniform(0.2, 2.0, (n, f)))


def transmat(stay):
    n = len(stay)
    a = np.diag(stay)
    a[np.arange(n - 1), np.arange(1, n)] = 1 - stay[:-1]
    return a


def oracle(comp):
    h = OracleHMM(n_components=comp.num_states, covariance_type="diag", init_params="",
                  params="")
    start = np.zeros(comp.num_states)
    start[0] = 1.0
    h.startprob_, h.transmat_ = start, transmat(comp.stay)
    h.means_, h.covars_ = comp.mean.copy(), comp.var.copy()
    h.n_features = comp.num_features
    return h


def ours(comp, x, weights=None):
    """Our log-likelihood of one (T, F) sequence under one component."""
    w = np.ones(comp.num_features) if weights is None else np.asarray(weights, float)
    emit = log_emissions(x, comp.mean[None], comp.var[None], w)[0]          # (T, N)
    with np.errstate(divide="ignore"):
        log_stay, log_move = np.log(comp.stay), np.log1p(-comp.stay[:-1])
    return float(forward_log_likelihood(emit, log_stay, log_move)), emit


def weighted_log_pdf(x, mean, var, weights):
    """Independent scalar computation of the weighted diagonal log-density."""
    return sum(w * (-0.5 * math.log(2 * math.pi * v) - (xi - m) ** 2 / (2 * v))
               for xi, m, v, w in zip(x, mean, var, weights))


def brute_force(comp, x, weights):
    """log of the sum over every state path that starts in 0, moves by 0 or +1
    and ends in the last state, of the product of transitions and emissions."""
    n, t_max = comp.num_states, len(x)
    terms = []
    for path in itertools.product(range(n), repeat=t_max):
        if path[0] != 0 or path[-1] != n - 1:
            continue
        steps = np.diff(path)
        if ((steps != 0) & (steps != 1)).any():
            continue
        log_p = 0.0
        for t, state in enumerate(path):
            if t:
                p = comp.stay[path[t - 1]] if steps[t - 1] == 0 else 1 - comp.stay[path[t - 1]]
                log_p += math.log(p) if p > 0 else -math.inf
            log_p += weighted_log_pdf(x[t], comp.mean[state], comp.var[state], weights)
        terms.append(log_p)
    if not terms:
        return -math.inf
    top = max(terms)
    if top == -math.inf:
        return -math.inf
    return top + math.log(sum(math.exp(v - top) for v in terms))


# ---- the forward algorithm against oracles ----------------------------------------------
@pytest.mark.parametrize("seed", range(4))
@pytest.mark.parametrize("n, t_max", [(1, 4), (3, 7), (5, 20)])
def test_forward_equals_hmmlearn_last_state_of_the_lattice(seed, n, t_max):
    from hmmlearn import _hmmc
    rng = np.random.default_rng(seed)
    comp = random_component(rng, n)
    x = rng.normal(0, 1.5, (t_max, F))
    h = oracle(comp)
    value, emit = ours(comp, x)
    # Emission log-densities: hmmlearn's own.
    assert np.allclose(emit, h._compute_log_likelihood(x), rtol=1e-12, atol=1e-9)
    # hmmlearn's forward lattice (what score() sums over the last row); ours is the
    # entry of the last state, since the gesture must end there.
    with np.errstate(divide="ignore"), warnings.catch_warnings():
        warnings.simplefilter("ignore")
        total, lattice = _hmmc.forward_log(h.startprob_, h.transmat_,
                                           h._compute_log_likelihood(x))
    assert np.isclose(value, lattice[-1, -1], rtol=1e-10, atol=1e-8)
    # Sanity of the way the lattice is read: its last row sums to score().
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        assert np.isclose(np.logaddexp.reduce(lattice[-1]), h.score(x), rtol=1e-10)
    assert np.isclose(total, h.score(x), rtol=1e-10)
    if n == 1:                                       # one state: nothing but the emissions
        assert np.isclose(value, h.score(x), rtol=1e-12)


@pytest.mark.parametrize("seed", range(5))
def test_forward_equals_the_sum_over_all_paths(seed):
    """N=3, T=5: every one of the 3**5 state sequences, weights 1 and not."""
    rng = np.random.default_rng(100 + seed)
    comp = random_component(rng, 3, low_stay=0.0)
    x = rng.normal(0, 1.0, (5, F))
    for weights in (np.ones(F), rng.uniform(0.1, 3.0, F)):
        value, _ = ours(comp, x, weights)
        assert np.isclose(value, brute_force(comp, x, weights), rtol=1e-10, atol=1e-9)


def test_too_short_to_reach_the_last_state_is_impossible():
    rng = np.random.default_rng(7)
    comp = random_component(rng, 4)
    value, _ = ours(comp, rng.normal(size=(3, F)))   # 3 vectors, 4 states
    assert value == -np.inf
    assert brute_force(comp, rng.normal(size=(3, F)), np.ones(F)) == -np.inf
    # stay = 0 everywhere: only T = N is possible
    chain = GaussianHMM([0.0, 0.0, 1.0], np.zeros((3, F)), np.ones((3, F)))
    assert np.isfinite(ours(chain, np.zeros((3, F)))[0])
    assert ours(chain, np.zeros((2, F)))[0] == -np.inf


def test_weights_scale_each_features_log_density():
    rng = np.random.default_rng(3)
    comp = random_component(rng, 4)
    x = rng.normal(size=(9, F))
    one = log_emissions(x, comp.mean[None], comp.var[None], np.ones(F))[0]
    for k in range(F):
        w = np.ones(F)
        w[k] = 2.5
        per_feature = -0.5 * (np.log(2 * np.pi * comp.var[None, :, k])
                              + (x[:, None, k] - comp.mean[None, :, k]) ** 2 / comp.var[None, :, k])
        scaled = log_emissions(x, comp.mean[None], comp.var[None], w)[0]
        assert np.allclose(scaled - one, 1.5 * per_feature, rtol=1e-12, atol=1e-10)
    w = rng.uniform(0.1, 3, F)
    got = log_emissions(x, comp.mean[None], comp.var[None], w)[0]
    want = [[weighted_log_pdf(x[t], comp.mean[j], comp.var[j], w) for j in range(4)]
            for t in range(9)]
    assert np.allclose(got, want, rtol=1e-12, atol=1e-10)


def test_batched_scores_equal_one_at_a_time_and_best_component_wins():
    rng = np.random.default_rng(11)
    comps = [(random_component(rng, 3), random_component(rng, 3)), (random_component(rng, 3),)]
    models = GaussianGestureModels(("a", "b"), comps, 8, np.ones(F))
    x = rng.normal(size=(4, 7, F))
    batch = models.scores_of_features(x)
    assert batch.shape == (4, 2)
    for s in range(4):
        assert np.allclose(batch[s], models.scores_of_features(x[s]), rtol=1e-12)
        per = [[ours(c, x[s])[0] for c in group] for group in comps]
        assert np.allclose(batch[s], [max(p) for p in per], rtol=1e-10)
    assert models.steps == 7 and models.num_states == 3


# ---- validation --------------------------------------------------------------------------
GOOD = dict(stay=[0.5, 0.5, 1.0], mean=np.zeros((3, F)), var=np.ones((3, F)))


@pytest.mark.parametrize("change, field", [
    (dict(stay=[0.5, 0.5, 0.9]), "stay"),
    (dict(stay=[0.5, 1.5, 1.0]), "stay"),
    (dict(stay=[-0.1, 0.5, 1.0]), "stay"),
    (dict(stay=[[0.5, 0.5, 1.0]]), "stay"),
    (dict(stay=[np.nan, 0.5, 1.0]), "stay"),
    (dict(stay=[]), "stay"),
    (dict(mean=np.zeros((2, F))), "mean"),
    (dict(mean=np.zeros(3)), "mean"),
    (dict(mean=np.full((3, F), np.nan)), "mean"),
    (dict(mean="abc"), "mean"),
    (dict(var=np.ones((3, F + 1))), "var"),
    (dict(var=np.zeros((3, F))), "var"),
    (dict(var=-np.ones((3, F))), "var"),
    (dict(var=np.full((3, F), np.inf)), "var"),
])
def test_bad_component_is_a_value_error_naming_the_field(change, field):
    with pytest.raises(ValueError) as info:
        GaussianHMM(**{**GOOD, **change})
    message = str(info.value)
    assert field in message and "\n" not in message


def good_models(**change):
    comp = GaussianHMM(**GOOD)
    options = dict(class_names=("a", "b"), components=((comp,), (comp, comp)), resample=8,
                   weights=np.ones(F))
    options.update(change)
    return GaussianGestureModels(**options)


@pytest.mark.parametrize("change, words", [
    (dict(class_names=("a", "a")), ["class_names", "unique"]),
    (dict(class_names=("a",)), ["class_names", "models"]),
    (dict(components=((), (GaussianHMM(**GOOD),))), ["'a'", "component"]),
    (dict(resample=2), ["resample"]),
    (dict(resample=8.0), ["resample"]),
    (dict(resample=True), ["resample"]),
    (dict(weights=np.ones(F - 1)), ["weights"]),
    (dict(weights=np.zeros(F)), ["weights"]),
    (dict(weights=np.full(F, 11.0)), ["weights"]),
    (dict(weights=np.full(F, np.nan)), ["weights"]),
    (dict(thresholds=[-1.0]), ["thresholds", "2"]),
    (dict(thresholds=[-1.0, np.nan]), ["thresholds"]),
    (dict(components=((GaussianHMM([1.0], np.zeros((1, F)), np.ones((1, F))),),
                      (GaussianHMM(**GOOD),))), ["same"]),
    (dict(components=((GaussianHMM(GOOD["stay"], np.zeros((3, 2)), np.ones((3, 2))),),) * 2),
     ["features"]),
])
def test_bad_model_set_is_a_one_line_value_error(change, words):
    with pytest.raises(ValueError) as info:
        good_models(**change)
    message = str(info.value)
    assert "\n" not in message
    for word in words:
        assert word in message, (word, message)


# ---- model file -------------------------------------------------------------------------
def trained_like(seed=0, thresholds=None):
    rng = np.random.default_rng(seed)
    comps = ((random_component(rng, 4), random_component(rng, 4)),
             (random_component(rng, 4),), (random_component(rng, 4),))
    return GaussianGestureModels(("left", "right", "stop"), comps, 12,
                                 rng.uniform(0.5, 2, F), thresholds, {"note": "x", "n": 3})


def test_model_file_round_trip_keeps_every_score(tmp_path):
    models = trained_like(thresholds=[-3.0, -2.5, -4.0])
    path = tmp_path / "gauss.json"
    save_models(models, path)
    data = json.loads(path.read_text())
    assert (data["version"], data["emission"]) == (6, "gaussian")
    assert data["rejection"]["thresholds"] == [-3.0, -2.5, -4.0]
    assert data["features"]["names"] == list(FEATURE_NAMES)
    loaded = load_models(path)
    assert isinstance(loaded, GaussianGestureModels) and loaded.emission == "gaussian"
    assert loaded.class_names == models.class_names and loaded.resample == 12
    assert loaded.thresholds == models.thresholds and loaded.meta == models.meta
    assert np.array_equal(loaded.weights, models.weights)
    assert [len(g) for g in loaded.components] == [2, 1, 1]
    x = np.random.default_rng(1).normal(size=(5, 11, F))
    assert np.array_equal(loaded.scores_of_features(x), models.scores_of_features(x))
    assert loaded.to_dict() == models.to_dict()
    # Without rejection: null in the file, None after loading.
    save_models(trained_like(), path)
    assert json.loads(path.read_text())["rejection"] is None
    assert load_models(path).thresholds is None


def test_with_thresholds_keeps_the_models():
    models = trained_like()
    refusing = models.with_thresholds([0.0, 1.0, 2.0])
    assert refusing.thresholds == (0.0, 1.0, 2.0) and models.thresholds is None
    x = np.random.default_rng(2).normal(size=(11, F))
    assert np.array_equal(refusing.scores_of_features(x), models.scores_of_features(x))
    assert refusing.meta == models.meta and refusing.meta is not models.meta


def discrete_v1():
    b = np.full((2, 8), 0.02)
    b[:, 3] = 1 - 0.02 * 7
    return {"format": "stereogest-hmm", "version": 1, "num_symbols": 8,
            "class_names": ["stop", "left"],
            "models": [{"pi": [1.0, 0.0], "A": [[0.9, 0.1], [0.0, 1.0]], "B": b.tolist()},
                       {"pi": [1.0], "A": [[1.0]], "B": [[0.125] * 8]}],
            "meta": {"states": 2}}


def test_version_1_discrete_file_still_loads(tmp_path):
    path = tmp_path / "v1.json"
    path.write_text(json.dumps(discrete_v1()))
    models = load_models(path)
    assert isinstance(models, GestureModels) and models.emission == "discrete"
    assert models.class_names == ("stop", "left") and models.thresholds is None
    assert [m.num_states for m in models.models] == [2, 1]
    scores = models.scores([3, 3, 3])
    assert models.decide(scores, 3) == (0, None)
    # Version 1 has no emission field: even a stray one is ignored (always discrete).
    path.write_text(json.dumps({**discrete_v1(), "emission": "gaussian"}))
    assert load_models(path).emission == "discrete"
    # Written back, it is a version 6 discrete file with the same scores.
    save_models(models, tmp_path / "v6.json")
    data = json.loads((tmp_path / "v6.json").read_text())
    assert (data["version"], data["emission"], data["rejection"], data["spotting"],
            data["postures"], data["commands"], data["verifier"]) == \
        (6, "discrete", None, None, None, None, None)
    assert np.array_equal(load_models(tmp_path / "v6.json").scores([3, 3, 3]), scores)
    # A version 2 file (no spotting) loads too.
    path.write_text(json.dumps({**discrete_v1(), "version": 2, "emission": "discrete",
                                "rejection": None}))
    assert load_models(path).spotting is None


def test_discrete_thresholds_round_trip(tmp_path):
    models = GestureModels.from_dict(discrete_v1()).with_thresholds([-1.0, -2.0])
    save_models(models, tmp_path / "d.json")
    assert load_models(tmp_path / "d.json").thresholds == (-1.0, -2.0)


def gaussian_dict(**change):
    data = trained_like(thresholds=[-3.0, -2.5, -4.0]).to_dict()
    data.update(change)
    return data


@pytest.mark.parametrize("data, words", [
    (gaussian_dict(emission="poisson"), ["emission", "poisson"]),
    (gaussian_dict(version=7), ["version", "7"]),
    (gaussian_dict(version=True), ["version"]),
    (gaussian_dict(version="2"), ["version"]),
    (gaussian_dict(format="other"), ["format"]),
    (gaussian_dict(rejection={"thresholds": [-1.0, -2.0]}), ["thresholds", "3"]),
    (gaussian_dict(rejection={"thresholds": [-1.0, -2.0, None]}), ["thresholds"]),
    (gaussian_dict(rejection={"quantile": 0.1}), ["rejection", "thresholds"]),
    (gaussian_dict(rejection=[1, 2, 3]), ["rejection"]),
    (gaussian_dict(features={"names": ["a"], "resample": 12, "weights": [1] * F}),
     ["features", "names"]),
    (gaussian_dict(features=None), ["features"]),
    (gaussian_dict(models=[{"components": []}, {"components": []}, {"components": []}]),
     ["'left'", "components"]),
    (gaussian_dict(models=[{"components": [{"stay": [1.0]}]}] * 3), ["'left'", "component 0"]),
    (gaussian_dict(models=[{"components": [{"stay": [0.5, 0.9], "mean": [[0] * F] * 2,
                                            "var": [[1] * F] * 2}]}] * 3),
     ["'left'", "component 0", "stay"]),
    (gaussian_dict(class_names=["left", "right", "stop", "extra"]), ["4 class_names", "3"]),
    ({**discrete_v1(), "version": 2, "emission": "discrete",
      "rejection": {"thresholds": [0.0]}}, ["thresholds", "2"]),
    ({**discrete_v1(), "version": 3, "emission": "discrete",
      "spotting": {"end_delay": 0}}, ["spotting end_delay", "[1, 1000]"]),
    ({**discrete_v1(), "version": 3, "emission": "discrete",
      "spotting": {"delay": 3}}, ["spotting", "unknown", "delay"]),
    ({**discrete_v1(), "version": 3, "emission": "discrete", "spotting": [1]},
     ["spotting must be null or an object"]),
    (gaussian_dict(version=3, spotting={"end_delay": 4}), ["spotting must be null", "gaussian"]),
    ({**discrete_v1(), "version": 7}, ["version must be one of [1, 2, 3, 4, 5, 6]"]),
    ({**discrete_v1(), "version": 5, "emission": "discrete", "commands": ["stop"]},
     ["commands must be null or an object"]),
    ({**discrete_v1(), "version": 5, "emission": "discrete", "commands": {"zigzag": "stop"}},
     ["commands", "'zigzag' is not a class"]),
    (gaussian_dict(version=5, commands={"left": "fly"}),
     ["commands", "'left' maps to 'fly'", "not a robot command", "rotate-right"]),
    ({**discrete_v1(), "version": 4, "emission": "discrete", "postures": []},
     ["postures must be null or an object"]),
    ({**discrete_v1(), "version": 4, "emission": "discrete", "postures": {"fingers": 1}},
     ["postures: unknown key", "fingers"]),
    ({**discrete_v1(), "version": 4, "emission": "discrete",
      "postures": {"command": ["asl2"], "share": 1.5}}, ["postures share", "[0, 1]"]),
    ({**discrete_v1(), "version": 4, "emission": "discrete",
      "postures": {"command": ["asl2"], "power": {"asl2": 101}}},
     ["postures power 'asl2'", "[0, 100]", "NXT motor power"]),
    ({**discrete_v1(), "version": 4, "emission": "discrete",
      "postures": {"command": ["asl2", "asl3"], "power": {"asl2": 50}}},
     ["postures power has no level", "asl3"]),
    ({**discrete_v1(), "version": 4, "emission": "discrete",
      "postures": {"command": ["fist"], "stop": "fist"}}, ["postures stop 'fist'"]),
    ({**discrete_v1(), "version": 4, "emission": "discrete",
      "postures": {"stop": "fist", "stop_frames": 0}}, ["postures stop_frames", "[1, 30]"]),
    (gaussian_dict(version=4, postures={"command": "asl2"}), ["postures command", "list"]),
])
def test_bad_model_file_is_a_one_line_error_naming_the_problem(tmp_path, data, words):
    path = tmp_path / "bad.json"
    path.write_text(json.dumps(data))
    with pytest.raises(ValueError) as info:
        load_models(path)
    message = str(info.value)
    assert "\n" not in message and message.startswith(str(path))
    for word in words:
        assert word in message, (word, message)



def test_more_models_than_class_names_is_refused(tmp_path):
    data = gaussian_dict(class_names=["left", "right"], rejection=None)
    path = tmp_path / "extra.json"
    path.write_text(json.dumps(data))
    with pytest.raises(ValueError, match="class_names"):
        load_models(path)


def test_discrete_reader_refuses_more_models_than_class_names(tmp_path):
    data = {**discrete_v1(), "class_names": ["stop"]}
    path = tmp_path / "extra.json"
    path.write_text(json.dumps(data))
    with pytest.raises(ValueError, match="1 class_names but 2 models"):
        load_models(path)


# ---- the rejection rule -----------------------------------------------------------------
NAMES = ("left", "right", "stop")


def test_decide_accepts_the_best_class_at_or_above_its_threshold():
    scores = np.array([-40.0, -20.0, -30.0])
    assert decide(scores, 10, None, NAMES) == (1, None)            # no thresholds
    assert decide(scores, 10, (-1.0, -2.0, -1.0), NAMES) == (1, None)  # -2.0 >= -2.0
    assert decide(scores, 10, (0.0, -2.5, 0.0), NAMES) == (1, None)    # only the best's counts


def test_decide_refuses_below_the_best_class_threshold_naming_it():
    scores = np.array([-40.0, -20.0, -30.0])
    index, reason = decide(scores, 10, (-10.0, -1.9, -10.0), NAMES)
    assert index == -1
    assert "'right'" in reason and "-2.000" in reason and "-1.900" in reason
    assert "not a gesture" in reason and "\n" not in reason


def test_decide_with_no_finite_score():
    minus = np.full(3, -np.inf)
    index, reason = decide(minus, 7, None, NAMES)
    assert index == -1 and "probability 0" in reason and "7" in reason
    assert decide(minus, 7, (-1.0, -1.0, -1.0), NAMES)[0] == -1
    # -inf for some classes only: the finite one wins.
    assert decide(np.array([-np.inf, -5.0, -np.inf]), 5, (-2.0, -2.0, -2.0), NAMES) == (1, None)


def test_model_decide_uses_its_steps_and_thresholds():
    models = trained_like()
    x = np.random.default_rng(4).normal(size=(models.steps, F))
    scores = models.scores_of_features(x)
    best = int(np.argmax(scores))
    assert models.decide(scores) == (best, None)
    per_step = scores[best] / models.steps
    above = [per_step - 0.01] * 3
    below = [per_step + 0.01] * 3
    assert models.with_thresholds(above).decide(scores) == (best, None)
    index, reason = models.with_thresholds(below).decide(scores, steps=999)  # steps ignored
    assert index == -1 and repr(models.class_names[best]) in reason


def test_check_thresholds():
    assert check_thresholds(None, 3) is None
    assert check_thresholds(np.array([1, 2, 3]), 3) == (1.0, 2.0, 3.0)
    for bad in ([1.0, 2.0], [[1.0, 2.0, 3.0]], [1.0, np.inf, 2.0], "abc", [1.0, None, 2.0]):
        with pytest.raises(ValueError, match="3 finite numbers"):
            check_thresholds(bad, 3)
    with pytest.raises(ValueError, match="thresholds"):
        GestureModels(("a",), (DiscreteHMM([1.0], [[1.0]], [[0.5, 0.5]]),), {}, [1.0, 2.0])
