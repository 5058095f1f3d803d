"""sim/calibration.py and ``stereogest chessboards`` / ``calibrate``: chessboard
pairs rendered from a known, misaligned rig (sim.calibration.StereoRig); the
calibration recovers the rig; its rectification puts the board's corners on
the same rows; the file round-trips and refuses what is not a calibration."""
import json

import cv2
import numpy as np
import pytest

from sim.calibration import (StereoRig, calibrate, camera_frames, find_corners,
                             load_calibration,
                             misalign_frames, parse_pattern, render_chessboard_pairs,
                             rig_calibration, save_calibration, stereo_rectification)
from sim.model.rectify import homography_maps, misalignment, rectify
from stereogest import cli

RIG = StereoRig()


@pytest.fixture(scope="module")
def pairs():
    return render_chessboard_pairs(RIG, 10, seed=4)


@pytest.fixture(scope="module")
def calibration(pairs):
    return calibrate(pairs)


def test_the_rig_is_recovered(calibration):
    c = calibration
    assert c.pairs == 10 and c.rms < 0.3
    for side, k in (("left", c.camera_left), ("right", c.camera_right)):
        truth = RIG.camera_matrix(side)
        assert abs(k[0, 0] / truth[0, 0] - 1) < 0.005 and abs(k[1, 1] / truth[1, 1] - 1) < 0.005
        assert np.abs(k[:2, 2] - truth[:2, 2]).max() < 3
    # the lens distortion (its coefficients trade off against each other): where
    # points far out in the image land once undistorted
    corners = np.array([[[30.0, 30.0]], [[610.0, 40.0]], [[320.0, 450.0]], [[600.0, 460.0]]])
    for side, k, d in (("left", c.camera_left, c.distortion_left),
                       ("right", c.camera_right, c.distortion_right)):
        ours = cv2.undistortPoints(corners, k, d, P=k)
        truth = RIG.camera_matrix(side)
        theirs = cv2.undistortPoints(corners, truth, RIG.distortion(side), P=truth)
        assert np.abs(ours - theirs).max() < 2.0, side
    assert abs(c.baseline / np.linalg.norm(RIG.T) - 1) < 0.005
    angle = np.degrees(np.linalg.norm(cv2.Rodrigues(c.R @ RIG.R.T)[0]))
    assert angle < 0.1


def test_rectification_puts_the_corners_on_the_same_rows(pairs, calibration):
    rect = stereo_rectification(calibration)
    before, after = [], []
    for left, right in pairs[:3]:
        cl, cr = find_corners(left, (9, 6)), find_corners(right, (9, 6))
        before.append(np.abs(cl[:, 1] - cr[:, 1]))
        rl = find_corners(rectify(left, rect.left), (9, 6))
        rr = find_corners(rectify(right, rect.right), (9, 6))
        after.append(np.abs(rl[:, 1] - rr[:, 1]))
    assert np.mean(before) > 1 and np.mean(after) < 0.3


def test_file_round_trip(calibration, tmp_path):
    path = save_calibration(calibration, tmp_path / "c.json")
    back = load_calibration(path)
    for name in ("camera_left", "distortion_right", "R", "T", "P2", "Q"):
        assert np.allclose(getattr(back, name), getattr(calibration, name), atol=1e-12), name
    assert (back.width, back.height, back.pairs, back.pattern) == (640, 480, 10, (9, 6))


@pytest.mark.parametrize("change, match", [
    (lambda d: d.update(format="x"), "not a calibration file"),
    (lambda d: d.update(version=2), "version must be 1"),
    (lambda d: d.update(image_size=[640]), "image_size must be"),
    (lambda d: d.update(image_size=[8, 480]), "image_size[0] must be in [16, 4096]"),
    (lambda d: d.update(camera_left=[[1, 2], [3, 4]]), "camera_left must be a finite (3, 3)"),
    (lambda d: d["camera_right"][0].__setitem__(0, -5), "camera_right must be a camera matrix"),
    (lambda d: d.update(R1=np.eye(3).tolist() + [[0, 0, 0]]), "R1 must be a finite (3, 3)"),
    (lambda d: d.update(R2=(2 * np.eye(3)).tolist()), "R2 must be a rotation matrix"),
    (lambda d: d.update(rms_px=float("nan")), "rms_px must be a number"),
    (lambda d: d.pop("Q"), "Q is missing"),
    (lambda d: d.update(T=["a", 0, 0]), "T must be a (3,) array of numbers"),
])
def test_load_refuses_naming_the_field(calibration, tmp_path, change, match):
    doc = json.loads(save_calibration(calibration, tmp_path / "c.json").read_text())
    change(doc)
    (tmp_path / "c.json").write_text(json.dumps(doc))
    with pytest.raises(ValueError) as info:
        load_calibration(tmp_path / "c.json")
    assert match in str(info.value)


def test_too_few_boards_and_a_wrong_pattern_are_refused(pairs):
    with pytest.raises(ValueError, match="found in both images of 0 of 6 pairs"):
        calibrate(pairs[:6], pattern=(8, 6))
    with pytest.raises(ValueError, match="at least 5"):
        calibrate(pairs[:3])
    assert parse_pattern("9X6") == (9, 6)


def test_misaligned_frames_are_undone_by_their_maps():
    from sim.model.rectify import compress_map, map_size
    from sim.model.ycbcr import ycbcr422_to_444, ycbcr444_to_422
    rng = np.random.default_rng(2)
    y = cv2.GaussianBlur(rng.integers(0, 256, (48, 64)).astype(np.uint8), (5, 5), 1.5)
    frame = ycbcr444_to_422(y, np.full_like(y, 100), np.full_like(y, 150))[None]
    hom = misalignment(64, 48, roll=1.0, shift_y=1.5)
    warped = misalign_frames(frame, hom)
    assert np.abs(ycbcr422_to_444(warped[0])[0].astype(int) - y).mean() > 5
    grid = compress_map(*homography_maps(hom, *map_size(64, 48, 8)), 64, 48)
    back = rectify(ycbcr422_to_444(warped[0])[0], grid)
    inner = (slice(6, -6), slice(6, -6))
    assert np.abs(back[inner].astype(int) - y[inner]).mean() < 2


