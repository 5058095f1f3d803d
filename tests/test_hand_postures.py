"""sim/hand_postures.py and the renderer's postures: every posture drawn, its
roll and per-frame changes, the per-frame truth in clip.json and truth.csv
(validated on loading), and the fingers the posture descriptor sees."""
import json

import numpy as np
import pytest

from sim.clip import load_clip, save_clip
from sim.hand_postures import (DEFAULT_POSTURE, POSTURE_ALIASES, POSTURE_NAMES, ROLL_RANGE,
                               extended_fingers, resolve_posture)
from sim.model.posture import describe_still
from sim.render import StereoScene, render_clip, render_sequence
from stereogest import cli

SHORT = dict(n_pre_rest=1, n_motion=2, n_post_rest=1)


def test_names_aliases_and_finger_counts():
    assert len(POSTURE_NAMES) == 11 and POSTURE_NAMES[:10] == tuple(f"asl{k}" for k in range(10))
    assert {alias: resolve_posture(alias) for alias in POSTURE_ALIASES} == \
        {"open": "asl5", "point": "asl1", "v": "asl2"}
    assert [extended_fingers(f"asl{k}") for k in range(10)] == [0, 1, 2, 3, 4, 5, 3, 3, 3, 3]
    assert extended_fingers("fist") == 0
    for bad in ("asl10", "", None, 5):
        with pytest.raises(ValueError, match="posture must be one of asl0"):
            resolve_posture(bad)


@pytest.mark.parametrize("name", POSTURE_NAMES + ("open", "v"))
def test_every_posture_is_drawn_and_recorded(name):
    clip = render_clip("stop", 3, 320, 240, posture=name, **SHORT)
    assert clip.postures == (resolve_posture(name),) * clip.frames
    assert clip.renderer["posture"] == resolve_posture(name)
    assert ROLL_RANGE[0] <= clip.renderer["roll_degrees"] <= ROLL_RANGE[1]
    assert (clip.hand_area > 100).all()


def test_rolls_wander_slowly_about_the_clips_and_people_differ():
    scene = StereoScene("rotate-left", 8, posture="asl4")
    rolls = scene.hand_rolls
    assert np.abs(np.diff(rolls)).max() <= 1 and np.abs(rolls - scene.roll).max() <= 3
    assert len(set(rolls.tolist())) > 1
    other = StereoScene("rotate-left", 9, posture="asl4")
    assert scene.parameters()["person"] != other.parameters()["person"]
    fixed = StereoScene("stop", 8, posture="asl4", roll=-30, **SHORT)
    assert fixed.roll == -30 and abs(fixed.hand_rolls).max() <= 33
    with pytest.raises(ValueError, match="roll"):
        StereoScene("stop", 8, posture="asl4", roll=31, **SHORT)
    with pytest.raises(ValueError, match="roll needs a posture"):
        StereoScene("stop", 8, roll=5, **SHORT)


def test_the_open_hand_without_a_posture_is_upright_and_recorded_as_asl5():
    scene = StereoScene("stop", 2, **SHORT)
    assert scene.posture is None and not scene.hand_rolls.any()
    clip = render_clip("stop", 2, 320, 240, **SHORT)
    assert clip.postures == (DEFAULT_POSTURE,) * clip.frames
    assert "posture" not in clip.renderer


def test_the_descriptor_counts_the_raised_fingers():
    """Runs per row above the palm: an open hand's fingers apart, a fist's none."""
    seen = {}
    for name in ("asl5", "asl4", "fist", "asl0"):
        seen[name] = [max(describe_still(StereoScene("stop", seed, posture=name, **SHORT)
                                         .hand_mask(0))[0].band_max) for seed in range(4)]
    assert min(seen["asl5"]) >= 4 and min(seen["asl4"]) >= 4
    assert max(seen["fist"]) <= 2 and max(seen["asl0"]) <= 2


def test_a_sequence_changes_posture_and_the_truth_round_trips(tmp_path):
    clip = render_sequence(["stop", "left"], 4, 320, 240, postures=["fist", "v"])
    (_, a, _), (_, b, _) = clip.sequence
    assert clip.postures[a] == "fist" and clip.postures[b] == "asl2"
    assert clip.postures[-1] == "asl2"
    path = save_clip(clip, tmp_path / "clip")
    meta = json.loads((path / "clip.json").read_text())
    runs = meta["postures"]
    assert [r["posture"] for r in runs] == ["fist", "asl2"]
    assert runs[0]["frames"][0] == 0 and runs[-1]["frames"][1] == clip.frames - 1
    header, first = (path / "truth.csv").read_text().splitlines()[:2]
    assert header.endswith(",posture") and first.endswith(",fist")
    assert load_clip(path).postures == clip.postures
    with pytest.raises(ValueError, match="postures"):
        render_sequence(["stop", "left"], 4, 320, 240, postures=["fist"])


def _tampered(path, edit):
    meta = json.loads((path / "clip.json").read_text())
    edit(meta)
    (path / "clip.json").write_text(json.dumps(meta))


def test_loading_validates_the_postures(tmp_path):
    path = save_clip(render_clip("stop", 5, 96, 64, posture="fist", **SHORT), tmp_path / "c")
    truth = (path / "truth.csv").read_text()
    (path / "truth.csv").write_text(truth.replace(",fist\n", ",asl3\n", 1))
    with pytest.raises(ValueError, match="truth.csv: line 2: field 'posture' must be fist"):
        load_clip(path)
    (path / "truth.csv").write_text(truth)
    for edit in (lambda m: m["postures"][0].update(posture="wave"),
                 lambda m: m["postures"][0].update(frames=[1, m["frames"] - 1]),
                 lambda m: m.update(postures="fist")):
        _tampered(path, edit)
        with pytest.raises(ValueError, match="field 'postures' must be"):
            load_clip(path)
        path = save_clip(render_clip("stop", 5, 96, 64, posture="fist", **SHORT), path)
    _tampered(path, lambda m: m.pop("postures"))
    with pytest.raises(ValueError, match="header must be"):
        load_clip(path)


def test_cli_render_takes_postures(tmp_path, capsys):
    out = tmp_path / "c"
    assert cli.main(["render", "--sequence", "stop@fist,left", "--posture", "point",
                     "--width", "320", "--height", "240", "--pause", "0-0", "-o", str(out),
                     "--json"]) == 0
    report = json.loads(capsys.readouterr().out.splitlines()[-1])
    assert [r["posture"] for r in report["postures"]] == ["fist", "asl1"]
