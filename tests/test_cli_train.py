"""The train and classify subcommands, called in-process: a round trip on a tiny
synthetic dataset, cross-validation with its report, model meta, and one-line
errors (exit status 2); discrete models (FAST) and the default gaussian ones
with rejection (rejection rates, the confusion PNG)."""
import json

import numpy as np
import pytest

from recognition.recogniser import MARGIN_GRID
from recognition.datasets import TrajectorySet, save_trajectories
from recognition.features import sequences
from sw_hps.gaussian_hmm import GaussianGestureModels
from sw_hps.hmm import load_models
from tests.cli_helpers import assert_one_line_error, run

STROKES = {"right": (1.0, 0.0), "up": (0.0, -1.0), "down-left": (-0.7, 0.7)}


def strokes(per_class=6, seed=0, extra_label=None):
    """Pen strokes: straight lines of 3 directions with a wobble, uneven sampling;
    subject = index within the class modulo 3."""
    rng = np.random.default_rng(seed)
    trajs, labels, subjects = [], [], []
    names = list(STROKES) + ([extra_label] if extra_label else [])
    for name in names:
        dx, dy = STROKES.get(name, (0.0, 1.0))
        for i in range(per_class):
            u = np.sort(rng.random(int(rng.integers(20, 40))))
            wobble = 8 * np.sin(2 * np.pi * u * rng.uniform(1, 2)) + rng.normal(0, 1, u.size)
            x = 300 + 200 * u * dx - wobble * dy
            y = 300 + 200 * u * dy + wobble * dx
            trajs.append(np.column_stack([x, y]))
            labels.append(name)
            subjects.append(i % 3)
    return TrajectorySet.from_list(trajs, labels, subjects)


@pytest.fixture(scope="module")
def dataset(tmp_path_factory):
    path = tmp_path_factory.mktemp("data") / "strokes.npz"
    save_trajectories(strokes(), path)
    return path


FAST = ["--emission", "discrete", "--tol", "1e-3", "--max-iter", "200",
        "--expected-length", "30", "--emission-floor", "1e-3"]


def test_train_and_classify_round_trip(tmp_path, capsys, dataset):
    model = tmp_path / "model.json"
    status, out, err = run(capsys, "train", dataset, "-o", model, "--states", "3",
                           "--resample", "32", *FAST)
    assert status == 0, err
    summary = json.loads(out.strip().splitlines()[-1])
    assert summary["states"] == 3 and summary["sequences"] == 18 and summary["converged"]
    assert "training 3 models" in err                   # progress on stderr
    models = load_models(model)
    assert models.class_names == ("down-left", "right", "up")
    assert [m.num_states for m in models.models] == [3, 3, 3]
    meta = models.meta
    assert (meta["states"], meta["resample"], meta["emission_floor"], meta["tol"],
            meta["max_iter"], meta["expected_length"]) == (3, 32, 1e-3, 1e-3, 200, 30)
    assert meta["dataset"] == str(dataset) and "cv_accuracy" not in meta
    assert sorted(p.name for p in tmp_path.iterdir()) == ["model.json"]

    status, out, err = run(capsys, "classify", model, dataset)
    assert status == 0 and err == ""
    report = json.loads(out)
    assert report["resample"] == 32                     # from the model's meta
    assert report["samples"] == 18 and report["rejected"] == 0
    assert report["in_vocabulary"] == 18 and report["emission"] == "discrete"
    assert report["class_names"] == ["down-left", "right", "up"]
    assert report["accuracy"] == report["accuracy_without_rejection"] == 1.0
    assert report["rejection_rate_in"] == 0.0 and report["rejection_rate_out"] is None
    # Rows: true class; columns: decision, the last "none" (refused).
    assert report["confusion"] == [[6, 0, 0, 0], [0, 6, 0, 0], [0, 0, 6, 0]]
    # The same decisions as the library.
    seqs = sequences(strokes(), resample=32)
    assert all(models.class_names[models.classify(s)] == label
               for s, label in zip(seqs, strokes().label))


