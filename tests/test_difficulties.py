"""sim/difficulties.py and the renderer's difficulty options: off, the easy scene
bit for bit; each on, the frames change as it says, deterministically per seed,
and the truth (the hand's exact centroid and area) does not."""
import hashlib

import numpy as np
import pytest

from sim.difficulties import RANGES, Difficulties, camera_gains
from sim.model.segmentation import skin_mask
from sim.model.ycbcr import ycbcr422_to_444
from sim.render import StereoScene, render_clip
from stereogest import cli

SIZE = dict(width=160, height=120, n_pre_rest=2, n_motion=4, n_post_rest=1)


def clip_of(**difficulties):
    return render_clip("rotate-left", 5, **SIZE, difficulties=Difficulties(**difficulties))


@pytest.fixture(scope="module")
def easy():
    return clip_of()


def test_the_easy_scene_is_todays_bit_for_bit(easy):
    # recorded from the renderer before the difficulties existed (commit e994414)
    digest = hashlib.sha256(easy.left.tobytes() + easy.right.tobytes()
                            + easy.hand_xy.tobytes() + easy.hand_area.tobytes()).hexdigest()
    assert digest == "0cb37822f128e0862747eb36c5c3669dfde17c13177b7e40a498ae04751f1867"
    assert not Difficulties().any and "difficulties" not in easy.renderer


@pytest.mark.parametrize("option", [dict(exposure_drift=0.3), dict(flicker=0.1),
                                    dict(motion_blur=1.0), dict(skin_tone=0.9),
                                    dict(forearm=True), dict(clutter=True),
                                    dict(defocus=1.5), dict(hand_scale=1.15),
                                    dict(misaligned=True)])
def test_each_difficulty_changes_frames_not_truth(easy, option):
    hard = clip_of(**option)
    assert not np.array_equal(hard.left, easy.left)
    if "hand_scale" not in option:            # a larger hand has another centroid and area
        np.testing.assert_array_equal(hard.hand_xy, easy.hand_xy)
        np.testing.assert_array_equal(hard.hand_area, easy.hand_area)
    assert hard.renderer["difficulties"] == Difficulties(**option).as_dict()
    again = clip_of(**option)
    assert np.array_equal(again.left, hard.left) and np.array_equal(again.right, hard.right)


def test_exposure_gains_per_camera():
    d = Difficulties(exposure_drift=0.2, flicker=0.05)
    gains = camera_gains(d, 60, np.random.default_rng(3))
    assert gains.shape == (2, 60)
    assert (gains >= 0.8 * 0.95 - 1e-9).all() and (gains <= 1.2 * 1.05 + 1e-9).all()
    assert np.ptp(gains[0]) > 0.2 and not np.allclose(gains[0], gains[1])
    np.testing.assert_array_equal(camera_gains(Difficulties(), 5, np.random.default_rng(0)),
                                  np.ones((2, 5)))


def test_exposure_scales_luma_only(easy):
    hard = clip_of(exposure_drift=0.4)
    luma = [np.mean(c.left[:, :, 0::2], axis=(1, 2)) for c in (easy, hard)]
    assert np.abs(luma[1] / luma[0] - 1).max() > 0.05
    chroma = [c.left[:, :, 1::2].astype(int) for c in (easy, hard)]
    assert np.abs(chroma[1] - chroma[0]).max() <= 8          # only the sensor noise's draw


def test_motion_blur_leaves_still_frames_and_smears_moving_ones():
    size = dict(SIZE, n_pre_rest=4)
    easy = render_clip("rotate-left", 5, **size)
    hard = render_clip("rotate-left", 5, **size, difficulties=Difficulties(motion_blur=1.0))
    scene = StereoScene("rotate-left", 5, **size)
    still = [n for n in range(1, scene.frames - 1)
             if (scene.hand_anchor[n - 1] == scene.hand_anchor[n]).all()
             and (scene.hand_anchor[n + 1] == scene.hand_anchor[n]).all()]
    moving = [n for n in range(1, scene.frames - 1) if n not in still]
    assert still and moving
    for n in still:
        assert np.array_equal(hard.left[n], easy.left[n])
    for n in moving:
        assert not np.array_equal(hard.left[n], easy.left[n])


