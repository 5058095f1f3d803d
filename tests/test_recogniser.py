"""Training of the Gaussian gesture HMMs (recognition.gaussian_train) and the
recogniser with rejection (recognition.recogniser, recognition.evaluation) on
tiny synthetic data: Baum-Welch recovers a known model and never lowers the
likelihood, two stroke classes are separated, thresholds are calibrated on
held-out subjects, gestures are accepted and a random walk is refused."""
from dataclasses import replace

import numpy as np
import pytest

from recognition.datasets import TrajectorySet
from recognition.evaluation import (CVOutcome, confusion_png, grouped_cross_validation,
                                    open_set_rejection)
from recognition.gaussian_train import (MAX_AUTO_COMPONENTS, SAMPLES_PER_COMPONENT,
                                        baum_welch_gaussian, default_components,
                                        train_gaussian_models)
from recognition.recogniser import MARGIN_GRID, Recogniser, fold_of_groups
from sw_hps.gaussian_hmm import (GaussianGestureModels, GaussianHMM, forward_log_likelihood,
                                 log_emissions)
from sw_hps.stroke import FEATURE_NAMES, stroke_features

F = len(FEATURE_NAMES)
PNG = b"\x89PNG\r\n\x1a\n"


# ---- Baum-Welch --------------------------------------------------------------------------
TRUE_STAY = np.array([0.8, 0.85, 1.0])
TRUE_MEAN = np.array([[0.0, 0.0], [4.0, 0.0], [0.0, 4.0]])
TRUE_VAR = np.array([[0.3, 0.5], [0.4, 0.2], [0.25, 0.3]])


def sample_sequences(rng, count, t_max=30):
    """Sequences of the true model that end in its last state (the model's
    definition of a complete gesture)."""
    out = []
    while len(out) < count:
        state, states = 0, []
        for _ in range(t_max):
            states.append(state)
            if rng.random() > TRUE_STAY[state]:
                state += 1
        if states[-1] != 2:
            continue
        states = np.array(states)
        out.append(rng.normal(TRUE_MEAN[states], np.sqrt(TRUE_VAR[states])))
    return np.stack(out)


def total_log_likelihood(model: GaussianHMM, x, weights):
    emit = log_emissions(x, model.mean[None], model.var[None], np.asarray(weights, float))[:, 0]
    with np.errstate(divide="ignore"):
        return float(forward_log_likelihood(emit, np.log(model.stay),
                                            np.log1p(-model.stay[:-1])).sum())


@pytest.fixture(scope="module")
def sequences():
    return sample_sequences(np.random.default_rng(0), 60)


def test_baum_welch_recovers_a_known_model(sequences):
    model = baum_welch_gaussian(sequences, 3, np.ones(2), iterations=10, var_floor=1e-3)
    assert np.allclose(model.mean, TRUE_MEAN, atol=0.15)
    assert np.allclose(model.var, TRUE_VAR, atol=0.1)
    assert np.allclose(model.stay, TRUE_STAY, atol=0.05) and model.stay[-1] == 1.0


@pytest.mark.parametrize("weights", [np.ones(2), np.array([0.5, 2.0])])
def test_baum_welch_never_lowers_the_likelihood(sequences, weights):
    x = sequences[:30]
    values = [total_log_likelihood(baum_welch_gaussian(x, 3, weights, iterations=i,
                                                       var_floor=1e-3), x, weights)
              for i in range(0, 6)]
    # iterations=0 is the initial even split; every re-estimation keeps or raises it
    assert all(np.isfinite(values))
    assert all(b >= a - 1e-6 * abs(a) for a, b in zip(values, values[1:])), values
    assert values[-1] > values[0]


