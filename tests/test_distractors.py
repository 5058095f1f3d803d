"""Non-gesture motion (issue 28): sim.distractors' paths, the renderer's
distractor scenes and sequences, their truth in clip files and the render
command's options."""
from __future__ import annotations

import json

import numpy as np
import pytest

from sim.clip import load_clip, save_clip
from sim.distractors import DEPTH_AWAY, DEPTH_TOWARDS, DISTRACTOR_KINDS, distractor_motion
from sim.model.pipeline import PipelineParams
from sim.render import (SEQUENCE_LEAD, DistractorScene, StereoScene, render_scene,
                        render_sequence)
from stereogest import cli


@pytest.mark.parametrize("kind", DISTRACTOR_KINDS)
def test_every_path_starts_and_ends_where_the_hand_was(kind):
    for seed in range(20):
        path = distractor_motion(kind, np.random.default_rng(seed))
        assert path.kind == kind and path.offset.shape == (path.frames, 2)
        assert path.disparity.shape == (path.frames,)
        assert np.array_equal(path.offset[0], [0, 0]) and np.array_equal(path.offset[-1], [0, 0])
        assert path.disparity[0] == 0 and path.disparity[-1] == 0
        assert path.in_view.shape == (path.frames,) and path.in_view[0] and path.in_view[-1]
        assert path.in_view.all() == (kind != "out-of-view")
        assert 30 <= path.frames <= 240           # 1-8 s at 30 fps
        # no jump: at most half an amplitude per frame
        assert np.abs(np.diff(path.offset, axis=0)).max() < 0.5
        again = distractor_motion(kind, np.random.default_rng(seed))
        assert np.array_equal(again.offset, path.offset)


def test_each_kind_does_what_its_name_says():
    rng = np.random.default_rng(5)
    band = PipelineParams()
    low, high = band.band_low, band.max_disparity - 2
    for _ in range(20):
        out = distractor_motion("out-of-view", rng, exit_below=1.6)
        assert out.offset[:, 1].max() > 1.6                     # below the picture
        assert np.array_equal(out.in_view, out.offset[:, 1] < 1.6)
        face = np.array([0.1, -1.4])
        scratch = distractor_motion("scratch", rng, face=face)
        assert np.linalg.norm(scratch.offset - face, axis=1).min() < 0.4
        reach = distractor_motion("reach", rng)
        assert np.abs(reach.offset[:, 0]).max() >= 0.9
        drift = distractor_motion("drift", rng)
        assert np.linalg.norm(np.diff(drift.offset, axis=0), axis=1).max() < 0.012 * 1.9
        depth = distractor_motion("depth", rng)
        extreme = depth.disparity[np.argmax(np.abs(depth.disparity))]
        assert not low < 40 + extreme < high                  # leaves the band 33 < d < 46
        assert DEPTH_TOWARDS[0] <= extreme <= DEPTH_TOWARDS[1] or \
            DEPTH_AWAY[0] <= extreme <= DEPTH_AWAY[1]


@pytest.mark.parametrize("kwargs, message", [
    (dict(kind="jump"), "distractor kind must be one of out-of-view"),
    (dict(fps=2), "fps must be an integer in"),
    (dict(face=(1.0, float("nan"))), "face must be two finite numbers"),
    (dict(exit_below=0.0), "exit_below must be a positive number"),
])
def test_bad_parameters_are_named(kwargs, message):
    kind = kwargs.pop("kind", "wave")
    with pytest.raises(ValueError, match=message):
        distractor_motion(kind, np.random.default_rng(0), **kwargs)


