"""The synthetic stereo scene renderer and the `stereogest render` subcommand."""
import json

import numpy as np
import pytest

import stereogest.cli as cli
from sim.clip import load_clip, round_truth, save_clip
from sim.gesture_shapes import GESTURE_NAMES
from sim.model.segmentation import skin_mask
from sim.model.ycbcr import ycbcr422_to_444
from sim.render import (
    LAYER_LABELS, RIGHT_Y_GAIN, RIGHT_Y_OFFSET, StereoScene, render_clip,
)

SMALL = dict(width=160, height=120, n_pre_rest=2, n_motion=8, n_post_rest=2)


@pytest.fixture(scope="module")
def scene():
    return StereoScene("rotate-left", 7, **SMALL)


@pytest.fixture(scope="module")
def clip():
    return render_clip("rotate-left", 7, **SMALL)


def erode(mask: np.ndarray, steps: int = 1) -> np.ndarray:
    """4-neighbour binary erosion (keeps clear of 4:2:2 chroma pairs on the outline)."""
    out = mask.copy()
    for _ in range(steps):
        inner = out.copy()
        inner[1:] &= out[:-1]
        inner[:-1] &= out[1:]
        inner[:, 1:] &= out[:, :-1]
        inner[:, :-1] &= out[:, 1:]
        inner[[0, -1], :] = False
        inner[:, [0, -1]] = False
        out = inner
    return out


def test_clip_shape_and_metadata(clip):
    clip.validate()
    assert clip.left.shape == clip.right.shape == (12, 120, 320)
    assert clip.left.dtype == np.uint8
    assert clip.motion_frames == (2, 9)
    assert clip.moving.tolist() == [False] * 2 + [True] * 8 + [False] * 2
    assert (clip.hand_disparity, clip.face_disparity) == (40, 24)
    params = clip.renderer
    assert params["torso_disparity"] == 28 and 4 <= params["background_disparity"] <= 10
    json.dumps(clip.metadata())                    # JSON-serialisable


def test_deterministic_per_seed_and_different_across_seeds(clip):
    again = render_clip("rotate-left", 7, **SMALL)
    assert np.array_equal(clip.left, again.left) and np.array_equal(clip.right, again.right)
    assert np.array_equal(clip.hand_xy, again.hand_xy)
    other = render_clip("rotate-left", 8, **SMALL)
    assert not np.array_equal(clip.left, other.left)
    assert np.mean(clip.left[0] != other.left[0]) > 0.5       # a different room


def test_seeded_timing_and_amplitude():
    timings, amplitudes = set(), []
    for seed in range(6):
        sc = StereoScene("left", seed, 160, 120)
        assert 15 <= sc.n_pre_rest <= 30 and 15 <= sc.n_post_rest <= 30
        assert 40 <= sc.n_motion <= 80
        assert sc.frames == sc.n_pre_rest + sc.n_motion + sc.n_post_rest
        assert sc.motion_span == (sc.n_pre_rest, sc.n_pre_rest + sc.n_motion - 1)
        timings.add((sc.n_pre_rest, sc.n_motion, sc.n_post_rest))
        amplitudes.append(sc.amplitude)
        # "left" has room: amplitude is 200 px at 640x480 +- 15 %, scaled to 160x120.
        assert 0.85 * 50 - 1e-9 <= sc.amplitude <= 1.15 * 50 + 1e-9
        xs = sc.hand_anchor[:, 0]
        assert xs.max() - xs[0] == pytest.approx(sc.amplitude, abs=1.0)   # goes right
        assert xs.min() == xs[0] == xs[-1]
    assert len(timings) > 3 and np.ptp(amplitudes) > 2
    fast = StereoScene("left", 0, 160, 120, fps=60)
    assert 80 <= fast.n_motion <= 160


def test_reference_size_hand_and_amplitude():
    sc = StereoScene("forward", 3, n_pre_rest=1, n_motion=30, n_post_rest=1)
    width, height = sc.hand_size
    assert 70 <= height <= 90 and 45 <= width <= 75
    assert 170 <= sc.amplitude <= 230
    ys = sc.hand_anchor[:, 1]
    assert ys[0] - ys.min() == pytest.approx(sc.amplitude * sc.aspect, abs=1.0)   # goes up


