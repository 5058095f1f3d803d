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
                                    dict(misaligned=True)])
def test_each_difficulty_changes_frames_not_truth(easy, option):
    hard = clip_of(**option)
    assert not np.array_equal(hard.left, easy.left)
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
                                                "misaligned": True}
    capsys.readouterr()
    assert cli.main(["render", "--gesture", "stop", "-o", str(tmp_path / "d"),
                     "--motion-blur", "2"]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "--motion-blur must be a number in [0, 1]" in err
    assert not (tmp_path / "d").exists()