def test_distractor_scene_leaves_the_picture_and_the_band():
    out = DistractorScene("out-of-view", 3, 160, 120, index=1, n_pre_rest=2, n_post_rest=2,
                          noise=False)
    clip = render_scene(out)
    assert clip.gesture is None and (clip.hand_area == 0).any()
    assert np.isnan(clip.hand_xy[clip.hand_area == 0]).all()
    assert clip.hand_area[0] > 0 and clip.hand_area[-1] > 0       # from rest, back to rest
    assert clip.renderer["distractor"] == "out-of-view"
    # the person and room are the gesture scenes' of the same seed
    gesture = StereoScene("stop", 3, 160, 120, noise=False)
    assert np.array_equal(out._static["left"], gesture._static["left"])
    for seed in range(6):
        depth = DistractorScene("depth", seed, 160, 120, noise=False)
        d = depth.hand_disparities
        assert d[0] == 40 and d[-1] == 40 and (d != 40).any()
        frame = int(np.argmax(np.abs(d - 40)))
        truth = depth.disparity_map(frame)
        assert (truth[depth.hand_mask(frame)] == d[frame]).all()


def test_sequence_with_distractors_truth_and_clip_files(tmp_path):
    names = ["right", "stop", "left"]
    plain = render_sequence(names, 4, 160, 120, pause=(0, 6), noise=False)
    clip = render_sequence(names, 4, 160, 120, pause=(0, 6), noise=False, distractors=True)
    assert [g for g, _, _ in clip.sequence] == names and clip.gesture == "left"
    assert len(clip.distractors) == 3
    assert clip.distractors[0][1] == SEQUENCE_LEAD
    kinds = [k for k, _, _ in clip.distractors]
    assert len(set(kinds)) == 3 and set(kinds) <= set(DISTRACTOR_KINDS)
    # each distractor before its gesture, none overlapping one
    for (kind, a, b), (_, g0, _) in zip(clip.distractors, clip.sequence):
        assert a <= b < g0
    assert clip.frames > plain.frames
    # the gestures' pauses are drawn as without distractors
    gaps = [b0 - a1 for (_, _, a1), (_, b0, _) in zip(plain.sequence, plain.sequence[1:])]
    assert all(g >= 1 for g in gaps)
    again = render_sequence(names, 4, 160, 120, pause=(0, 6), noise=False, distractors=True)
    assert again.distractors == clip.distractors and np.array_equal(again.left, clip.left)
    path = save_clip(clip, tmp_path / "seq")
    loaded = load_clip(path)
    assert loaded.distractors == clip.distractors and loaded.sequence == clip.sequence
    meta = json.loads((path / "clip.json").read_text())
    meta["distractors"][1]["frames"] = list(meta["sequence"][0]["motion_frames"])
    (path / "clip.json").write_text(json.dumps(meta))
    with pytest.raises(ValueError, match="field 'distractors' must be"):
        load_clip(path)


def test_distractors_only(tmp_path):
    clip = render_sequence([], 2, 160, 120, pause=(0, 4), distractors=True, frames=420,
                           noise=False)
    assert clip.frames == 420 and clip.sequence == () and clip.gesture is None
    kinds = [k for k, _, _ in clip.distractors]
    assert kinds[:6] and len(set(kinds[:6])) == len(kinds[:6])   # every kind before a repeat
    assert clip.motion_frames == (clip.distractors[0][1], clip.distractors[-1][2])
    assert not clip.moving.any()
    loaded = load_clip(save_clip(clip, tmp_path / "idle"))
    assert loaded.distractors == clip.distractors and loaded.gesture is None
    for kwargs, message in ((dict(frames=None), "needs frames"),
                            (dict(frames=0), "frames must be")):
        with pytest.raises(ValueError, match=message):
            render_sequence([], 2, 160, 120, distractors=True, **kwargs)
    with pytest.raises(ValueError, match="sequence must name one or more"):
        render_sequence([], 2, 160, 120, frames=10)
    with pytest.raises(ValueError, match="frames is for a clip of distractors only"):
        render_sequence(["stop"], 2, 160, 120, distractors=True, frames=10)


def test_render_command_distractors(tmp_path, capsys):
    out = tmp_path / "idle"
    assert cli.main(["render", "--sequence", "none", "--distractors", "--frames", "120",
                     "--width", "160", "--height", "120", "--scene", "hard", "-o", str(out),
                     "--json"]) == 0
    report = json.loads(capsys.readouterr().out.splitlines()[-1])
    assert report["sequence"] == [] and report["frames"] == 120 and report["distractors"]
    assert load_clip(out).distractors == tuple((d["kind"], *d["frames"])
                                               for d in report["distractors"])


