"""recognition.datasets: the trajectory .npz layout, its validation and the vendored
$1 unistroke data."""
from pathlib import Path

import numpy as np
import pytest

from recognition.datasets import TrajectorySet, load_trajectories, save_trajectories

DOLLAR1 = (Path(__file__).resolve().parent.parent / "data" / "gestures" / "dollar1_unistroke"
           / "dollar1_unistroke.npz")


def small_set(with_subject=True):
    rng = np.random.default_rng(3)
    trajectories = [rng.uniform(0, 640, size=(n, 2)) for n in (5, 1, 12, 7)]
    return TrajectorySet.from_list(trajectories, ["up", "down", "up", "circle"],
                                   [4, 2, 4, 9] if with_subject else None)


def valid_arrays():
    """Plain arrays of a well-formed file (two trajectories of 3 and 2 points)."""
    return {"points": np.arange(10, dtype=np.float32).reshape(5, 2),
            "offsets": np.array([0, 3, 5], np.int64),
            "label": np.array(["a", "b"]),
            "subject": np.array([1, 2], np.int64)}


def write(path, arrays):
    np.savez(path, **arrays)
    return path


# ---------------------------------------------------------------- round trip


@pytest.mark.parametrize("with_subject", [True, False])
def test_save_load_round_trip(tmp_path, with_subject):
    data = small_set(with_subject)
    path = tmp_path / "set.npz"
    save_trajectories(data, path, note=np.array([1, 2, 3]))
    loaded = load_trajectories(path)
    assert len(loaded) == 4
    assert loaded.label.tolist() == ["up", "down", "up", "circle"]
    assert np.array_equal(loaded.offsets, data.offsets)
    # Points are stored as float32: equal to float32 precision.
    for i in range(len(data)):
        assert np.allclose(loaded.trajectory(i), data.trajectory(i), rtol=0, atol=1e-3)
    if with_subject:
        assert loaded.subject.tolist() == [4, 2, 4, 9]
    else:
        assert loaded.subject is None
    assert sorted(p.name for p in tmp_path.iterdir()) == ["set.npz"]   # no temporary left
    with np.load(path, allow_pickle=False) as raw:
        assert raw["note"].tolist() == [1, 2, 3]                        # extra keys kept


def test_subset_and_class_names():
    data = small_set()
    part = data.subset(data.label == "up")
    assert len(part) == 2 and part.subject.tolist() == [4, 4]
    assert np.array_equal(part.trajectory(1), data.trajectory(2))
    assert data.class_names == ("circle", "down", "up")


# ---------------------------------------------------------------- malformed files


def test_missing_key_is_named(tmp_path):
    arrays = valid_arrays()
    del arrays["offsets"]
    with pytest.raises(ValueError, match="offsets"):
        load_trajectories(write(tmp_path / "bad.npz", arrays))


@pytest.mark.parametrize("offsets", [[0, 3, 3, 5], [0, 4, 3], [1, 3, 5], [0, 3, 6]])
def test_offsets_must_rise_from_zero_to_the_point_count(tmp_path, offsets):
    arrays = valid_arrays()
    arrays["offsets"] = np.array(offsets, np.int64)
    if len(offsets) == 4:
        arrays["label"] = np.array(["a", "b", "c"])
        arrays["subject"] = np.array([1, 2, 3])
    with pytest.raises(ValueError, match="offsets"):
        load_trajectories(write(tmp_path / "bad.npz", arrays))


def test_label_length_mismatch_is_named(tmp_path):
    arrays = valid_arrays()
    arrays["label"] = np.array(["a", "b", "c"])
    with pytest.raises(ValueError, match="label"):
        load_trajectories(write(tmp_path / "bad.npz", arrays))


def test_subject_length_mismatch_is_named(tmp_path):
    arrays = valid_arrays()
    arrays["subject"] = np.array([1])
    with pytest.raises(ValueError, match="subject"):
        load_trajectories(write(tmp_path / "bad.npz", arrays))


@pytest.mark.parametrize("value", [np.nan, np.inf])
def test_non_finite_points_are_named(tmp_path, value):
    arrays = valid_arrays()
    arrays["points"][2, 1] = value
    with pytest.raises(ValueError, match="points"):
        load_trajectories(write(tmp_path / "bad.npz", arrays))


def test_pickled_object_array_is_refused(tmp_path):
    arrays = valid_arrays()
    arrays["label"] = np.array(["a", "b"], dtype=object)     # np.savez pickles it
    with pytest.raises(ValueError):
        load_trajectories(write(tmp_path / "bad.npz", arrays))


def test_pickled_object_array_error_names_the_key(tmp_path):
    arrays = valid_arrays()
    arrays["label"] = np.array(["a", "b"], dtype=object)
    with pytest.raises(ValueError, match="label"):
        load_trajectories(write(tmp_path / "bad.npz", arrays))


def test_not_an_npz_and_missing_file(tmp_path):
    junk = tmp_path / "junk.npz"
    junk.write_bytes(b"not a zip file")
    with pytest.raises(ValueError, match="npz"):
        load_trajectories(junk)
    with pytest.raises(FileNotFoundError):
        load_trajectories(tmp_path / "absent.npz")


# ---------------------------------------------------------------- vendored data


def test_vendored_dollar1_unistroke_loads():
    data = load_trajectories(DOLLAR1)
    assert len(data) == 3360
    assert len(data.class_names) == 16
    assert {"arrow", "circle", "pigtail", "star", "x"} <= set(data.class_names)
    assert sorted(set(data.subject.tolist())) == list(range(2, 9))
    counts = np.unique(data.label, return_counts=True)[1]
    assert (counts == 210).all()                   # 7 subjects x 3 speeds x 10 repetitions
    lengths = np.diff(data.offsets)
    assert lengths.min() == 25 and lengths.max() == 209
