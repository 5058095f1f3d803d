"""Footage as clips (sim/footage.py, `stereogest clip`): the colour conversion
against OpenCV's, video files and image sequences the tests encode from
rendered clips, a fake webcam pair, and bad input."""
from __future__ import annotations

import json

import cv2
import numpy as np
import pytest

from sim.clip import load_clip
from sim.footage import bgr_to_ycbcr, footage_clip, frame_to_422, frame_to_bgr
from sim.model.ycbcr import ycbcr444_to_422
from stereogest.cli import main


def test_conversion_equals_opencv_bt601_full_range():
    rng = np.random.default_rng(0)
    image = rng.integers(0, 256, (256, 1024, 3), dtype=np.uint8)
    image[0, :8] = [[0, 0, 0], [255, 255, 255], [0, 0, 255], [0, 255, 0], [255, 0, 0],
                    [255, 255, 0], [0, 255, 255], [255, 0, 255]]
    ref = cv2.cvtColor(image, cv2.COLOR_BGR2YCrCb)
    y, cb, cr = bgr_to_ycbcr(image)
    assert np.array_equal(y, ref[:, :, 0])
    assert np.array_equal(cr, ref[:, :, 1])
    assert np.array_equal(cb, ref[:, :, 2])
    # full range: white is 255, black 0, grey has neutral chroma
    assert (y[0, 0], y[0, 1], cb[0, 1], cr[0, 1]) == (0, 255, 128, 128)


def test_frame_to_422_resizes_then_packs():
    rng = np.random.default_rng(1)
    image = rng.integers(0, 256, (90, 130, 3), dtype=np.uint8)
    got = frame_to_422(image, 96, 64)
    small = cv2.resize(image, (96, 64), interpolation=cv2.INTER_AREA)
    assert got.shape == (64, 192) and got.dtype == np.uint8
    assert np.array_equal(got, ycbcr444_to_422(*bgr_to_ycbcr(small)))
    # grey, BGRA and 16-bit images are accepted too
    assert frame_to_422(image[:, :, 0], 96, 64).shape == (64, 192)
    assert frame_to_422(np.dstack([image, image[:, :, :1]]), 96, 64).shape == (64, 192)
    assert frame_to_422(image.astype(np.uint16) << 8, 96, 64).shape == (64, 192)


@pytest.fixture(scope="module")
def rendered():
    from sim.render import render_clip
    return render_clip("stop", 2, 160, 120, n_pre_rest=2, n_motion=6, n_post_rest=0)


def write_video(path, frames, fps=30):
    height, width = frames[0].shape[0], frames[0].shape[1] // 2
    writer = cv2.VideoWriter(str(path), cv2.VideoWriter_fourcc(*"MJPG"), fps,
                             (width, height))
    assert writer.isOpened()
    for frame in frames:
        writer.write(frame_to_bgr(frame))
    writer.release()


def test_video_files_make_a_clip_near_the_rendered_one(tmp_path, rendered, capsys):
    write_video(tmp_path / "left.avi", rendered.left, fps=25)
    write_video(tmp_path / "right.avi", rendered.right, fps=25)
    out = tmp_path / "clip"
    assert main(["clip", "--left", str(tmp_path / "left.avi"), "--right",
                 str(tmp_path / "right.avi"), "-o", str(out), "--width", "160",
                 "--height", "120", "--json", "--quiet"]) == 0
    result = json.loads(capsys.readouterr().out.strip().splitlines()[-1])
    assert result == {"clip": str(out), "frames": rendered.frames, "width": 160,
                      "height": 120, "fps": 25, "gesture": None}
    clip = load_clip(out)
    assert not clip.has_truth and clip.fps == 25
    assert "BT.601" in clip.source["conversion"] and "left.avi" in clip.source["left"]
    # MJPEG is lossy (and smooths the sensor noise): a few grey levels on average;
    # a wrong matrix (studio range, Cb and Cr swapped) is off by tens
    for got, ref in ((clip.left, rendered.left), (clip.right, rendered.right)):
        luma = np.abs(got[:, :, 0::2].astype(int) - ref[:, :, 0::2]).mean()
        chroma = np.abs(got[:, :, 1::2].astype(int) - ref[:, :, 1::2]).mean()
        assert luma < 5.0 and chroma < 5.0, (luma, chroma)


