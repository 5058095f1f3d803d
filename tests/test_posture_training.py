"""Training the posture classifier (recognition/posture.py): the board's numpy
machine decides as scikit-learn's SVC it was exported from (an oracle we did
not write); train-posture and classify-posture on real photos
(data/hand_postures) with students held out."""
from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest

from recognition import posture as rp
from stereogest.cli import main
from sw_hps.posture import PostureModel, read_posture_model

DATA = Path(__file__).resolve().parent.parent / "data" / "hand_postures" / \
    "sign_language_digits_dev.npz"


@pytest.fixture(scope="module")
def photos():
    data = rp.load_postures(DATA)
    assert len(data) == 1122 and len(np.unique(data.subject)) == 111
    masks = rp.picture_masks(data)
    return data, masks, rp.still_features(masks)


@pytest.fixture(scope="module")
def small(tmp_path_factory, photos):
    """The pictures of 30 students as a DATA.npz."""
    data = photos[0]
    keep = data.subject < 30
    path = tmp_path_factory.mktemp("postures") / "small.npz"
    np.savez(path, image=data.image[keep], label=data.label[keep],
             subject=data.subject[keep])
    return path, keep


def test_numpy_machine_decides_as_sklearn(photos):
    """The exported machine against the library that trained it (an oracle
    we did not write), on pictures of students it was not trained on."""
    from sklearn.svm import SVC
    data, _, x = photos
    train, test = data.subject >= 20, data.subject < 20
    model = rp.train_posture(x[train], data.label[train], data.class_names, c=10.0)
    svm = SVC(C=10.0, gamma=model.gamma).fit((x[train] - model.mean) / model.scale,
                                              data.label[train])
    expected = svm.predict((x[test] - model.mean) / model.scale)
    assert np.array_equal(model.decide(x[test]), expected)
    # students held out (the first 20, the hardest: 81 % measured), no
    # augmentation; chance is 10 %
    assert np.mean(expected == data.label[test]) > 0.7
    # two classes: scikit-learn flips its signs there, the export undoes it
    pair = train & (data.label <= 1)
    two = rp.train_posture(x[pair], data.label[pair], data.class_names[:2], c=10.0)
    svm2 = SVC(C=10.0, gamma=two.gamma).fit((x[pair] - two.mean) / two.scale, data.label[pair])
    held = test & (data.label <= 1)
    assert np.array_equal(two.decide(x[held]),
                          svm2.predict((x[held] - two.mean) / two.scale))
    assert np.mean(two.decide(x[held]) == data.label[held]) > 0.9
    # round trip through the model file
    again = PostureModel.from_dict(json.loads(json.dumps(model.to_dict())))
    assert np.array_equal(again.decide(x[test]), model.decide(x[test]))
    assert model.classify(x[test][0]) == data.class_names[expected[0]]


def test_refusal_by_votes(photos):
    data, _, x = photos
    model = rp.train_posture(x[:300], data.label[:300], data.class_names, c=10.0)
    model.min_votes = 9
    decided = model.decide(x[300:400])
    assert (decided == -1).any() and (decided >= 0).any()
    assert model.classify(x[300:301]) in data.class_names + [None]


def test_augmented_copies_keep_the_labels_shape(photos):
    _, masks, _ = photos
    copies = rp.augment_masks(masks[:10], 3, seed=4)
    assert copies.shape == (30,) + masks.shape[1:] and copies.dtype == bool
    assert not np.array_equal(copies[:10], masks[:10])
    # a longer forearm reaches the bottom edge and keeps the hand's top
    long_arm = rp._forearm(masks[0], 0.6)
    assert long_arm[-1].any()
    assert np.nonzero(long_arm.any(axis=1))[0][0] == np.nonzero(masks[0].any(axis=1))[0][0]


