"""The board's posture classifier (sw_hps/posture.py), with the board's own
packages only (tests/test_hps_floor.py runs it on Python 3.7 and numpy 1.16):
the features of the descriptor's registers, a hand-made machine's decisions,
and the model file's checks (one line naming the file and the field)."""
from __future__ import annotations

import json

import numpy as np
import pytest

from soc.hps_interface import POSTURE_WORD_COUNT
from sw_hps.posture import (POSTURE_OFFSET, PostureModel, PostureReader, posture_features,
                            read_posture_model)


def test_features_of_the_registers():
    polar = [0, 4, 8, 0]
    features = posture_features(polar, band_sum=[6, 0], band_rows=[3, 0], band_max=[4, 0],
                                width=2)
    assert features.tolist() == [0, 1, 2, 0, 2, 4, 0, 0]
    assert not posture_features(polar, [6, 0], [3, 0], [4, 0], width=0).any()


def _bad_model(tmp_path, change):
    data = {"format": "stereogest-posture", "version": 1, "class_names": ["a", "b"],
            "features": 2, "mean": [0, 0], "scale": [1, 1], "gamma": 0.5,
            "n_support": [1, 1], "dual_coef": [[1.0, -1.0]], "intercept": [0.0],
            "support_vectors": {"shape": [2, 2], "float32_base64": "AACAPwAAAAAAAAAAAACAPw=="}}
    change(data)
    path = tmp_path / "bad.json"
    path.write_text(json.dumps(data))
    return path


@pytest.mark.parametrize("change, message", [
    (lambda d: None, None),
    (lambda d: d.update(format="stereogest-hmm"), "format must be 'stereogest-posture'"),
    (lambda d: d.update(version=2), "version must be 1"),
    (lambda d: d.update(scale=[1, 0]), "scale must be > 0"),
    (lambda d: d.update(n_support=[1, 2]), "support_vectors must hold shape"),
    (lambda d: d["support_vectors"].update(float32_base64="!!"), "is not base64"),
    (lambda d: d.update(mean=[0]), r"mean must be finite numbers of shape \(2,\)"),
    (lambda d: d.update(min_votes=3), r"min_votes must be an integer in \[0, 1\]"),
    (lambda d: d.update(gamma="x"), r"gamma must be a number"),
    (lambda d: d.update(class_names=[[1], [2]]), "class_names must be at least 2 unique"),
    (lambda d: d.update(n_support=[10 ** 20, 1]), r"n_support must be 2 integers"),
    (lambda d: d.update(mean=[10 ** 400, 0]), "mean must be numbers"),
    (lambda d: d.update(mean=["1", 0]), "mean must be numbers"),
    (lambda d: d.update(dual_coef="x"), "dual_coef must be numbers"),
    (lambda d: d.update(meta={"picture_sizes": 16}), "meta picture_sizes must be"),
    (lambda d: d.update(meta={"picture_sizes": [[16]]}), "meta picture_sizes must be"),
])
def test_model_file_checks(tmp_path, change, message):
    path = _bad_model(tmp_path, change)
    if message is None:
        model = read_posture_model(path)
        assert model.classify([1.0, 0.0]) == "a" and model.classify([0.0, 1.0]) == "b"
        assert PostureModel.from_dict(model.to_dict()).classify([0.9, 0.2]) == "a"
        with pytest.raises(ValueError, match=r"rows of 2 numbers, got shape \(1, 3\)"):
            model.decide([1.0, 0.0, 0.0])
        return
    with pytest.raises(ValueError, match=message) as info:
        read_posture_model(path)
    assert str(info.value).startswith(f"{path}: ") and "\n" not in str(info.value)


# ---------------------------------------------------------------- the posture slave


def _bus_with_slave():
    from sw_hps.bus import SimBus
    from sw_hps.simulated import SimulatedPostureSlave
    slave = SimulatedPostureSlave()
    bus = SimBus()
    bus.attach(POSTURE_OFFSET, slave)
    return bus, slave


def _record(seed):
    rng = np.random.RandomState(seed)
    return [int(v) for v in rng.randint(0, 2 ** 31, POSTURE_WORD_COUNT)]


def test_reader_takes_each_record_once_and_checks_the_layout():
    bus, slave = _bus_with_slave()
    reader = PostureReader(bus)
    assert reader.layout_ok() and reader.read() is None      # none yet
    slave.push_record(_record(1))
    seq, words = reader.read()
    assert (seq, words) == (1, _record(1)) and reader.read() is None
    slave.push_record(_record(2))
    slave.push_record(_record(3))
    assert reader.read() == (3, _record(3))
    assert reader.records == 2 and reader.torn == 0


def test_reader_reads_again_a_record_two_newer_ones_overwrote():
    bus, slave = _bus_with_slave()
    reads = {"n": 0}
    real = slave.read32

    def racing(offset):            # two records complete during the first read
        reads["n"] += 1
        if reads["n"] == 50:
            slave.push_record(_record(8))
            slave.push_record(_record(9))
        return real(offset)
    slave.read32 = racing
    slave.push_record(_record(7))
    reader = PostureReader(bus)
    seq, words = reader.read()
    assert (seq, words) == (3, _record(9)) and reader.torn == 1


def test_layout_of_another_build_is_seen():
    bus, slave = _bus_with_slave()
    slave.read32 = lambda offset: 0
    assert not PostureReader(bus).layout_ok()


def test_the_shipped_posture_model_loads_on_the_board():
    from pathlib import Path
    path = Path(__file__).resolve().parents[1] / "sw_hps" / "models" / "posture.json"
    model = read_posture_model(path)
    assert model.class_names == ["asl{}".format(k) for k in range(10)] + [
        "fist", "relaxed", "claw", "grasp"]
    assert model.features == 176 and len(model.support_vectors) > 100
    assert model.decide(np.zeros((2, 176))).shape == (2,)