@pytest.mark.parametrize("argv, message", [
    (["--sequence", "none"], "--sequence none needs --distractors and --frames N"),
    (["--sequence", "none", "--distractors"], "--sequence none needs --distractors"),
    (["--sequence", "right", "--frames", "9"], "--frames goes with --sequence none"),
    (["--gesture", "right", "--distractors"], "--distractors and --frames go with --sequence"),
    (["--sequence", "none", "--distractors", "--frames", "0"], "--frames must be in [1, "),
])
def test_render_command_distractors_bad_input(tmp_path, capsys, argv, message):
    assert cli.main(["render", *argv, "-o", str(tmp_path / "x"), "--width", "160",
                     "--height", "120"]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and message in err and "Traceback" not in err
    assert not (tmp_path / "x").exists()


def test_each_kind_has_the_hands_people_make_in_it():
    from sim.distractors import distractor_hands
    from sim.hand_postures import HAND_SHAPE_NAMES
    for kind in DISTRACTOR_KINDS:
        for seed in range(6):
            motion = distractor_motion(kind, np.random.default_rng(seed))
            hands = distractor_hands(motion, np.random.default_rng(seed))
            assert len(hands) == motion.frames and set(hands) <= set(HAND_SHAPE_NAMES)
            first, last = motion.hold
            if kind == "reach":      # open on the way out, closed round the object after
                assert set(hands[:first]) == {"asl5"} and set(hands[first:]) == {"grasp"}
                assert motion.offset[first:last + 1].std(axis=0).max() < 1e-9
            elif kind == "scratch":
                assert set(hands[first:last + 1]) == {"claw"}
                assert hands[0] == hands[-1] == "relaxed"
            elif kind == "wave":
                assert set(hands) == {"asl5"}
            elif kind == "drift":
                assert set(hands) == {"relaxed"}
            else:                    # any hand but the stop posture's, held throughout
                assert len(set(hands)) == 1 and hands[0] != "fist"
            assert distractor_hands(motion, np.random.default_rng(seed), "asl3") == \
                ("asl3",) * motion.frames


def test_a_share_of_the_distractors_is_made_in_the_command_posture():
    from sim.distractors import COMMAND_SHARE
    clip = render_sequence([], 11, 96, 64, distractors=True, frames=2400, command="asl3")
    share = clip.renderer["distractor_command_share"]
    assert COMMAND_SHARE[0] <= share <= COMMAND_SHARE[1]
    plain = render_sequence([], 11, 96, 64, distractors=True, frames=2400, command=None)
    assert plain.renderer["distractor_command_share"] == 0.0
    assert plain.distractors == clip.distractors      # the same motion, other hands
    made = [clip.postures[a:b + 1] != plain.postures[a:b + 1] for _, a, b in clip.distractors]
    assert all(set(clip.postures[a:b + 1]) == {"asl3"}
               for (_, a, b), m in zip(clip.distractors, made) if m)
    # one in every 1 / share, give or take the first
    assert abs(sum(made) - share * len(made)) <= 1 and sum(made) >= len(made) // 5


def test_a_held_posture_between_rests():
    from sim.render import HoldScene, render_hold
    clip = render_hold("fist", 4, 160, 120, before=5, hold=7, after=3, around="asl2")
    assert clip.frames == 15 and clip.motion_frames == (5, 11) and clip.gesture is None
    assert clip.postures == ("asl2",) * 5 + ("fist",) * 7 + ("asl2",) * 3
    scene = HoldScene("fist", 4, 160, 120, before=5, hold=7, after=3, around="asl2")
    assert len({tuple(a) for a in scene.hand_anchor}) == 1          # the hand stays put
    assert scene.parameters()["hold_posture"] == "fist"
    with pytest.raises(ValueError, match="hold must be"):
        render_hold("fist", 4, 160, 120, hold=0)
    with pytest.raises(ValueError, match="posture must be one of"):
        render_hold("claw", 4, 160, 120)