@pytest.mark.parametrize("tone", [-1.0, 1.0])
def test_skin_tone_reaches_the_box_edges(tone):
    scene = StereoScene("stop", 2, **SIZE, noise=False,
                        difficulties=Difficulties(skin_tone=tone))
    y, cb, cr = scene.views444(0)[0]
    hand = scene.hand_mask(0)
    mean_cb, mean_cr = cb[hand].mean(), cr[hand].mean()
    expected = Difficulties(skin_tone=tone).skin_chroma()
    assert abs(mean_cb - expected[0]) < 3 and abs(mean_cr - expected[1]) < 3
    inside = skin_mask(cb, cr)[hand]
    assert 0.3 < inside.mean() < 1.0          # at the edge: part of the hand fails the box


def test_misaligned_cameras_are_undone_by_the_rigs_calibration(easy):
    from sim.calibration import StereoRig, rig_calibration, stereo_rectification
    from sim.model.rectify import rectify
    hard = clip_of(misaligned=True)
    rect = stereo_rectification(rig_calibration(StereoRig().resized(160, 120)))
    y_easy = ycbcr422_to_444(easy.left[0])[0].astype(int)
    y_hard = ycbcr422_to_444(hard.left[0])[0]
    back = rectify(y_hard, rect.left).astype(int)
    inner = (slice(10, -10), slice(10, -10))
    before = np.abs(y_hard.astype(int) - y_easy)[inner].mean()
    after = np.abs(back - y_easy)[inner].mean()
    assert before > 2 * after and after < 6


@pytest.mark.parametrize("kwargs, name", [
    *[(dict({field: hi + 0.01}), field) for field, (lo, hi) in RANGES.items()],
    *[(dict({field: lo - 0.01}), field) for field, (lo, hi) in RANGES.items()],
    (dict(motion_blur=float("nan")), "motion_blur"),
    (dict(misaligned=1), "misaligned"),
    (dict(forearm="yes"), "forearm"),
    (dict(intruder=None), "intruder"),
])
def test_bad_values_name_the_field(kwargs, name):
    with pytest.raises(ValueError, match=name):
        Difficulties(**kwargs)


