"""Cross-validation (recognition.crossval): folds, determinism, leave-one-group-out,
the same result in process, on a process pool and on a Dask cluster, and the
report files."""
import json
from concurrent.futures import ThreadPoolExecutor

import numpy as np
import pytest
from PIL import Image

from recognition.crossval import cross_validate, fold_assignment, write_cv_report
from recognition.hmm_train import train_models

CLASSES = ("down", "right", "up")
PREFERRED = {"down": 6, "right": 0, "up": 2}


def toy_data(per_class=6, seed=0):
    """Symbol sequences of three classes: mostly one direction, some noise;
    subject = position within the class modulo 3."""
    rng = np.random.default_rng(seed)
    seqs, labels, subjects = [], [], []
    for name in CLASSES:
        for i in range(per_class):
            seq = np.full(int(rng.integers(15, 25)), PREFERRED[name])
            noise = rng.random(seq.size) < 0.3
            seq[noise] = rng.integers(0, 8, size=int(noise.sum()))
            seqs.append(seq)
            labels.append(name)
            subjects.append(i % 3)
    return seqs, labels, np.array(subjects)


OPTIONS = dict(tol=1e-3, max_iter=100, emission_floor=1e-3, expected_length=20)


# ------------------------------------------------------------ folds


def test_stratified_folds_are_deterministic_and_balanced():
    labels = ["a"] * 7 + ["b"] * 12 + ["c"] * 5
    first = fold_assignment(labels, folds=4, seed=3)
    assert np.array_equal(first, fold_assignment(labels, folds=4, seed=3))
    assert not np.array_equal(first, fold_assignment(labels, folds=4, seed=4))
    sizes = np.bincount(first, minlength=4)
    assert sizes.max() - sizes.min() <= 1 and sizes.sum() == 24
    for name, count in (("a", 7), ("b", 12), ("c", 5)):
        per_fold = np.bincount(first[np.array(labels) == name], minlength=4)
        assert per_fold.max() - per_fold.min() <= 1 and per_fold.sum() == count


def test_groups_give_one_fold_per_group():
    groups = np.array([5, 2, 5, 9, 2, 9])
    folds = fold_assignment(["a", "b"] * 3, groups=groups)
    assert list(folds) == [1, 0, 1, 2, 0, 2]


@pytest.mark.parametrize("kwargs, name", [
    (dict(folds=1), "folds"), (dict(folds=25), "folds"), (dict(folds=True), "folds"),
    (dict(seed=-1), "seed"), (dict(groups=[1] * 24), "groups"),
    (dict(groups=[1, 2]), "groups"),
])
def test_fold_assignment_validates(kwargs, name):
    with pytest.raises(ValueError, match=name):
        fold_assignment(["a", "b"] * 12, **kwargs)


# ------------------------------------------------------------ cross_validate


@pytest.fixture(scope="module")
def data():
    return toy_data()


@pytest.fixture(scope="module")
def serial(data):
    seqs, labels, _ = data
    calls = []
    result = cross_validate(seqs, labels, [1, 2, 3], folds=3, seed=1, jobs=1,
                            progress=lambda *args: calls.append(args), **OPTIONS)
    return result, calls


def test_result_is_consistent_with_direct_training(data, serial):
    seqs, labels, _ = data
    result, calls = serial
    assert result.state_counts == (1, 2, 3) and result.folds == 3
    assert result.class_names == CLASSES and result.scheme == "stratified"
    fold_of = fold_assignment(labels, folds=3, seed=1)
    assert np.array_equal(result.fold_of, fold_of)
    # Redo one job by hand.
    train = np.flatnonzero(fold_of != 2)
    models = train_models([seqs[i] for i in train], [labels[i] for i in train], CLASSES, 2,
                          **OPTIONS)
    test = np.flatnonzero(fold_of == 2)
    assert list(result.predictions[1, test]) == [models.classify(seqs[i]) for i in test]
    truth = np.array([CLASSES.index(x) for x in labels])
    for k in range(3):
        assert result.accuracy[k] == pytest.approx(np.mean(result.predictions[k] == truth))
        for f in range(3):
            mine = fold_of == f
            assert result.fold_accuracy[k, f] == pytest.approx(
                np.mean(result.predictions[k, mine] == truth[mine]))
    best = int(np.argmax(result.accuracy))
    assert result.best_states == result.state_counts[best]
    assert result.confusion.sum() + result.rejected.sum() == len(seqs)
    assert np.trace(result.confusion) == round(result.best_accuracy * len(seqs))
    assert result.best_accuracy > 0.8                     # the toy classes are easy
    # One progress call per job, counting up to the total.
    assert [c[0] for c in calls] == list(range(1, 10)) and {c[1] for c in calls} == {9}
    assert sorted((c[2], c[3]) for c in calls) == [(s, f) for s in (1, 2, 3) for f in range(3)]


