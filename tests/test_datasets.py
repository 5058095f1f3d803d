"""recognition.datasets: the trajectory .npz layout, its validation (string or integer
labels, subject or writer), the vendored $1 unistroke and UCI pendigits data, and the
train/classify commands on an integer-labelled file."""
import hashlib
import json
import re
from pathlib import Path

import numpy as np
import pytest

from recognition.datasets import TrajectorySet, load_trajectories, save_trajectories
from tests.cli_helpers import assert_one_line_error, run

GESTURES = Path(__file__).resolve().parent.parent / "data" / "gestures"
DOLLAR1 = GESTURES / "dollar1_unistroke" / "dollar1_unistroke.npz"
PENDIGITS = GESTURES / "uci_pendigits" / "pendigits_orig.npz"


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


def test_vendored_uci_pendigits_loads():
    data = load_trajectories(PENDIGITS)
    assert len(data) == 7494
    assert data.class_names == tuple(str(d) for d in range(10))
    assert data.subject is not None                 # from the writer key
    assert sorted(set(data.subject.tolist())) == list(range(1, 31))
    counts = dict(zip(*np.unique(data.label, return_counts=True)))
    assert counts["0"] == 780 and counts["3"] == 719 and sum(counts.values()) == 7494
    with np.load(PENDIGITS, allow_pickle=False) as raw:
        assert "subject" not in raw.files
        assert np.array_equal(data.subject, raw["writer"])
        assert data.label.tolist() == [str(d) for d in raw["label"].tolist()]
    lengths = np.diff(data.offsets)
    assert lengths.min() == 9 and lengths.max() == 185


def test_vendored_uci_pendigits_matches_its_readme():
    readme = (PENDIGITS.parent / "README.md").read_text()
    digests = re.findall(r"`([0-9a-f]{64})`", readme)
    assert digests == [hashlib.sha256(PENDIGITS.read_bytes()).hexdigest()]
    assert f"{PENDIGITS.stat().st_size:,}" in readme


# ---------------------------------------------------------------- integer labels, writer


def integer_arrays(label=(2, 0, 1), class_names=("right", "up", "down-left")):
    """Three trajectories (2, 3 and 1 points) with integer labels into class_names."""
    arrays = {"points": np.arange(12, dtype=np.float32).reshape(6, 2),
              "offsets": np.array([0, 2, 5, 6], np.int64),
              "label": np.array(label, np.int8)}
    if class_names is not None:
        arrays["class_names"] = np.array(class_names)
    return arrays


@pytest.mark.parametrize("dtype", [np.int8, np.int16, np.int64, np.uint8, np.uint32])
def test_integer_labels_load_as_class_names(tmp_path, dtype):
    arrays = integer_arrays()
    arrays["label"] = arrays["label"].astype(dtype)
    data = load_trajectories(write(tmp_path / "int.npz", arrays))
    assert data.label.dtype.kind == "U"
    assert data.label.tolist() == ["down-left", "right", "up"]
    assert data.class_names == ("down-left", "right", "up")
    assert data.subject is None
    assert np.array_equal(data.trajectory(1), arrays["points"][2:5])
    # Saving writes the string labels; class_names may be given as an extra array.
    again = tmp_path / "again.npz"
    save_trajectories(data, again, class_names=arrays["class_names"])
    assert load_trajectories(again).label.tolist() == data.label.tolist()


def test_class_names_need_not_all_be_used(tmp_path):
    arrays = integer_arrays(label=(3, 3, 0), class_names=("a", "b", "c", "d"))
    data = load_trajectories(write(tmp_path / "int.npz", arrays))
    assert data.label.tolist() == ["d", "d", "a"] and data.class_names == ("a", "d")


def test_string_labels_leave_class_names_uninterpreted(tmp_path):
    arrays = valid_arrays()
    arrays["class_names"] = np.array(["x", "x"])      # would be refused with integer labels
    assert load_trajectories(write(tmp_path / "s.npz", arrays)).label.tolist() == ["a", "b"]


def _one_line_error(path, *words):
    with pytest.raises(ValueError) as info:
        load_trajectories(path)
    message = str(info.value)
    assert "\n" not in message and message.startswith(str(path))
    for word in words:
        assert word in message, (word, message)
    return message


@pytest.mark.parametrize("label, class_names, words", [
    ((0, 1, 2), None, ["label", "class_names is needed"]),
    ((0, 3, 1), ("a", "b", "c"), ["label", "0..2", "e.g. 3"]),
    ((0, -1, 1), ("a", "b", "c"), ["label", "0..2", "e.g. -1"]),
    ((0, 1, 0), ("a",), ["label", "0..0"]),
    ((0, 1, 0), ("a", "b", "a"), ["class_names", "unique", "'a'"]),
    ((0, 1, 0), (), ["class_names", "1-D"]),
    ((0, 1, 0), (("a", "b"), ("c", "d")), ["class_names", "1-D", "(2, 2)"]),
    ((0, 1, 0), (7, 8), ["class_names", "string"]),
])
def test_bad_integer_labels_or_class_names_are_named(tmp_path, label, class_names, words):
    arrays = integer_arrays(label, None)
    if class_names is not None:
        arrays["class_names"] = np.array(class_names)
    _one_line_error(write(tmp_path / "bad.npz", arrays), *words)