def test_classify_counts_unknown_labels_and_overrides_resample(tmp_path, capsys, dataset):
    model = tmp_path / "model.json"
    assert run(capsys, "train", dataset, "-o", model, "--states", "2", "--resample", "24",
               *FAST, "--quiet")[0] == 0
    other = tmp_path / "other.npz"
    save_trajectories(strokes(per_class=2, seed=5, extra_label="circle"), other)
    status, out, err = run(capsys, "classify", model, other, "--resample", "16")
    assert status == 0, err
    # said on stderr, the samples still classified
    assert err == (f"stereogest classify: warning: {other}: labels the model has no class "
                   f"for (circle): scored as out-of-vocabulary (rejection_rate_out), not in "
                   f"accuracy\n")
    report = json.loads(out)
    assert report["resample"] == 16 and report["samples"] == 8
    assert report["unknown_labels"] == ["circle"]
    # Unknown labels are not in the confusion matrix (rows: the model's classes);
    # accuracy is over the in-vocabulary samples, refused ones count as errors.
    assert report["in_vocabulary"] == 6
    assert sum(map(sum, report["confusion"])) == 6
    assert all(len(row) == 4 for row in report["confusion"])
    assert report["accuracy"] == report["correct"] / 6
    refused_in = sum(row[-1] for row in report["confusion"])
    assert report["rejection_rate_in"] == refused_in / 6
    refused_out = report["rejected"] - refused_in
    assert 0 <= refused_out <= 2 and report["rejection_rate_out"] == refused_out / 2


def test_train_with_cross_validation(tmp_path, capsys, dataset):
    model = tmp_path / "out" / "gestures.json"
    model.parent.mkdir()
    status, out, err = run(capsys, "train", dataset, "-o", model, "--cv-states", "1-3",
                           "--folds", "3", "--jobs", "1", "--seed", "4", "--resample", "32",
                           *FAST)
    assert status == 0, err
    assert "cv: 9/9 jobs" in err
    lines = out.strip().splitlines()
    assert "3-fold cross-validation" in lines[0]
    summary = json.loads(lines[-1])
    report_json = model.parent / "gestures-cv.json"
    assert summary["report"] == [str(report_json), str(model.parent / "gestures-cv.png")]
    report = json.loads(report_json.read_text())
    assert report["state_counts"] == [1, 2, 3] and report["folds"] == 3 and report["seed"] == 4
    best = report["best_states"]
    assert summary["states"] == summary["cv_best_states"] == best
    models = load_models(model)
    assert models.meta["states"] == best
    assert models.meta["cv_accuracy"] == report["best_accuracy"] == summary["cv_accuracy"]
    assert [m.num_states for m in models.models] == [best] * 3
    assert (model.parent / "gestures-cv.png").read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"


def test_train_leave_one_subject_out_with_report_prefix(tmp_path, capsys, dataset):
    model = tmp_path / "model.json"
    status, out, err = run(capsys, "train", dataset, "-o", model, "--cv-states", "2",
                           "--groups", "subject", "--jobs", "1", "--report", tmp_path / "logo",
                           "--resample", "32", *FAST, "--quiet",
                           "--commands", "up=forward,down-left=back")
    assert status == 0, err
    assert err == ""            # --quiet, and every class mapped to a robot command
    report = json.loads((tmp_path / "logo.json").read_text())
    assert report["scheme"] == "leave-one-group-out" and report["groups"] == [0, 1, 2]
    assert load_models(model).meta["cv"]["groups"] == "subject"


def camera_dataset(target, per_class=4):
    """Per-frame centroids with rest before and after, no subjects."""
    rng = np.random.default_rng(1)
    trajs, labels = [], []
    for name, (dx, dy) in STROKES.items():
        for _ in range(per_class):
            move = np.linspace(0, 1, int(rng.integers(30, 40)))[:, None] * [dx, dy] * 200
            path = np.concatenate([np.zeros((20, 2)), move, np.repeat(move[-1:], 25, 0)])
            trajs.append(path + 300 + rng.normal(0, 0.5, path.shape))
            labels.append(name)
    save_trajectories(TrajectorySet.from_list(trajs, labels), target)
    return target