def test_deterministic_and_executor_independent(data, serial):
    seqs, labels, _ = data
    result, _ = serial
    again = cross_validate(seqs, labels, [3, 1, 2], folds=3, seed=1, jobs=1, **OPTIONS)
    pooled = cross_validate(seqs, labels, [1, 2, 3], folds=3, seed=1, jobs=2, **OPTIONS)
    with ThreadPoolExecutor(2) as executor:
        threaded = cross_validate(seqs, labels, [1, 2, 3], folds=3, seed=1,
                                  executor=executor, **OPTIONS)
    for other in (again, pooled, threaded):
        assert np.array_equal(other.predictions, result.predictions)
        assert other.accuracy == result.accuracy
        assert np.array_equal(other.fold_accuracy, result.fold_accuracy)
        assert np.array_equal(other.confusion, result.confusion)


def test_dask_cluster_gives_the_same_result(data, serial):
    distributed = pytest.importorskip("distributed")
    seqs, labels, _ = data
    result, _ = serial
    with distributed.LocalCluster(n_workers=1, threads_per_worker=1, processes=True,
                                  host="127.0.0.1", dashboard_address=None) as cluster:
        done = []
        remote = cross_validate(seqs, labels, [1, 2, 3], folds=3, seed=1,
                                scheduler=cluster.scheduler_address,
                                progress=lambda *args: done.append(args[0]), **OPTIONS)
    assert np.array_equal(remote.predictions, result.predictions)
    assert remote.accuracy == result.accuracy
    assert sorted(done) == list(range(1, 10))


def test_leave_one_group_out(data):
    seqs, labels, subjects = data
    result = cross_validate(seqs, labels, [2], groups=subjects, jobs=1, **OPTIONS)
    assert result.scheme == "leave-one-group-out"
    assert result.groups == (0, 1, 2) and result.fold_sizes == (6, 6, 6)
    for f, subject in enumerate(result.groups):
        held = np.flatnonzero(subjects == subject)
        train = np.flatnonzero(subjects != subject)
        models = train_models([seqs[i] for i in train], [labels[i] for i in train],
                              CLASSES, 2, **OPTIONS)
        assert list(result.predictions[0, held]) == [models.classify(seqs[i]) for i in held]


def test_empty_held_out_sequence_is_rejected(data):
    seqs, labels, _ = data
    seqs = [*seqs[:-1], np.array([], dtype=np.int8)]
    result = cross_validate(seqs, labels, [2], folds=3, jobs=1, **OPTIONS)
    assert result.predictions[0, -1] == -1
    assert result.rejected[CLASSES.index(labels[-1])] >= 1
    assert result.confusion.sum() + result.rejected.sum() == len(seqs)


@pytest.mark.parametrize("kwargs, name", [
    (dict(state_counts=[]), "state_counts"), (dict(state_counts=[0, 2]), "state_counts"),
    (dict(state_counts=[65]), "state_counts"), (dict(state_counts=[2.5]), "state_counts"),
    (dict(folds=1), "folds"), (dict(jobs=0), "jobs"),
    (dict(class_names=("up", "down")), "class_names"),
])
def test_cross_validate_validates(data, kwargs, name):
    seqs, labels, _ = data
    args = dict(state_counts=[2], folds=3, jobs=1)
    args.update(kwargs)
    with pytest.raises(ValueError, match=name):
        cross_validate(seqs, labels, **args)


def test_a_class_needs_two_samples():
    seqs = [np.array([0, 1])] * 4
    with pytest.raises(ValueError, match="'b' has 1 sample"):
        cross_validate(seqs, ["a", "a", "a", "b"], [1], folds=2, jobs=1)


# ------------------------------------------------------------ report


def test_report_files(tmp_path, serial):
    result, _ = serial
    write_cv_report(result, tmp_path / "cv.json", tmp_path / "cv.png")
    assert sorted(p.name for p in tmp_path.iterdir()) == ["cv.json", "cv.png"]
    report = json.loads((tmp_path / "cv.json").read_text())
    assert report["state_counts"] == [1, 2, 3]
    assert report["accuracy"] == list(result.accuracy)
    assert report["fold_accuracy"] == result.fold_accuracy.tolist()
    assert report["best_states"] == result.best_states
    assert report["confusion"] == result.confusion.tolist()
    assert report["class_names"] == list(CLASSES) and report["samples"] == 18
    with Image.open(tmp_path / "cv.png") as img:
        assert img.format == "PNG" and img.size[0] >= 400