@pytest.mark.parametrize("label", [np.array([0.0, 1.0, 0.0]), np.array([True, False, True])])
def test_labels_neither_strings_nor_integers_are_named(tmp_path, label):
    arrays = integer_arrays()
    arrays["label"] = label
    _one_line_error(write(tmp_path / "bad.npz", arrays), "label", "strings", "integers")


def test_integer_label_count_must_match_the_trajectories(tmp_path):
    arrays = integer_arrays(label=(0, 1))
    _one_line_error(write(tmp_path / "bad.npz", arrays), "label", "(3,)", "(2,)")
    arrays = integer_arrays(label=((0, 1, 2),))
    _one_line_error(write(tmp_path / "bad.npz", arrays), "label", "1-D")


def test_writer_is_the_subject_when_there_is_no_subject(tmp_path):
    arrays = integer_arrays()
    arrays["writer"] = np.array([7, 3, 7], np.int16)
    data = load_trajectories(write(tmp_path / "w.npz", arrays))
    assert data.subject.tolist() == [7, 3, 7]
    arrays["subject"] = np.array([1, 2, 3])            # subject wins; writer is kept
    assert load_trajectories(write(tmp_path / "ws.npz", arrays)).subject.tolist() == [1, 2, 3]


@pytest.mark.parametrize("writer", [np.array([1, 2]), np.array([1.5, 2.0, 3.0])])
def test_bad_writer_is_named(tmp_path, writer):
    arrays = integer_arrays()
    arrays["writer"] = writer
    message = _one_line_error(write(tmp_path / "bad.npz", arrays), "writer", "subject")
    assert "(3,) integers" in message


# ---------------------------------------------------------------- the commands


def pen_digits(per_class=4, writers=2, seed=0):
    """Arrays of a small pendigits-like file: straight strokes of three directions with a
    wobble, integer labels into unsorted class_names, writer ids, a stroke key."""
    rng = np.random.default_rng(seed)
    directions = [(1.0, 0.0), (0.0, -1.0), (-0.7, 0.7)]
    parts, labels, writer = [], [], []
    for k, (dx, dy) in enumerate(directions):
        for i in range(per_class):
            u = np.sort(rng.random(int(rng.integers(20, 30))))
            wobble = 6 * np.sin(2 * np.pi * u * rng.uniform(1, 2)) + rng.normal(0, 1, u.size)
            parts.append(np.column_stack([300 + 200 * u * dx - wobble * dy,
                                          300 + 200 * u * dy + wobble * dx]))
            labels.append(k)
            writer.append(11 + i % writers)
    lengths = [len(p) for p in parts]
    return {"points": np.concatenate(parts).astype(np.float32),
            "offsets": np.concatenate([[0], np.cumsum(lengths)]).astype(np.int64),
            "label": np.array(labels, np.int8),
            "class_names": np.array(["right", "up", "down-left"]),
            "writer": np.array(writer, np.int16),
            "stroke": np.zeros(sum(lengths), np.int8)}


FAST = ["--emission", "discrete", "--resample", "24", "--tol", "1e-3", "--max-iter", "100",
        "--expected-length", "24", "--emission-floor", "1e-3"]


@pytest.mark.parametrize("groups", ["writer", "subject"])
def test_train_and_classify_an_integer_labelled_file(tmp_path, capsys, groups):
    data = write(tmp_path / "digits.npz", pen_digits())
    model = tmp_path / "model.json"
    status, out, err = run(capsys, "train", data, "-o", model, "--cv-states", "2",
                           "--groups", groups, "--jobs", "1", *FAST, "--quiet")
    assert status == 0, err
    summary = json.loads(out.strip().splitlines()[-1])
    assert summary["classes"] == ["down-left", "right", "up"] and summary["sequences"] == 12
    assert f"leave-one-{groups}-out (2 groups)" in out
    report = json.loads((tmp_path / "model-cv.json").read_text())
    assert report["scheme"] == "leave-one-group-out" and report["groups"] == [11, 12]

    status, out, err = run(capsys, "classify", model, data)
    assert status == 0 and err == ""
    result = json.loads(out)
    assert result["class_names"] == ["down-left", "right", "up"]
    assert result["samples"] == 12 and result["unknown_labels"] == []
    assert result["accuracy"] == 1.0
    assert result["confusion"] == [[4, 0, 0, 0], [0, 4, 0, 0], [0, 0, 4, 0]]  # last: "none"