def test_train_camera_front_end(tmp_path, capsys):
    """Per-frame centroids with rest before and after: the FPGA's feature chain."""
    data = camera_dataset(tmp_path / "camera.npz")
    model = tmp_path / "model.json"
    status, out, err = run(capsys, "train", data, "-o", model, "--states", "2", *FAST)
    assert status == 0, err
    assert load_models(model).meta["resample"] is None
    status, out, _ = run(capsys, "classify", model, data)
    report = json.loads(out)
    assert report["resample"] is None and report["accuracy"] == 1.0


def test_train_gaussian_camera_front_end(tmp_path, capsys):
    """Gaussian features of the camera points; rejection calibrated on stratified
    folds (no subjects)."""
    data = camera_dataset(tmp_path / "camera.npz", per_class=6)
    model = tmp_path / "model.json"
    status, out, err = run(capsys, "train", data, "-o", model, "--states", "4",
                           "--components", "1", "--quiet")
    assert status == 0, err
    summary = json.loads(out)
    assert summary["rejection"]["grouped"] is False and summary["rejection"]["folds"] == 3
    assert summary["rejection"]["margin"] == 1.5 and not summary["rejection"]["margin_chosen"]
    models = load_models(model)
    assert models.meta["resample"] is None and models.meta["front_end"] == "camera"
    assert models.resample == 64                      # the default feature resampling
    status, out, _ = run(capsys, "classify", model, data)
    report = json.loads(out)
    assert report["resample"] is None and report["emission"] == "gaussian"
    assert report["accuracy_without_rejection"] == 1.0 and report["accuracy"] >= 17 / 18


@pytest.mark.parametrize("argv, words", [
    (["--states", "0"], ["--states"]),
    (["--states", "65"], ["--states"]),
    (["--states", "40"], ["--states", "--expected-length"]),
    (["--cv-states", "5-2"], ["--cv-states", "5-2"]),
    (["--cv-states", "0-3"], ["--cv-states"]),
    (["--cv-states", "a"], ["--cv-states"]),
    (["--cv-states", "2-3", "--folds", "1"], ["--folds"]),
    (["--cv-states", "2-3", "--states", "3"], ["--states", "--cv-states"]),
    (["--folds", "3"], ["--folds", "--cv-states"]),
    (["--cv-states", "2", "--groups", "person"], ["--groups", "person"]),
    (["--cv-states", "2", "--jobs", "0"], ["--jobs"]),
    (["--emission-floor", "0.5"], ["--emission-floor"]),
    (["--tol", "-1"], ["--tol"]),
    (["--max-iter", "0"], ["--max-iter"]),
    (["--resample", "1"], ["--resample"]),
    (["--commands", "up=fly"], ["--commands", "'up' maps to 'fly'", "rotate-right"]),
    (["--commands", "zigzag=stop"], ["--commands", "'zigzag' is not a class", "down-left"]),
    (["--commands", "up"], ["--commands", "'up' is not CLASS=COMMAND"]),
])
def test_train_errors_name_the_option(tmp_path, capsys, dataset, argv, words):
    model = tmp_path / "model.json"
    status, out, err = run(capsys, "train", dataset, "-o", model, "--emission", "discrete",
                           "--expected-length", "30", *argv)
    assert status == 2
    assert_one_line_error(err, "train", *words)
    assert not model.exists()