def test_initial_model_is_the_even_split(sequences):
    x = sequences[:10]
    model = baum_welch_gaussian(x, 3, np.ones(2), iterations=0, var_floor=1e-3)
    part = np.minimum(np.arange(30) * 3 // 30, 2)
    for j in range(3):
        assert np.allclose(model.mean[j], x[:, part == j].reshape(-1, 2).mean(axis=0))
    assert np.allclose(model.stay, [0.9, 0.9, 1.0])


def test_variance_floor(sequences):
    model = baum_welch_gaussian(sequences[:10], 3, np.ones(2), iterations=3, var_floor=0.9)
    assert (model.var >= 0.9).all()
    constant = np.zeros((4, 12, 2))
    model = baum_welch_gaussian(constant, 2, np.ones(2), iterations=3, var_floor=0.05)
    assert np.allclose(model.var, 0.05) and np.allclose(model.mean, 0.0)


def test_baum_welch_bad_state_count(sequences):
    with pytest.raises(ValueError, match="states"):
        baum_welch_gaussian(sequences[:, :5], 6, np.ones(2))
    with pytest.raises(ValueError, match="states"):
        baum_welch_gaussian(sequences, 0, np.ones(2))


# ---- whole-class training ----------------------------------------------------------------
def line(rng, dx, dy, points=None):
    """A noisy pen line of about 200 px in direction (dx, dy), uneven sampling."""
    n = int(rng.integers(15, 30)) if points is None else points
    u = np.sort(rng.random(n))
    u[0], u[-1] = 0.0, 1.0
    wobble = 5 * np.sin(2 * np.pi * u * rng.uniform(0.5, 1.5)) + rng.normal(0, 1, n)
    length = rng.uniform(150, 250)
    return np.column_stack([300 + length * u * dx - wobble * dy,
                            300 + length * u * dy + wobble * dx])


def corner(rng):
    """Right, then up (an L drawn from its foot)."""
    a = line(rng, 1.0, 0.0)
    b = line(rng, 0.0, -1.0) - [300, 300] + a[-1]
    return np.concatenate([a, b[1:]])


SHAPES = {"right": lambda rng: line(rng, 1.0, 0.0), "up": lambda rng: line(rng, 0.0, -1.0),
          "corner": corner}


def shapes_data(per_class=9, subjects=3, seed=0, names=tuple(SHAPES)):
    rng = np.random.default_rng(seed)
    trajs, labels, subject = [], [], []
    for name in names:
        for i in range(per_class):
            trajs.append(SHAPES[name](rng))
            labels.append(name)
            subject.append(i % subjects)
    return TrajectorySet.from_list(trajs, labels, subject)


def random_walk(rng, steps=40):
    return np.cumsum(rng.normal(0, 12, (steps, 2)), axis=0) + 300


def test_default_components():
    assert default_components(0) == 1
    assert default_components(1) == 1
    assert default_components(SAMPLES_PER_COMPONENT - 1) == 1
    assert default_components(2 * SAMPLES_PER_COMPONENT) == 2
    assert default_components(3 * SAMPLES_PER_COMPONENT + 1) == min(3, MAX_AUTO_COMPONENTS)
    assert default_components(10 ** 6) == MAX_AUTO_COMPONENTS
    counts = [default_components(n) for n in range(0, 12 * SAMPLES_PER_COMPONENT, 7)]
    assert counts == sorted(counts) and set(counts) == set(range(1, MAX_AUTO_COMPONENTS + 1))


def test_two_stroke_classes_are_separated_perfectly():
    rng = np.random.default_rng(1)
    names = ("right", "up")
    train = [(stroke_features(SHAPES[n](rng), 16), n) for n in names for _ in range(10)]
    test = [(stroke_features(SHAPES[n](rng), 16), n) for n in names for _ in range(10)]
    models = train_gaussian_models([x for x, _ in train], [n for _, n in train], names,
                                   num_states=4, components=1, iterations=5, resample=16)
    assert isinstance(models, GaussianGestureModels) and models.thresholds is None
    assert models.class_names == names and models.resample == 16 and models.num_states == 4
    scores = models.scores_of_features(np.stack([x for x, _ in test]))
    assert [names[i] for i in scores.argmax(axis=1)] == [n for _, n in test]
    meta = models.meta
    assert meta["training"] == {"right": {"samples": 10, "components": 1},
                                "up": {"samples": 10, "components": 1}}
    assert meta["states"] == 4 and meta["emission"] == "gaussian"


def test_components_are_clusters_of_a_class():
    """A class drawn two ways (right or left) with enough samples gets two components."""
    rng = np.random.default_rng(2)
    feats = [stroke_features(line(rng, d, 0.0), 12) for d in (1.0, -1.0) for _ in range(10)]
    feats += [stroke_features(line(rng, 0.0, -1.0), 12) for _ in range(10)]
    labels = ["both"] * 20 + ["up"] * 10
    models = train_gaussian_models(feats, labels, ("both", "up"), num_states=3, components=2,
                                   iterations=3, resample=12)
    assert [len(g) for g in models.components] == [2, 1]        # 10 < 2 * MIN_CLUSTER
    cos = sorted(float(c.mean[:, 0].mean()) for c in models.components[0])
    assert cos[0] < -0.8 and cos[1] > 0.8


def test_samples_without_motion_are_skipped_and_bad_options_named():
    rng = np.random.default_rng(3)
    feats = [stroke_features(line(rng, 1.0, 0.0), 8) for _ in range(3)] + [None]
    labels = ["a", "a", "a", "a"]
    models = train_gaussian_models(feats, labels, ("a",), num_states=2, components=1,
                                   iterations=2, resample=8)
    assert models.meta["training"]["a"]["samples"] == 3
    for options, word in [(dict(num_states=8), "states"), (dict(num_states=0), "states"),
                          (dict(components=0), "components"), (dict(components=17), "components"),
                          (dict(var_floor=0.0), "var_floor"), (dict(iterations=0), "iterations")]:
        with pytest.raises(ValueError, match=word):
            train_gaussian_models(feats, labels, ("a",), resample=8,
                                  **{"num_states": 2, **options})
    with pytest.raises(ValueError, match="'b'"):
        train_gaussian_models(feats, labels, ("a", "b"), num_states=2, resample=8)
    with pytest.raises(ValueError, match="not in class_names"):
        train_gaussian_models(feats, ["a", "a", "a", "z"], ("a",), num_states=2, resample=8)
    with pytest.raises(ValueError, match="one entry per sample"):
        train_gaussian_models(feats, labels[:2], ("a",), num_states=2, resample=8)


# ---- the recogniser with rejection -------------------------------------------------------
RECOGNISER = Recogniser(resample=16, states=4, components=1)


@pytest.fixture(scope="module")
def fitted():
    data = shapes_data()
    samples = RECOGNISER.samples(data)
    models = RECOGNISER.fit(samples, data.label, data.class_names, groups=data.subject)
    return data, samples, models


def test_fit_calibrates_one_threshold_per_class(fitted):
    data, _, models = fitted
    assert models.class_names == ("corner", "right", "up")
    assert models.thresholds is not None and len(models.thresholds) == 3
    assert all(np.isfinite(models.thresholds))
    info = models.meta["rejection"]
    assert info["folds"] == 3 and info["grouped"] and info["quantile"] == 0.005
    assert info["margin"] == 1.5 and not info["margin_chosen"]
    assert sum(info["held_out_samples"]) <= len(data) and min(info["held_out_samples"]) > 0
    assert models.meta["recogniser"]["states"] == 4
    assert RECOGNISER.fit(RECOGNISER.samples(data), data.label, data.class_names,
                          groups=data.subject).thresholds == models.thresholds  # deterministic


def held_out_scores(data, samples) -> list[tuple]:
    """Each sample scored by models trained without its subject (the fixture's
    3 subjects): (subject, best class, its per-step score, right)."""
    names = data.class_names
    held = []
    for subject in range(3):
        train = data.subject != subject
        models = train_gaussian_models([s for s, k in zip(samples, train) if k],
                                       data.label[train], names, num_states=4, components=1,
                                       resample=16)
        for i in np.flatnonzero(~train):
            row = models.scores_of_features(samples[i])
            best = int(np.argmax(row))
            held.append((subject, best, row[best] / 15, best == names.index(data.label[i])))
    return held


def test_thresholds_are_the_quantile_of_held_out_subjects_scores(fitted):
    """reject_quantile=0: the lowest per-step score of a correctly classified
    sample of the class, scored by models trained without its subject."""
    data, samples, _ = fitted
    recogniser = replace(RECOGNISER, reject_quantile=0.0, reject_margin=0.25)
    thresholds, info = recogniser.calibrate(samples, data.label, data.class_names, data.subject)
    lowest = [np.inf] * 3
    for _, best, score, right in held_out_scores(data, samples):
        if right:
            lowest[best] = min(lowest[best], score)
    assert np.allclose(np.array(thresholds) + 0.25, lowest, rtol=1e-12)
    assert info["quantile"] == 0.0 and info["margin"] == 0.25


def test_chosen_margin_is_the_smallest_that_spares_every_held_out_subject(fitted):
    """reject_margin None: brute force over the margins with each subject's
    held-out scores and thresholds from the other subjects' (quantile 0: their
    lowest right score); the chosen margin is the first that refuses at most
    the budget of every subject, and the thresholds use it."""
    data, samples, _ = fitted
    held = held_out_scores(data, samples)
    for budget in (0.0, 0.2):
        worst_of = {}
        for margin in MARGIN_GRID:
            worst = 0.0
            for subject in range(3):
                lowest = [min([s for h, b, s, ok in held if h != subject and b == c and ok],
                              default=None) for c in range(3)]
                mine = [(b, s) for h, b, s, _ in held if h == subject]
                refused = sum(lowest[b] is not None and s < lowest[b] - margin for b, s in mine)
                worst = max(worst, refused / len(mine))
            worst_of[margin] = worst
        expected = next((m for m in MARGIN_GRID if worst_of[m] <= budget), MARGIN_GRID[-1])
        recogniser = replace(RECOGNISER, reject_quantile=0.0, reject_margin=None,
                             reject_budget=budget)
        thresholds, info = recogniser.calibrate(samples, data.label, data.class_names,
                                                data.subject)
        assert info["margin"] == expected and info["margin_chosen"]
        assert info["worst_group_refused"] == pytest.approx(worst_of[expected])
        lowest = [min(s for _, b, s, ok in held if b == c and ok) for c in range(3)]
        assert np.allclose(np.array(thresholds) + expected, lowest, rtol=1e-12)
    assert any(worst_of[m] > 0 for m in MARGIN_GRID)          # the margin has work to do


def test_held_out_gestures_are_accepted_and_a_random_walk_refused(fitted):
    data, _, models = fitted
    names = models.class_names
    # New people: most gestures accepted, every accepted one right.
    other = shapes_data(per_class=6, seed=11)
    decided, best = RECOGNISER.decisions(models, RECOGNISER.samples(other))
    truth = np.array([names.index(x) for x in other.label])
    assert (best == truth).all()
    accepted = decided >= 0
    assert accepted.mean() >= 0.8 and (decided[accepted] == truth[accepted]).all()
    # A clean drawing of each class is accepted.
    clean = {"right": [[0, 0], [200, 0]], "up": [[0, 0], [0, -200]],
             "corner": [[0, 0], [200, 0], [200, -200]]}
    for name, path in clean.items():
        x = stroke_features(np.array(path, float) + 300, models.resample)
        assert models.decide(models.scores_of_features(x)) == (names.index(name), None)
    # Random walks are not gestures; the reason names the best class.
    rng = np.random.default_rng(5)
    walks = [stroke_features(random_walk(rng), models.resample) for _ in range(5)]
    decided, best = RECOGNISER.decisions(models, walks)
    assert (decided == -1).all() and (best >= 0).all()
    for x in walks:
        scores = models.scores_of_features(x)
        index, reason = models.decide(scores)
        assert index == -1 and repr(names[int(np.argmax(scores))]) in reason


def test_without_rejection_every_gesture_gets_a_class(fitted):
    data, samples, _ = fitted
    recogniser = replace(RECOGNISER, reject=False)
    models = recogniser.fit(samples, data.label, data.class_names, groups=data.subject)
    assert models.thresholds is None and "rejection" not in models.meta
    walk = stroke_features(random_walk(np.random.default_rng(5)), 16)
    decided, best = recogniser.decisions(models, [walk, None])
    assert decided[0] == best[0] >= 0
    assert decided[1] == best[1] == -1                    # nothing to score


def test_calibration_needs_every_class_held_out():
    data = shapes_data(per_class=6)
    labels = data.label.copy()
    labels[(labels == "up") & (data.subject != 0)] = "right"       # "up": subject 0 only
    with pytest.raises(ValueError, match="'up'.*--no-reject"):
        RECOGNISER.calibrate(RECOGNISER.samples(data), labels, data.class_names, data.subject)


def test_fold_of_groups():
    labels = np.array(list("aaabbbbcc"))
    groups = np.array([5, 7, 9, 5, 7, 9, 11, 5, 7])
    fold = fold_of_groups(labels, groups, 3)
    for g in np.unique(groups):                          # whole subjects per fold
        assert len(set(fold[groups == g].tolist())) == 1
    assert set(fold.tolist()) == {0, 1, 2}
    assert fold_of_groups(labels, np.array([1, 2] * 4 + [1]), 3).max() == 1   # 2 subjects
    fold = fold_of_groups(labels, None, 3, seed=1)       # stratified deal
    assert sorted(np.bincount(fold).tolist()) == [3, 3, 3]
    for name in "ab":
        assert np.bincount(fold[labels == name]).max() - \
            np.bincount(fold[labels == name], minlength=3).min() <= 1


@pytest.mark.parametrize("options, word", [
    (dict(emission="poisson"), "emission"), (dict(resample=1), "resample"),
    (dict(reject_quantile=0.5), "reject_quantile"), (dict(reject_quantile=-0.1), "reject_quantile"),
    (dict(calibration_folds=1), "calibration_folds"),
])
def test_bad_recogniser_options(options, word):
    with pytest.raises(ValueError, match=word):
        Recogniser(**options)


def test_discrete_recogniser_with_rejection():
    data = shapes_data()
    recogniser = Recogniser(emission="discrete", resample=16, states=3)
    samples = recogniser.samples(data)
    assert all(s.dtype.kind == "i" for s in samples)
    models = recogniser.fit(samples, data.label, data.class_names, groups=data.subject)
    assert models.emission == "discrete" and len(models.thresholds) == 3
    decided, best = recogniser.decisions(models, samples)
    truth = np.array([data.class_names.index(x) for x in data.label])
    assert (best == truth).all()
    assert (decided[decided >= 0] == truth[decided >= 0]).all()


# ---- evaluation --------------------------------------------------------------------------
def test_grouped_cross_validation():
    data = shapes_data(per_class=6, subjects=3)
    outcome = grouped_cross_validation(RECOGNISER, data, data.subject)
    assert isinstance(outcome, CVOutcome) and outcome.fold.max() == 2
    assert outcome.accuracy_without_rejection == 1.0
    assert outcome.accuracy == 1.0 - outcome.rejection_rate
    confusion = outcome.confusion()
    assert confusion.shape == (3, 4) and confusion.sum() == len(data)
    assert confusion[:, 3].sum() == (outcome.decided < 0).sum()
    summary = outcome.summary()
    assert summary["samples"] == 18 and summary["folds"] == 3
    assert len(summary["fold_accuracy"]) == 3


def test_refused_right_counts_only_gestures_the_best_class_had_right():
    truth = np.array([0, 0, 1, 1, 2, 2])
    best = np.array([0, 1, 1, 1, 2, 0])
    decided = np.array([-1, -1, 1, -1, 2, 0])     # refused: right, wrong, right
    outcome = CVOutcome(("a", "b", "c"), truth, decided, best, np.zeros(6, np.int64))
    groups = ["s1", "s1", "s2", "s2", "s3", "s3"]
    assert outcome.refused_by(groups) == {"s1": 1.0, "s2": 0.5, "s3": 0.0}
    assert outcome.refused_right_by(groups) == {"s1": 0.5, "s2": 0.5, "s3": 0.0}


def test_open_set_rejection_refuses_the_held_out_class():
    names = ("corner", "right", "up")
    data = shapes_data(per_class=6, subjects=3, names=names)
    result = open_set_rejection(RECOGNISER, data, data.subject, held_classes=1)
    assert len(result["rotations"]) == 3
    assert result["samples_out"] == 18 and result["samples_in"] == 36
    # right / up are far from each other; the corner contains both, so rotations
    # holding out one line may accept a few as the corner: refuse most.
    assert result["refused_out"] >= 0.5 and result["accuracy_in"] >= 0.7
    assert 0.0 <= result["refused_in"] <= 0.3


def test_confusion_png(tmp_path):
    path = tmp_path / "c.png"
    confusion_png(np.array([[3, 0, 1], [1, 2, 0]]), ("a", "b"), path, title="t")
    assert path.read_bytes()[:8] == PNG
    assert sorted(p.name for p in tmp_path.iterdir()) == ["c.png"]