def test_truth_is_the_hand_centroid(scene, clip):
    for frame in range(scene.frames):
        mask = scene.hand_mask(frame)
        rows, cols = np.nonzero(mask)
        assert clip.hand_area[frame] == rows.size > 0
        expected = round_truth([cols.mean(), rows.mean()])
        assert np.array_equal(clip.hand_xy[frame], expected)
        x, y = np.rint(clip.hand_xy[frame]).astype(int)
        assert mask[y, x]                                      # centre inside the hand
    still = clip.hand_xy[~clip.moving]
    assert np.all(still == still[0])                           # at rest before and after
    assert len({tuple(p) for p in clip.hand_xy[clip.moving]}) > 5


def test_colours_pass_or_fail_the_skin_test(scene, clip):
    for frame in (0, 5, 11):
        _, cb, cr = ycbcr422_to_444(clip.left[frame])
        skin = skin_mask(cb, cr)
        labels = scene.label_map(frame)
        hand = labels == LAYER_LABELS["hand"]
        assert skin[erode(hand)].all()
        assert skin[hand].mean() > 0.75                        # small hand: outline pairs mix
        face = labels == LAYER_LABELS["face"]
        assert skin[erode(face)].mean() > 0.98
        assert skin[labels == LAYER_LABELS["background"]].mean() < 0.1
        assert skin[labels == LAYER_LABELS["torso"]].mean() < 0.02
        assert skin[erode(labels == LAYER_LABELS["hair"])].mean() < 0.02


def test_disparity_ground_truth(scene):
    disparity = scene.disparity_map(5)
    labels = scene.label_map(5)
    assert disparity.max() <= 47
    assert np.all(disparity[labels == LAYER_LABELS["hand"]] == 40)
    assert np.all(disparity[labels == LAYER_LABELS["face"]] == 24)
    assert np.all(disparity[labels == LAYER_LABELS["torso"]] == 28)
    band = (disparity > 33) & (disparity < 46)
    assert np.array_equal(band, labels == LAYER_LABELS["hand"])     # only the hand is in the band


def test_right_view_is_shifted_by_the_layer_disparity(scene):
    left, right = scene.views444(5)
    d = scene.disparities["hand"]
    rows, cols = np.nonzero(scene.hand_mask(5))
    assert cols.min() >= d                                    # whole hand seen by both cameras
    lum_l = left[0, rows, cols].astype(float)
    lum_r = right[0, rows, cols - d].astype(float)
    assert np.all(np.abs(lum_r - (RIGHT_Y_GAIN * lum_l + RIGHT_Y_OFFSET)) <= 1.0)
    assert np.array_equal(left[1:, rows, cols], right[1:, rows, cols - d])
    # The static background too: a far-wall pixel at x is at x - d_bg on the right.
    d_bg = scene.disparities["background"]
    ys, xs = np.nonzero(scene.label_map(5) == LAYER_LABELS["background"])
    keep = xs >= d_bg
    ys, xs = ys[keep], xs[keep]
    right_labels = scene.label_map(5, view="right")
    visible = right_labels[ys, xs - d_bg] == LAYER_LABELS["background"]    # not occluded
    ys, xs = ys[visible], xs[visible]
    assert visible.mean() > 0.8
    assert np.array_equal(left[1:, ys, xs], right[1:, ys, xs - d_bg])
    # The right view's maps agree with the layers: the hand is at x - d there.
    assert np.array_equal(scene.hand_mask(5, view="right")[rows, cols - d],
                          np.ones(rows.size, bool))
    right_disparity = scene.disparity_map(5, view="right")
    assert np.all(right_disparity[right_labels == LAYER_LABELS["hand"]] == d)


def test_block_match_finds_the_hand_disparity(scene, clip):
    """Sum of absolute Y differences over the hand's box, noisy streams, d = 0..47."""
    for frame in (3, 7):
        y_left = clip.left[frame][:, 0::2].astype(np.int32)
        y_right = clip.right[frame][:, 0::2].astype(np.int32)
        rows, cols = np.nonzero(scene.hand_mask(frame))
        y0, y1, x0, x1 = rows.min(), rows.max() + 1, cols.min(), cols.max() + 1
        patch = y_left[y0:y1, x0:x1]
        patch = patch - patch.mean()
        costs = []
        for d in range(48):
            other = y_right[y0:y1, x0 - d:x1 - d]
            costs.append(np.abs(patch - (other - other.mean())).sum())
        assert int(np.argmin(costs)) == 40