def test_file_errors(tmp_path, capsys, dataset):
    model = tmp_path / "model.json"
    status, _, err = run(capsys, "train", tmp_path / "missing.npz", "-o", model)
    assert status == 2
    assert_one_line_error(err, "train", "missing.npz")
    garbage = tmp_path / "garbage.npz"
    garbage.write_bytes(b"not a zip file")
    status, _, err = run(capsys, "train", garbage, "-o", model)
    assert status == 2
    assert_one_line_error(err, "train", "garbage.npz")
    assert not model.exists()

    status, _, err = run(capsys, "classify", tmp_path / "none.json", dataset)
    assert status == 2
    assert_one_line_error(err, "classify", "none.json")
    bad = tmp_path / "bad.json"
    bad.write_text('{"format": "stereogest-hmm", "version": 1, "class_names": ["a"], '
                   '"models": [{"pi": [1], "A": [[0.5]], "B": [[1]]}]}')
    status, _, err = run(capsys, "classify", bad, dataset)
    assert status == 2
    assert_one_line_error(err, "classify", "bad.json", "A rows")
    bad.write_text("{")
    assert run(capsys, "classify", bad, dataset)[0] == 2
    assert run(capsys, "train", dataset, "-o", model, "--states", "2", "--resample", "32",
               *FAST, "--quiet")[0] == 0
    status, _, err = run(capsys, "classify", model, garbage)
    assert status == 2
    assert_one_line_error(err, "classify", "garbage.npz")
    status, _, err = run(capsys, "classify", model, dataset, "--resample", "x")
    assert status == 2
    assert_one_line_error(err, "classify", "--resample")


# ---------------------------------------------------------------- gaussian models (default)
PNG_SIGNATURE = b"\x89PNG\r\n\x1a\n"
GAUSSIAN = ["--resample", "16", "--states", "4", "--components", "1"]


@pytest.fixture(scope="module")
def gaussian_model(tmp_path_factory, dataset):
    """Trained with the default emission (gaussian) and rejection."""
    from stereogest import cli
    model = tmp_path_factory.mktemp("gauss") / "model.json"
    assert cli.main(["train", str(dataset), "-o", str(model), *GAUSSIAN, "--quiet"]) == 0
    return model


def test_train_gaussian_is_the_default_and_calibrates_rejection(tmp_path, capsys, dataset):
    model = tmp_path / "model.json"
    status, out, err = run(capsys, "train", dataset, "-o", model, *GAUSSIAN)
    assert status == 0, err
    summary = json.loads(out.strip().splitlines()[-1])
    assert summary["emission"] == "gaussian" and summary["states"] == 4
    assert summary["components"] == {"down-left": 1, "right": 1, "up": 1}
    assert summary["rejection"]["folds"] == 3 and summary["rejection"]["grouped"]
    assert "calibrating rejection: fold 3 of 3" in err
    models = load_models(model)
    assert isinstance(models, GaussianGestureModels) and models.resample == 16
    assert len(models.thresholds) == 3 and models.meta["resample"] == 16
    assert sorted(p.name for p in tmp_path.iterdir()) == ["model.json"]


def test_classify_gaussian_counts_refused_unknown_labels(tmp_path, capsys, gaussian_model):
    other = tmp_path / "other.npz"
    save_trajectories(strokes(per_class=2, seed=5, extra_label="circle"), other)  # circle: down
    png = tmp_path / "confusion.png"
    status, out, err = run(capsys, "classify", gaussian_model, other, "--plot", png)
    assert status == 0 and err.startswith("stereogest classify: warning: ")
    assert err.count("\n") == 1 and "(circle)" in err
    report = json.loads(out)
    assert report["emission"] == "gaussian" and report["samples"] == 8
    assert report["in_vocabulary"] == 6 and report["unknown_labels"] == ["circle"]
    # The model refuses the strokes of the direction it never saw.
    refused_in = sum(row[-1] for row in report["confusion"])
    refused_out = report["rejected"] - refused_in
    assert refused_out == 2 and report["rejection_rate_out"] == 1.0
    assert report["rejection_rate_in"] == refused_in / 6
    assert report["accuracy"] == report["correct"] / 6 == 1.0
    assert report["accuracy_without_rejection"] == 1.0
    assert report["confusion"] == [[2, 0, 0, 0], [0, 2, 0, 0], [0, 0, 2, 0]]
    assert report["confusion_png"] == str(png)
    assert png.read_bytes()[:8] == PNG_SIGNATURE
    assert sorted(p.name for p in tmp_path.iterdir()) == ["confusion.png", "other.npz"]