def test_cli_render_with_difficulties(tmp_path, capsys):
    import json
    out = tmp_path / "c"
    assert cli.main(["render", "--gesture", "stop", "--seed", "3", "--width", "160",
                     "--height", "120", "-o", str(out), "--motion-blur", "0.5",
                     "--skin-tone", "-0.5", "--exposure-drift", "0.1", "--flicker", "0.02",
                     "--misaligned", "--json"]) == 0
    clip = json.loads((out / "clip.json").read_text())
    assert clip["renderer"]["difficulties"] == {"exposure_drift": 0.1, "flicker": 0.02,
                                                "motion_blur": 0.5, "skin_tone": -0.5,
                                                "forearm": False, "clutter": False,
                                                "intruder": False, "defocus": 0.0,
                                                "hand_scale": 1.0, "misaligned": True}
    capsys.readouterr()
    assert cli.main(["render", "--gesture", "stop", "-o", str(tmp_path / "d"),
                     "--motion-blur", "2"]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "--motion-blur must be a number in [0, 1]" in err
    assert not (tmp_path / "d").exists()


def test_forearm_slopes_through_the_band_and_is_seen_by_both_cameras():
    from sim.render import LAYER_LABELS, RIGHT_Y_GAIN, RIGHT_Y_OFFSET
    scene = StereoScene("stop", 4, 320, 240, noise=False,
                        difficulties=Difficulties(forearm=True))
    frame = scene.motion_span[0] + 5
    labels = scene.label_map(frame)
    arm = labels == LAYER_LABELS["forearm"]
    disparity = scene.disparity_map(frame)
    values = np.unique(disparity[arm])
    hand, torso = scene.disparities["hand"], scene.disparities["torso"]
    assert values.max() == hand - 1 and values.min() > torso and len(values) >= 4
    assert ((values > 33) & (values < 46)).any() and (values <= 33).any()
    assert not (arm & scene.hand_mask(frame)).any()
    # a forearm pixel of the left view appears d pixels to the left in the right view
    left, right = scene.views444(frame)
    right_labels = scene.label_map(frame, "right")
    ys, xs = np.nonzero(arm)
    d = disparity[ys, xs].astype(int)
    seen = right_labels[ys, xs - d] == LAYER_LABELS["forearm"]
    assert seen.mean() > 0.9
    expected = np.clip(np.rint(RIGHT_Y_GAIN * left[0][ys, xs].astype(float) + RIGHT_Y_OFFSET),
                       0, 255)
    assert np.abs(right[0][ys[seen], (xs - d)[seen]] - expected[seen]).max() <= 1
    # the truth is the hand alone
    easy = StereoScene("stop", 4, 320, 240, noise=False)
    assert scene.hand_truth(frame) == easy.hand_truth(frame)


def test_clutter_passes_the_skin_box_outside_the_band():
    from sim.render import LAYER_LABELS
    scene = StereoScene("left", 6, 320, 240, noise=False, difficulties=Difficulties(clutter=True))
    y, cb, cr = scene.views444(0)[0]
    clutter = scene.label_map(0) == LAYER_LABELS["clutter"]
    assert clutter.sum() > 2000
    assert skin_mask(cb, cr)[clutter].mean() > 0.95
    d = scene.disparity_map(0)[clutter]
    assert ((d <= 33) | (d >= 46)).all()


def test_intruder_rolls_in_and_out_inside_the_band_clear_of_the_hand():
    from sim.render import LAYER_LABELS
    scene = StereoScene("forward", 2, 320, 240, noise=False,
                        difficulties=Difficulties(intruder=True))
    seen = []
    for n in range(scene.frames):
        ball = scene.label_map(n) == LAYER_LABELS["intruder"]
        seen.append(int(ball.sum()))
        if ball.any():
            assert not (ball & scene.hand_mask(n)).any()
            assert set(np.unique(scene.disparity_map(n)[ball])) == {scene.disparities["hand"] - 2}
    seen = np.array(seen)
    assert seen[0] == 0 or seen[-1] == 0
    assert 0.1 < (seen > 0).mean() < 0.5 and seen.max() > 500


def test_defocus_blurs_everything_but_the_hand():
    sharp = StereoScene("stop", 2, 320, 240, noise=False)
    soft = StereoScene("stop", 2, 320, 240, noise=False, difficulties=Difficulties(defocus=2.0))
    a, b = sharp.views444(0)[0][0].astype(int), soft.views444(0)[0][0].astype(int)
    hand = sharp.hand_mask(0)
    assert np.array_equal(a[hand], b[hand])
    background = sharp.label_map(0) == 0
    assert np.abs(np.diff(b, axis=1))[background[:, 1:]].mean() < \
        0.7 * np.abs(np.diff(a, axis=1))[background[:, 1:]].mean()


def test_hand_scale_scales_the_hand():
    areas = [StereoScene("stop", 2, 320, 240, difficulties=Difficulties(hand_scale=k))
             .hand_truth(0)[2] for k in (0.8, 1.0, 1.2)]
    assert areas[0] < areas[1] < areas[2]
    assert abs(areas[2] / areas[1] - 1.44) < 0.12 and abs(areas[0] / areas[1] - 0.64) < 0.08


def test_presets():
    from sim.difficulties import HARD, HARD_PERSON, preset
    assert preset("easy", 3) == Difficulties()
    hard = [preset("hard", seed) for seed in (1, 2, 1)]
    assert hard[0] == hard[2] and hard[0] != hard[1]
    for d in hard:
        assert all(getattr(d, k) == v for k, v in HARD.items()) and not d.misaligned
        for name, (lo, hi) in HARD_PERSON.items():
            assert lo <= getattr(d, name) <= hi
    with pytest.raises(ValueError, match="scene must be one of easy, hard"):
        preset("medium", 1)


def test_cli_scene_preset_and_overrides(tmp_path):
    import json
    from sim.difficulties import preset
    out = tmp_path / "c"
    assert cli.main(["render", "--gesture", "stop", "--seed", "4", "--width", "160",
                     "--height", "120", "-o", str(out), "--scene", "hard",
                     "--motion-blur", "0", "--misaligned"]) == 0
    got = json.loads((out / "clip.json").read_text())["renderer"]["difficulties"]
    expected = preset("hard", 4).as_dict()
    expected.update(motion_blur=0.0, misaligned=True)
    assert got == expected