def test_image_folder_and_glob_give_the_same_clip(tmp_path, rendered):
    for side in ("left", "right"):
        (tmp_path / side).mkdir()
        for n, frame in enumerate(getattr(rendered, side)):
            cv2.imwrite(str(tmp_path / side / f"{side}_{n:03d}.png"), frame_to_bgr(frame))
    (tmp_path / "left" / "notes.txt").write_text("not an image")
    a = footage_clip(str(tmp_path / "left"), str(tmp_path / "right"), width=160, height=120)
    b = footage_clip(str(tmp_path / "left" / "left_*.png"),
                     str(tmp_path / "right" / "right_*.png"), width=160, height=120,
                     frames=4, gesture="stop")
    assert a.frames == rendered.frames and a.fps == 30
    assert np.array_equal(a.left[:4], b.left) and np.array_equal(a.right[:4], b.right)
    assert b.frames == 4 and b.gesture == "stop"
    image = cv2.imread(str(tmp_path / "right" / "right_003.png"))
    assert np.array_equal(a.right[3], frame_to_422(image, 160, 120))


class FakeCamera:
    """cv2.VideoCapture for camera indices: frames of a colour per camera;
    records the order of grab/retrieve calls of both cameras."""
    calls: list = []

    def __init__(self, index):
        self.index, self.count = index, 0

    def isOpened(self):
        return self.index in (0, 1)

    def grab(self):
        FakeCamera.calls.append(("grab", self.index))
        self.count += 1
        return True

    def retrieve(self):
        FakeCamera.calls.append(("retrieve", self.index))
        frame = np.zeros((48, 64, 3), np.uint8)
        frame[:, :, self.index] = 10 * self.count
        return True, frame

    def get(self, prop):
        return 0.0

    def release(self):
        pass


def test_two_webcams_are_read_in_lockstep(tmp_path, monkeypatch, capsys):
    monkeypatch.setattr(cv2, "VideoCapture", FakeCamera)
    FakeCamera.calls = []
    out = tmp_path / "cams"
    assert main(["clip", "--left", "0", "--right", "1", "-o", str(out), "--width", "96",
                 "--height", "64", "--frames", "3", "--quiet"]) == 0
    clip = load_clip(out)
    assert clip.frames == 3 and clip.source["left"] == "camera 0"
    assert FakeCamera.calls[:4] == [("grab", 0), ("grab", 1), ("retrieve", 0),
                                    ("retrieve", 1)]
    # frame k of camera 0 is blue 10 * (k + 1): Cb above neutral and rising
    cb = clip.left[:, 0, 1]
    assert cb[0] > 128 and list(cb) == sorted(cb)
    # a camera needs --frames; an unknown index cannot be opened
    assert main(["clip", "--left", "0", "--right", "1", "-o", str(tmp_path / "x")]) == 2
    assert "--frames is required with a camera" in capsys.readouterr().err
    assert main(["clip", "--left", "0", "--right", "7", "-o", str(tmp_path / "x"),
                 "--frames", "2"]) == 2
    assert "--right: camera 7 cannot be opened" in capsys.readouterr().err
    assert not (tmp_path / "x").exists()


@pytest.mark.parametrize("args, message", [
    (["--left", "{missing}", "--right", "{video}"], "--left: '"),
    (["--left", "{video}", "--right", "{text}"], "--right: "),
    (["--left", "{video}", "--right", "{video}", "--width", "95"], "--width must be"),
    (["--left", "{video}", "--right", "{video}", "--width", "97"], "--width must be even"),
    (["--left", "{video}", "--right", "{video}", "--height", "5000"], "--height must be"),
    (["--left", "{video}", "--right", "{video}", "--frames", "0"], "--frames must be"),
    (["--left", "{video}", "--right", "{video}", "--fps", "0"], "--fps must be"),
    (["--left", "{empty}", "--right", "{video}"], "--left: folder"),
    (["--left", "{tmp}/nothing_*.png", "--right", "{video}"], "--left: no file matches"),
])
def test_bad_input_is_one_line_and_writes_nothing(tmp_path, rendered, capsys, args, message):
    write_video(tmp_path / "v.avi", rendered.left[:2])
    (tmp_path / "t.avi").write_text("not a video")
    (tmp_path / "empty").mkdir()
    names = {"missing": tmp_path / "nope.avi", "video": tmp_path / "v.avi",
             "text": tmp_path / "t.avi", "empty": tmp_path / "empty", "tmp": tmp_path}
    argv = ["clip", *[a.format(**names) for a in args], "-o", str(tmp_path / "out")]
    for option, value in (("--width", "96"), ("--height", "64")):
        if option not in args:
            argv += [option, value]
    assert main(argv) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and message in err and "Traceback" not in err
    assert not (tmp_path / "out").exists()