def test_classify_gaussian_without_unknown_labels(capsys, dataset, gaussian_model):
    status, out, err = run(capsys, "classify", gaussian_model, dataset)
    assert status == 0 and err == ""
    report = json.loads(out)
    assert report["rejection_rate_out"] is None and report["unknown_labels"] == []
    assert report["in_vocabulary"] == report["samples"] == 18
    assert report["rejected"] == sum(row[-1] for row in report["confusion"])
    assert report["accuracy"] == report["correct"] / 18 >= 17 / 18
    assert "confusion_png" not in report


def test_classify_refuses_data_of_another_vocabulary(tmp_path, capsys, gaussian_model):
    """No label of the data is a class of the model (a pen corpus against the
    gesture model, names spelt differently): the accuracy would mean nothing, so
    one line naming the labels and the classes (exit 2), no report, no PNG."""
    data = strokes(per_class=2)
    foreign = tmp_path / "foreign.npz"
    save_trajectories(TrajectorySet(data.points, data.offsets,
                                    np.char.add("pen-", data.label.astype(str))), foreign)
    png = tmp_path / "confusion.png"
    status, out, err = run(capsys, "classify", gaussian_model, foreign, "--plot", png)
    assert status == 2 and out == ""
    assert_one_line_error(err, "classify", f"{foreign}: none of its labels (pen-down-left, "
                          f"pen-right, pen-up) is a class of {gaussian_model} (down-left, "
                          f"right, up)")
    assert sorted(p.name for p in tmp_path.iterdir()) == ["foreign.npz"]


def test_classify_refuses_a_model_the_board_application_refuses(tmp_path, capsys, dataset):
    """A valid discrete HMM file of 9 symbols, which the board application
    refuses (sw_hps.app.check_models): classify refuses it too, one line, exit 2."""
    from pathlib import Path
    thesis = json.loads((Path(__file__).resolve().parent.parent / "sw_hps" / "models"
                         / "thesis7.json").read_text())
    thesis["num_symbols"] = 9
    for m in thesis["models"]:
        m["B"] = [[p * 0.9 for p in row] + [0.1] for row in m["B"]]
    model = tmp_path / "nine.json"
    model.write_text(json.dumps(thesis))
    load_models(model)                       # a well-formed model file ...
    status, out, err = run(capsys, "classify", model, dataset)
    assert status == 2 and out == ""         # ... that the board would not run
    assert_one_line_error(err, "classify", f"{model}: models must use the 8 orientation "
                          "symbols, got num_symbols=9")


def test_classify_confusion_png_must_be_a_png(tmp_path, capsys, dataset, gaussian_model):
    status, out, err = run(capsys, "classify", gaussian_model, dataset,
                           "--plot", tmp_path / "name.txt")
    assert status == 2 and out == ""
    assert_one_line_error(err, "classify", "--plot", "name.txt")
    assert list(tmp_path.iterdir()) == []


def test_train_without_rejection_when_calibration_cannot_work(tmp_path, capsys):
    """A class drawn by one subject only has no held-out sample: a one-line
    error pointing at --no-reject; with it, a model without thresholds."""
    data = strokes(per_class=6)
    subject = np.where(data.label == "up", 0, data.subject)
    path = tmp_path / "one-subject.npz"
    save_trajectories(TrajectorySet(data.points, data.offsets, data.label, subject), path)
    model = tmp_path / "model.json"
    status, out, err = run(capsys, "train", path, "-o", model, *GAUSSIAN, "--quiet")
    assert status == 2
    assert_one_line_error(err, "train", "'up'", "--no-reject")
    assert not model.exists()
    status, out, err = run(capsys, "train", path, "-o", model, *GAUSSIAN, "--no-reject",
                           "--quiet")
    assert status == 0, err
    assert load_models(model).thresholds is None
    assert json.loads(out)["rejection"] is None
    # one person's recordings: said so, and the same way out
    one = tmp_path / "one-person.npz"
    save_trajectories(TrajectorySet(data.points, data.offsets, data.label,
                                    np.zeros_like(data.subject)), one)
    model.unlink()
    status, out, err = run(capsys, "train", one, "-o", model, *GAUSSIAN, "--quiet")
    assert status == 2
    assert_one_line_error(err, "train", "one subject", "--no-reject")
    assert not model.exists()


