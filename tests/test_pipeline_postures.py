"""Each gesture's posture in `stereogest pipeline --json` and `demo`
(stereogest/pipeline_outputs.py: frame_postures, add_postures)."""
import json

import numpy as np

from sim.clip import save_clip
from sim.render import render_clip
from stereogest import cli
from stereogest.pipeline_outputs import add_postures, frame_postures


def test_the_posture_held_over_most_of_each_gesture():
    postures = ["fist", "fist", "asl5", None, "asl5", "asl5", "asl1", None, None, None]
    entries = [{"name": "stop", "first": 10, "last": 15}, {"name": "left", "first": 16,
                                                            "last": 19},
               {"name": "back", "first": None, "last": None}]
    out = add_postures(entries, postures, first_frame=10)
    assert [(e["posture"], e["posture_share"]) for e in out] == \
        [("asl5", 0.5), (None, 0.75), (None, None)]
    assert out[0]["name"] == "stop" and "posture" not in entries[0]
    # a tie goes to a named posture, not to refusals
    assert add_postures([{"first": 0, "last": 3}], ["fist", None, None, "fist"])[0][
        "posture"] == "fist"


def test_no_model_or_no_records_names_no_posture():
    from sim.model.pipeline import track
    trajectory = track(np.zeros((4, 2)), np.ones(4, np.int64))
    assert frame_postures(None, trajectory) == [None] * 4
    assert frame_postures(object(), trajectory) == [None] * 4      # no posture records


def test_pipeline_json_gives_each_gesture_its_posture(tmp_path, capsys):
    clip = render_clip("rotate-right", 1, 320, 240, n_pre_rest=2, n_motion=10, n_post_rest=2,
                       posture="fist")
    path = save_clip(clip, tmp_path / "clip")
    data = tmp_path / "postures.npz"
    model = tmp_path / "posture.json"
    assert cli.main(["postures", "-o", str(data), "--people", "2", "--seed", "1",
                     "--postures", "fist,open", "--width", "320", "--height", "240",
                     "--quiet"]) == 0
    assert cli.main(["train-posture", str(data), "-o", str(model), "--copies", "0"]) == 0
    capsys.readouterr()
    assert cli.main(["pipeline", str(path), "-o", str(tmp_path / "out"), "--json", "--quiet",
                     "--posture-model", str(model)]) == 0
    report = json.loads(capsys.readouterr().out.strip().splitlines()[-1])
    assert report["gestures"], "the clip's gesture must be named"
    for gesture in report["gestures"]:
        assert gesture["posture"] == "fist" and 0.5 < gesture["posture_share"] <= 1.0