def test_train_and_classify_commands(tmp_path, small, capsys):
    path, keep = small
    out = tmp_path / "posture.json"
    assert main(["train-posture", str(path), "-o", str(out), "--groups", "subject",
                 "--copies", "1"]) == 0
    summary = json.loads(capsys.readouterr().out.strip().splitlines()[-1])
    assert summary["pictures"] == int(keep.sum()) and summary["c"] in rp.C_CHOICES
    model = read_posture_model(out)
    assert model.meta["picture_sizes"] == [[100, 100]] and model.meta["copies"] == 1
    # the other students' pictures
    data = rp.load_postures(DATA)
    others = tmp_path / "others.npz"
    held = data.subject >= 100
    np.savez(others, image=data.image[held], label=data.label[held])
    assert main(["classify-posture", str(out), str(others), "--json"]) == 0
    report = json.loads(capsys.readouterr().out.strip().splitlines()[-1])
    assert report["pictures"] == int(held.sum())
    assert report["accuracy"] > 0.8
    confusion = np.array(report["confusion"])
    assert confusion.shape == (10, 11) and confusion.sum() == held.sum()
    assert report["accuracy"] == pytest.approx(np.trace(confusion) / confusion.sum())
    assert set(report["per_class"]) == set(rp.ASL_NAMES)




def test_rendered_postures_through_the_pipeline_and_joined_training(tmp_path, small, capsys):
    """`stereogest postures` writes pictures, the pipeline's masks, labels and
    people; train-posture joins it with the photos by class name (fist is the
    rendered file's own) and classify-posture takes either size."""
    rendered = tmp_path / "rendered.npz"
    assert main(["postures", "-o", str(rendered), "--people", "2", "--seed", "40",
                 "--postures", "fist,open,asl1", "--width", "320", "--height", "240",
                 "--quiet", "--json"]) == 0
    report = json.loads(capsys.readouterr().out.strip().splitlines()[-1])
    assert report["pictures"] == 6 and report["postures"] == ["fist", "asl5", "asl1"]
    data = rp.load_postures(rendered)
    assert data.class_names == ["fist", "asl5", "asl1"]
    assert data.subject.tolist() == [40, 40, 40, 41, 41, 41]
    assert data.image.shape == (6, 96, 96, 3) and data.mask.shape == (6, 96, 96)
    # the mask is the pipeline's (skin AND band), not the picture path's
    assert np.array_equal(rp.picture_masks(data), data.mask) and data.mask.any(axis=(1, 2)).all()
    areas = data.mask.sum(axis=(1, 2))
    assert areas[1] > areas[0] and areas[4] > areas[3]     # the open hand outgrows the fist
    # the features are the pipeline's third presentation's record, decoded as the board does
    from recognition.posture_renders import posture_still, present_still
    from sw_hps.posture import decode_posture_words, record_features
    person, params = posture_still("asl1", 41, width=320, height=240)
    still = present_still(*person.stereo_frame(0), params)
    assert np.array_equal(data.features[5],
                          record_features(decode_posture_words(still.posture_words())))
    assert np.array_equal(rp.picture_features(data), data.features)
    path, _ = small
    out = tmp_path / "joined.json"
    assert main(["train-posture", str(path), str(rendered), "-o", str(out), "--groups",
                 "subject", "--copies", "0"]) == 0
    summary = json.loads(capsys.readouterr().out.strip().splitlines()[-1])
    model = read_posture_model(out)
    assert model.class_names == list(rp.ASL_NAMES) + ["fist"]
    assert model.meta["picture_sizes"] == [[100, 100], [96, 96]]
    assert summary["pictures"] == len(rp.load_postures(path)) + 6
    assert main(["classify-posture", str(out), str(rendered), "--json"]) == 0
    report = json.loads(capsys.readouterr().out.strip().splitlines()[-1])
    assert report["pictures"] == 6 and report["accuracy"] == 1.0    # its training pictures


def test_the_rendered_benchmark_names_the_people_make_model_trains_on():
    """benchmarks/rendered_posture_accuracy.py's TRAINING_PEOPLE are the seeds
    of the Makefile's `stereogest postures` lines, per scene."""
    import re
    import sys
    from pathlib import Path
    root = Path(__file__).resolve().parents[1]
    sys.path.insert(0, str(root / "benchmarks"))
    try:
        from rendered_posture_accuracy import TRAINING_PEOPLE
    finally:
        sys.path.remove(str(root / "benchmarks"))
    text = (root / "Makefile").read_text().replace("\\\n", " ")
    made = {}
    for line in text.splitlines():
        if "stereogest postures" in line:
            people = int(re.search(r"--people (\d+)", line).group(1))
            seed = int(re.search(r"--seed (\d+)", line).group(1))
            scene = re.search(r"--scene (\w+)", line)
            made[scene.group(1) if scene else "easy"] = range(seed, seed + people)
    assert made == TRAINING_PEOPLE