def test_pipeline_names_the_gesture_of_footage(tmp_path, capsys):
    """A whole rendered gesture, encoded as two MJPEG videos, made a clip and
    run through the golden model and the shipped HMMs."""
    from sim.render import render_clip
    clip = render_clip("rotate-right", 1, 320, 240, n_pre_rest=10)
    write_video(tmp_path / "left.avi", clip.left)
    write_video(tmp_path / "right.avi", clip.right)
    assert main(["clip", "--left", str(tmp_path / "left.avi"), "--right",
                 str(tmp_path / "right.avi"), "-o", str(tmp_path / "clip"), "--width", "320",
                 "--height", "240", "--quiet"]) == 0
    assert main(["pipeline", str(tmp_path / "clip"), "-o", str(tmp_path / "out"), "--json",
                 "--quiet"]) == 0
    lines = capsys.readouterr().out.strip().splitlines()
    result = json.loads(lines[-1])
    assert result["gesture"] is None and result["frames"] == clip.frames
    assert result["recognised"] == "rotate-right"
    assert "recognised: rotate-right" in "\n".join(lines)
    summary = json.loads((tmp_path / "out" / "summary.json").read_text())
    assert summary["recognised"] == "rotate-right"
    # the default stage pictures of a clip without truth: first, middle, last frame
    last = clip.frames - 1
    assert (tmp_path / "out" / f"frame_{last:04d}_opening.png").exists()
    assert (tmp_path / "out" / "frame_0000_left.png").exists()


def test_demo_runs_a_given_clip(tmp_path, rendered, capsys):
    """`demo --clip` with footage (no truth) on the golden-model backend."""
    write_video(tmp_path / "l.avi", rendered.left)
    write_video(tmp_path / "r.avi", rendered.right)
    assert main(["clip", "--left", str(tmp_path / "l.avi"), "--right", str(tmp_path / "r.avi"),
                 "-o", str(tmp_path / "clip"), "--width", "160", "--height", "120",
                 "--gesture", "stop", "--quiet"]) == 0
    capsys.readouterr()
    # labelled stop, but 8 frames flag no gesture: the demo fails its label (exit 1)
    assert main(["demo", "--clip", str(tmp_path / "clip"), "--backend", "model", "-o",
                 str(tmp_path / "out"), "--quiet"]) == 1
    out, err = capsys.readouterr()
    assert err == "stereogest demo: error: the clip shows stop but the board application " \
                  "recognised nothing\n"
    lines = out.strip().splitlines()
    report = json.loads(lines[-1])
    assert report["gesture"] == "stop" and report["frames"] == rendered.frames
    assert report["width"] == 160 and "recognised" in report
    assert f"clip {tmp_path / 'clip'}: {rendered.frames} frames of 160x120, labelled stop" \
        in lines[0]
    assert not (tmp_path / "out" / "clip").exists()          # nothing rendered
    assert main(["demo", "--clip", str(tmp_path / "nowhere"), "--backend", "model", "-o",
                 str(tmp_path / "out2")]) == 2
    assert "not a clip directory" in capsys.readouterr().err


def test_pipeline_spotting_options_and_warnings(tmp_path, rendered, capsys):
    from dataclasses import replace

    from sim.clip import save_clip
    path = save_clip(rendered, tmp_path / "small")
    assert main(["pipeline", str(path), "-o", str(tmp_path / "o1"), "--spot-hold", "0"]) == 2
    err = capsys.readouterr().err
    assert err.strip() == "stereogest pipeline: error: --spot-hold must be in [1, 255], got 0"
    assert not (tmp_path / "o1").exists()
    # at 160x120 the hand's disparity falls below the band: a warning, not an error
    assert main(["pipeline", str(path), "-o", str(tmp_path / "o2"), "--spot-threshold", "3",
                 "--quiet", "--json"]) == 0
    captured = capsys.readouterr()
    assert "warning: no hand found in any of 8 frames at 160x120: skin and the disparity " \
        "band never overlap" in captured.err
    result = json.loads(captured.out.strip().splitlines()[-1])
    assert result["recognised"] is None and result["gesture"] == "stop"
    summary = json.loads((tmp_path / "o2" / "summary.json").read_text())
    assert summary["params"]["spot_threshold"] == 3 and summary["clip"] == str(path)
    # the same picture for both cameras: skin is found, the band is not
    same = save_clip(replace(rendered, right=rendered.left), tmp_path / "same")
    assert main(["pipeline", str(same), "-o", str(tmp_path / "o3"), "--quiet"]) == 0
    err = capsys.readouterr().err
    assert "the disparity band is empty" in err and "same picture" in err, err


def test_the_hint_names_the_stage_that_lost_the_hand():
    from types import SimpleNamespace

    from sim.model.pipeline import PipelineParams
    from stereogest.pipeline_outputs import lost_stage
    none, some = np.zeros((4, 4), bool), np.ones((4, 4), bool)
    params = PipelineParams()

    def stages(skin, band, hand):
        return [SimpleNamespace(skin=skin, band=band, hand=hand)]
    assert lost_stage(stages(none, some, none), params).startswith("the skin mask is empty")
    assert lost_stage(stages(some, none, none), params).startswith("the disparity band is empty")
    assert lost_stage(stages(some, some, none), params).startswith("skin and the disparity band")
    assert lost_stage(stages(some, some, some), params).startswith("the 11x11 opening erased")