@pytest.mark.parametrize("argv, words", [
    (["--cv-states", "2-3"], ["--cv-states", "--emission discrete"]),
    (["--folds", "3"], ["--folds", "--emission discrete"]),
    (["--groups", "subject"], ["--groups"]),
    (["--emission", "discrete", "--components", "2"], ["--components", "gaussian"]),
    (["--components", "0"], ["--components", "1..16"]),
    (["--components", "17"], ["--components", "1..16"]),
    (["--resample", "2"], ["--resample", ">= 3"]),
    (["--resample", "16", "--states", "16"], ["--states", "1..15"]),
    (["--states", "0"], ["--states"]),
    (["--reject-quantile", "0.5"], ["--reject-quantile"]),
    (["--reject-quantile", "-0.1"], ["--reject-quantile"]),
    (["--calibration-folds", "1"], ["--calibration-folds"]),
    (["--emission", "discrete", "--calibration-folds", "1"], ["--calibration-folds"]),
])
def test_gaussian_train_errors_name_the_option(tmp_path, capsys, dataset, argv, words):
    model = tmp_path / "model.json"
    status, out, err = run(capsys, "train", dataset, "-o", model, *argv)
    assert status == 2
    assert_one_line_error(err, "train", *words)
    assert not model.exists()


def test_train_chooses_the_margin_with_reject_margin_auto(tmp_path, capsys, dataset):
    """--reject-margin auto: the margin is one of the grid, chosen for the budget,
    and the thresholds are the fixed-margin ones moved by the difference."""
    fixed, auto = tmp_path / "fixed.json", tmp_path / "auto.json"
    status, _, err = run(capsys, "train", dataset, "-o", fixed, *GAUSSIAN, "--reject-margin", "0")
    assert status == 0, err
    status, out, err = run(capsys, "train", dataset, "-o", auto, *GAUSSIAN,
                           "--reject-margin", "auto", "--reject-budget", "0.01")
    assert status == 0, err
    rejection = json.loads(out.strip().splitlines()[-1])["rejection"]
    assert rejection["margin_chosen"] and rejection["budget"] == 0.01
    assert rejection["margin"] in MARGIN_GRID and 0 <= rejection["worst_group_refused"] <= 1
    shift = np.array(load_models(fixed).thresholds) - np.array(load_models(auto).thresholds)
    assert np.allclose(shift, rejection["margin"])


def test_train_maps_classes_to_robot_commands(tmp_path, capsys, dataset):
    """Classes named otherwise than the robot's commands: train warns, and
    --commands maps them into the model file, where the board reads them."""
    plain, mapped = tmp_path / "plain.json", tmp_path / "mapped.json"
    status, _, err = run(capsys, "train", dataset, "-o", plain, *GAUSSIAN, "--quiet")
    assert status == 0
    assert "warning: 'down-left', 'up' map to no robot command" in err
    assert load_models(plain).commands is None
    status, _, err = run(capsys, "train", dataset, "-o", mapped, *GAUSSIAN, "--quiet",
                         "--commands", "up=forward, down-left=back")
    assert status == 0 and "warning" not in err, err
    models = load_models(mapped)
    assert models.commands == {"up": "forward", "down-left": "back"}
    assert [models.command_of(n) for n in models.class_names] == ["back", "right", "forward"]
    assert json.loads(mapped.read_text())["version"] == 6
