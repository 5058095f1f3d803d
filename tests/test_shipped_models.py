"""The model files shipped with the board application (``make model``): the
default Gaussian one recognises the seven robot gestures of people it was not
trained on and refuses hands that move without making a gesture."""
from pathlib import Path

import numpy as np
import pytest

import sw_hps
from recognition.corpus import synthetic_corpus
from recognition.features import feature_sets, sequences
from recognition.non_gestures import (as_centroid_tracks, random_walks, scribbles,
                                      wandering_hands)
from recognition.recogniser import Recogniser
from stereogest.pipeline_outputs import shipped_model_path
from sw_hps.hmm import load_models
from sw_hps.telegram import GESTURE_NAMES

MODELS = Path(sw_hps.__file__).parent / "models"


@pytest.fixture(scope="module")
def default_models():
    return load_models(shipped_model_path())


@pytest.fixture(scope="module")
def other_people():
    # Seed 1 trained the shipped models; seed 4242 draws other people.
    return synthetic_corpus(per_class=12, people=3, seed=4242)


def test_default_model_is_gaussian_with_rejection(default_models):
    assert default_models.emission == "gaussian"
    assert sorted(default_models.class_names) == sorted(GESTURE_NAMES)
    assert default_models.thresholds is not None
    assert default_models.meta["front_end"] == "camera"


def test_default_model_recognises_other_people_through_the_camera_front_end(
        default_models, other_people):
    samples = feature_sets(other_people, default_models.resample, camera=True)
    decided, _ = Recogniser().decisions(default_models, samples)
    truth = [default_models.class_names.index(x) for x in other_people.label]
    assert (decided == truth).all(), np.flatnonzero(decided != truth)


@pytest.mark.parametrize("make, camera", [(wandering_hands, True), (random_walks, False),
                                          (scribbles, False)])
def test_default_model_refuses_non_gestures(default_models, make, camera):
    data = make(40, seed=11)
    if not camera:
        data = as_centroid_tracks(data)
    samples = feature_sets(data, default_models.resample, camera=True)
    decided, _ = Recogniser().decisions(default_models, samples)
    assert (decided < 0).mean() >= 0.95


def test_thesis_model_still_recognises_other_people(other_people):
    models = load_models(MODELS / "thesis7.json")
    assert models.emission == "discrete" and models.thresholds is None
    decided, _ = Recogniser(emission="discrete").decisions(models, sequences(other_people))
    truth = [models.class_names.index(x) for x in other_people.label]
    assert (decided == truth).all()