def test_noise_is_independent_per_camera():
    sc = StereoScene("back", 1, **SMALL)
    quiet = StereoScene("back", 1, noise=False, **SMALL)
    left, right = sc.stereo_frame(4)
    left0, right0 = quiet.stereo_frame(4)
    noise_l = left.astype(int) - left0
    noise_r = right.astype(int) - right0
    assert 1.6 < noise_l[:, 0::2].std() < 2.4 and 0.7 < noise_l[:, 1::2].std() < 1.3
    assert abs(np.corrcoef(noise_l.ravel(), noise_r.ravel())[0, 1]) < 0.05
    assert not np.array_equal(sc.stereo_frame(5)[0] - left0, noise_l)


@pytest.mark.parametrize("kwargs, field", [
    (dict(width=161), "width"),
    (dict(width=90), "width"),
    (dict(width=4098), "width"),
    (dict(height=63), "height"),
    (dict(height=121), "height"),
    (dict(hand_disparity=48), "hand_disparity"),
    (dict(face_disparity=-1), "face_disparity"),
    (dict(background_disparity=50), "background_disparity"),
    (dict(fps=2), "fps"),
    (dict(seed=-1), "seed"),
    (dict(n_motion=1), "n_motion"),
    (dict(gesture="wave"), "gesture"),
])
def test_bad_parameters_name_the_parameter(kwargs, field):
    args = dict(gesture="left", seed=0, width=160, height=120) | kwargs
    with pytest.raises(ValueError, match=field):
        render_clip(**args)


@pytest.mark.parametrize("gesture", GESTURE_NAMES)
def test_every_gesture_keeps_the_hand_in_both_views(gesture):
    sc = StereoScene(gesture, 11, 96, 64)
    margin = sc.disparities["hand"]
    for frame in range(sc.frames):
        rows, cols = np.nonzero(sc.hand_mask(frame))
        assert rows.size > 0 and cols.min() >= margin
        assert rows.min() > 0 and rows.max() < 63 and cols.max() < 95


def test_rendered_clip_round_trip(tmp_path, clip):
    save_clip(clip, tmp_path / "c")
    loaded = load_clip(tmp_path / "c")
    assert np.array_equal(loaded.left, clip.left) and np.array_equal(loaded.right, clip.right)
    assert np.array_equal(loaded.hand_xy, clip.hand_xy)
    assert loaded.metadata() == clip.metadata()


def test_cli_render(tmp_path, capsys):
    out = tmp_path / "clip"
    status = cli.main(["render", "--gesture", "stop", "--seed", "3", "-o", str(out),
                       "--width", "96", "--height", "64", "--fps", "10"])
    assert status == 0
    printed = capsys.readouterr().out.strip()
    assert "\n" not in printed and "frames" in printed and str(out) in printed
    clip = load_clip(out)
    assert clip.gesture == "stop" and clip.seed == 3 and clip.fps == 10
    assert (clip.width, clip.height) == (96, 64)
    first, last = clip.motion_frames
    assert f"motion in frames {first}-{last}" in printed and f"{clip.frames} frames" in printed


def test_cli_bad_value_exits_2(tmp_path, capsys):
    status = cli.main(["render", "--gesture", "left", "--seed", "1", "-o",
                       str(tmp_path / "c"), "--width", "97"])
    assert status == 2
    err = capsys.readouterr().err
    assert "stereogest render: error:" in err and "width must be even" in err
    assert list(tmp_path.iterdir()) == []
    with pytest.raises(SystemExit) as exit_info:
        cli.main(["render", "--gesture", "wave", "--seed", "1", "-o", str(tmp_path / "c")])
    assert exit_info.value.code == 2
    assert "invalid choice" in capsys.readouterr().err