def test_cli_chessboards_calibrate_and_stereo(tmp_path, capsys):
    folder = tmp_path / "boards"
    assert cli.main(["chessboards", "-o", str(folder), "--count", "6", "--seed", "3"]) == 0
    assert len(list(folder.glob("left_*.png"))) == len(list(folder.glob("right_*.png"))) == 6
    assert cli.main(["calibrate", str(folder), "-o", str(tmp_path / "c.json")]) == 0
    report = json.loads(capsys.readouterr().out.strip().splitlines()[-1])
    assert report["pairs"] == 6 and report["rms_px"] < 0.3
    assert abs(report["baseline_mm"] - 60.03) < 0.5
    calib = load_calibration(tmp_path / "c.json")
    assert calib.pairs == 6
    assert cli.main(["stereo", str(folder / "left_00.png"), str(folder / "right_00.png"),
                     "-o", str(tmp_path / "d.png"), "--calibration", str(tmp_path / "c.json"),
                     "--max-disparity", "64", "--hamming-window", "9"]) == 0


def test_chessboards_writes_the_rigs_true_calibration(tmp_path, capsys):
    """--truth: the rig's own calibration, the maps every figure of the default rig uses."""
    from sim.calibration import StereoRig, rig_calibration, stereo_rectification
    truth = tmp_path / "truth.json"
    assert cli.main(["chessboards", "-o", str(tmp_path / "b"), "--count", "1",
                     "--truth", str(truth), "--json"]) == 0
    assert json.loads(capsys.readouterr().out.strip().splitlines()[-1])["truth"] == str(truth)
    ours = stereo_rectification(load_calibration(truth), 640, 480)
    expected = stereo_rectification(rig_calibration(StereoRig()), 640, 480)
    assert ours.max_shift == expected.max_shift
    for side in ("left", "right"):
        for grid in ("dx", "dy"):
            np.testing.assert_array_equal(getattr(getattr(ours, side), grid),
                                          getattr(getattr(expected, side), grid))


def test_calibrate_reads_a_clip_of_chessboard_pairs(pairs, tmp_path, capsys):
    """`stereogest clip` records the pairs as a clip; calibrate takes it."""
    from sim.clip import Clip, save_clip
    from sim.model.ycbcr import ycbcr444_to_422
    grey = np.full_like(pairs[0][0], 128)

    def frames(side):
        return np.stack([ycbcr444_to_422(p[side], grey, grey) for p in pairs[:6]])

    save_clip(Clip(fps=5, left=frames(0), right=frames(1)), tmp_path / "boards")
    assert cli.main(["calibrate", str(tmp_path / "boards"), "-o", str(tmp_path / "c.json")]) == 0
    report = json.loads(capsys.readouterr().out.strip().splitlines()[-1])
    assert report["pairs"] == report["offered"] == 6 and report["rms_px"] < 0.3


def test_pipeline_command_rectifies_with_a_calibration(tmp_path, capsys):
    """`stereogest pipeline --calibration`: a clip seen through a small rig,
    rectified with its calibration, gives the trajectory of the model run with
    that rectification (and not the unrectified one)."""
    from sim.clip import Clip, save_clip
    from sim.model.pipeline import PipelineParams, run_clip
    from sim.render import render_clip
    rig = StereoRig().resized(320, 240)
    calib = rig_calibration(rig)
    save_calibration(calib, tmp_path / "c.json")
    clip = render_clip("stop", 3, 320, 240, n_pre_rest=1, n_motion=2, n_post_rest=0)
    left, right = camera_frames(clip.left, calib, "left"), camera_frames(clip.right, calib, "right")
    save_clip(Clip(fps=clip.fps, left=left, right=right), tmp_path / "clip")
    assert cli.main(["pipeline", str(tmp_path / "clip"), "-o", str(tmp_path / "out"), "--quiet",
                     "--calibration", str(tmp_path / "c.json")]) == 0
    rows = (tmp_path / "out" / "trajectory.csv").read_text().splitlines()
    params = PipelineParams.for_frame(320)
    ours, _ = run_clip(left, right, params, rectification=stereo_rectification(calib))
    plain, _ = run_clip(left, right, params)
    scale = 1 << params.frac_bits
    expected = [f"{n},{x / scale:.4f},{y / scale:.4f},{int(f)},{int(sym)}" for n, ((x, y), f, sym)
                in enumerate(zip(ours.smoothed, ours.flag, ours.symbol))]
    assert rows[1:] == expected
    assert (ours.area > 0).all() and not np.array_equal(ours.centroid, plain.centroid)


def test_demo_renders_through_the_calibrated_rig_and_rectifies(tmp_path, capsys):
    """`stereogest demo --calibration` (model backend): the rendered gesture as the
    calibrated cameras see it, rectified back, recognised."""
    save_calibration(rig_calibration(StereoRig().resized(320, 240)), tmp_path / "c.json")
    assert cli.main(["demo", "--backend", "model", "--gesture", "stop", "--seed", "2",
                     "--width", "320", "--height", "240", "-o", str(tmp_path / "out"),
                     "--quiet", "--calibration", str(tmp_path / "c.json")]) == 0
    report = json.loads(capsys.readouterr().out.strip().splitlines()[-1])
    assert report["recognised"] == "stop"