@pytest.mark.parametrize("change, words", [
    ({"label": np.array([0, 1, 2, 5] * 3, np.int8)}, ["label", "0..2", "e.g. 5"]),
    ({"class_names": None}, ["label", "class_names is needed"]),
    ({"class_names": np.array(["a", "b", "a"])}, ["class_names", "unique"]),
])
def test_commands_report_bad_integer_labels_in_one_line(tmp_path, capsys, change, words):
    arrays = pen_digits()
    for key, value in change.items():
        if value is None:
            del arrays[key]
        else:
            arrays[key] = value
    data = write(tmp_path / "bad.npz", arrays)
    model = tmp_path / "model.json"
    status, _, err = run(capsys, "train", data, "-o", model, "--states", "2", *FAST)
    assert status == 2
    assert_one_line_error(err, "train", "bad.npz", *words)
    assert not model.exists()

    good = write(tmp_path / "good.npz", pen_digits())
    assert run(capsys, "train", good, "-o", model, "--states", "2", *FAST, "--quiet")[0] == 0
    status, out, err = run(capsys, "classify", model, data)
    assert status == 2 and out == ""
    assert_one_line_error(err, "classify", "bad.npz", *words)


# ---- stereogest dataset: one's own gestures -------------------------------------------

def _csv(path, points):
    path.write_text("x,y\n" + "".join(f"{x},{y}\n" for x, y in points))
    return path


def test_dataset_command_from_csv_files_and_a_manifest(tmp_path, capsys):
    from tests.cli_helpers import run
    a = _csv(tmp_path / "a.csv", [(1, 2), (3, 4), (5, 6)])
    b = _csv(tmp_path / "b.csv", [(10, 10), (20, 30)])
    (tmp_path / "more").mkdir()
    c = _csv(tmp_path / "more" / "c.csv", [(0, 0), (1, 1), (2, 2), (3, 3)])
    manifest = tmp_path / "more" / "list.csv"
    manifest.write_text("path,label,subject\nc.csv,zigzag,7\n../b.csv,circle,\n")
    out = tmp_path / "mine.npz"
    status, stdout, err = run(capsys, "dataset", a, manifest, "-o", out, "--label", "circle",
                              "--subject", "3", "--json")
    assert status == 0, err
    data = load_trajectories(out)
    assert data.label.tolist() == ["circle", "zigzag", "circle"]
    assert data.subject.tolist() == [3, 7, 3]
    assert np.allclose(data.trajectory(1), [(0, 0), (1, 1), (2, 2), (3, 3)])
    report = json.loads(stdout.strip().splitlines()[-1])
    assert report["classes"] == {"circle": 2, "zigzag": 1} and report["points"] == 9


def test_dataset_command_runs_clips_through_the_pipeline(tmp_path, capsys):
    from sim.clip import save_clip
    from sim.model.pipeline import PipelineParams, run_clip
    from sim.render import render_clip
    from tests.cli_helpers import run
    clip = render_clip("right", 3, 320, 240, n_pre_rest=1, n_motion=4, n_post_rest=0)
    folder = save_clip(clip, tmp_path / "right-3")
    out = tmp_path / "mine.npz"
    status, _, err = run(capsys, "dataset", folder, "-o", out, "--quiet")
    assert status == 0, err
    data = load_trajectories(out)
    trajectory, _ = run_clip(clip.left, clip.right, PipelineParams.for_frame(320))
    seen = trajectory.area > 0
    assert data.label.tolist() == ["right"] and seen.sum() >= 2
    assert np.array_equal(data.trajectory(0), trajectory.centroid[seen].astype(np.float32))


@pytest.mark.parametrize("case, words", [
    ("no_xy", ["a.csv", "x and y columns"]),
    ("bad_number", ["a.csv:3", "x and y must be numbers"]),
    ("no_label", ["a.csv", "no label", "--label"]),
    ("missing_row_path", ["list.csv:2", "does not exist"]),
    ("bad_subject", ["--subject", "0..65535"]),
    ("one_point", ["a.csv", "1 points", "at least 2"]),
    ("nothing", ["INPUT", "neither a clip folder nor a CSV file"]),
])
def test_dataset_command_refuses_bad_input_in_one_line(tmp_path, capsys, case, words):
    from tests.cli_helpers import assert_one_line_error, run
    a = tmp_path / "a.csv"
    a.write_text({"no_xy": "u,v\n1,2\n", "bad_number": "x,y\n1,2\nfoo,3\n",
                  "one_point": "x,y\n1,2\n"}.get(case, "x,y\n1,2\n3,4\n"))
    (tmp_path / "list.csv").write_text("path,label\nnowhere.csv,a\n")
    inputs = {"missing_row_path": [tmp_path / "list.csv"],
              "nothing": [tmp_path / "nothing"]}.get(case, [a])
    extra = [] if case == "no_label" else ["--label", "circle"]
    if case == "bad_subject":
        extra += ["--subject", "70000"]
    out = tmp_path / "out.npz"
    status, _, err = run(capsys, "dataset", *inputs, "-o", out, *extra)
    assert status == 2
    assert_one_line_error(err, "dataset", *words)
    assert not out.exists()