def test_sequence_truth_and_its_clip_files(tmp_path):
    """render_sequence (issue 28): the gestures one after another, each span
    where its own clip puts it (the pauses drawn from the seed), the truth
    saved and loaded; a clip.json whose sequence is not in order is refused."""
    import json

    from sim.clip import load_clip, save_clip
    from sim.render import SEQUENCE_LEAD, SEQUENCE_TAIL, render_sequence
    names = ["right", "stop", "left"]
    clip = render_sequence(names, 3, 160, 120, pause=(0, 6), noise=False)
    assert [g for g, _, _ in clip.sequence] == names and clip.gesture == "left"
    spans = [(a, b) for _, a, b in clip.sequence]
    assert spans[0][0] == SEQUENCE_LEAD and clip.frames - 1 - spans[-1][1] == SEQUENCE_TAIL
    gaps = [b0 - a1 - 1 for (_, a1), (b0, _) in zip(spans, spans[1:])]
    assert all(0 <= g <= 6 for g in gaps)
    assert clip.motion_frames == (spans[0][0], spans[-1][1])
    assert clip.moving.sum() == sum(b - a + 1 for a, b in spans)
    # the same seed draws the same pauses; each gesture as render_clip draws it
    again = render_sequence(names, 3, 160, 120, pause=(0, 6), noise=False)
    assert again.sequence == clip.sequence and np.array_equal(again.left, clip.left)
    alone = render_clip("stop", 3, 160, 120, n_pre_rest=0, n_post_rest=gaps[1], noise=False)
    start = spans[1][0]
    assert np.array_equal(clip.left[start:start + alone.frames], alone.left)
    path = save_clip(clip, tmp_path / "seq")
    loaded = load_clip(path)
    assert loaded.sequence == clip.sequence and np.array_equal(loaded.moving, clip.moving)
    meta = json.loads((path / "clip.json").read_text())
    meta["sequence"][1], meta["sequence"][0] = meta["sequence"][0], meta["sequence"][1]
    (path / "clip.json").write_text(json.dumps(meta))
    with pytest.raises(ValueError, match="clip.json: field 'sequence' must be"):
        load_clip(path)
    with pytest.raises(ValueError, match="sequence must name one or more"):
        render_sequence(["wave"], 3, 160, 120)
    with pytest.raises(ValueError, match="pause"):
        render_sequence(names, 3, 160, 120, pause=(5, 2))


def test_render_sequence_command_and_continuous_pipeline(tmp_path, capsys):
    """`render --sequence` writes the truth; `pipeline --spotting continuous`
    names every gesture of it and scores itself against that truth, where the
    thesis' spotting (one flagged run over gestures without rests) names none."""
    out = tmp_path / "seq"
    assert cli.main(["render", "--sequence", "right,stop,left", "--pause", "0-8", "--seed",
                     "8", "--width", "320", "--height", "240", "-o", str(out), "--json"]) == 0
    report = json.loads(capsys.readouterr().out.splitlines()[-1])
    assert [s["gesture"] for s in report["sequence"]] == ["right", "stop", "left"]
    assert cli.main(["pipeline", str(out), "-o", str(tmp_path / "p"), "--spotting",
                     "continuous", "--json", "--quiet"]) == 0
    result = json.loads(capsys.readouterr().out.splitlines()[-1])
    assert [g["name"] for g in result["gestures"]] == ["right", "stop", "left"]
    assert (result["truth"]["correct"], result["truth"]["false"]) == (3, 0)
    assert cli.main(["pipeline", str(out), "-o", str(tmp_path / "t"), "--json",
                     "--quiet"]) == 0
    thesis = json.loads(capsys.readouterr().out.splitlines()[-1])
    assert thesis["truth"]["correct"] < 3


@pytest.mark.parametrize("argv, message", [
    (["--sequence", "right,wave"], "--sequence: names must be among"),
    (["--sequence", "right", "--gesture", "stop"], "give either --gesture NAME or --sequence"),
    ([], "give either --gesture NAME or --sequence"),
    (["--sequence", "right,stop", "--pause", "9-3"], "--pause must satisfy"),
])
def test_render_sequence_bad_input(tmp_path, capsys, argv, message):
    assert cli.main(["render", *argv, "-o", str(tmp_path / "x"), "--width", "160",
                     "--height", "120"]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and message in err and "Traceback" not in err
    assert not (tmp_path / "x").exists()
