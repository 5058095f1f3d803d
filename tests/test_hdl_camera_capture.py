# amaranth: UnusedElaboratable=no
"""hdl/camera_capture.py (thesis §5.2): the OV5642 waveform model (sim/camera.py)
and CameraCapture against its golden model ``capture_words``, cycle by cycle,
clean and with every link fault. The two captures feeding the
StereoSynchronizer: tests/test_hdl_stereo_sync.py."""
import numpy as np
import pytest
from amaranth.sim import Simulator

from hdl.camera_capture import CameraCapture
from sim.camera import (CLOCK_STOPPED, CameraTiming, camera_waveform, capture_words,
                        cut_frame, href_glitch, pack_pins, stop_clock, stop_frame,
                        vsync_in_line)

W, H = 24, 6
TIMING = CameraTiming(vsync_cycles=100, front_porch=20, hblank=16, back_porch=30)
CAM_NS = 20
VSYNC_BIT = 1 << 9


def _frames(count, seed, h=H, w=W):
    return np.random.default_rng(seed).integers(0, 256, (count, h, 2 * w), dtype=np.uint8)


def _run_capture(wave, width=W, height=H, *, start=None, pause=None, ready=None):
    """Drive one CameraCapture cycle by cycle from ``wave``; ``start``/``pause``: per
    cycle arrays (default 1 / 0), ``ready(count)``: ready for the count-th word.
    Returns (words as (cycle, sof, sol, luma, chroma, x_after, y_after), dut counters)."""
    dut = CameraCapture(width, height)
    pins = (pack_pins(wave).tolist()
            + [VSYNC_BIT] * 8)
    n = len(pins)
    start = np.ones(n, int) if start is None else start
    pause = np.zeros(n, int) if pause is None else pause
    words, result = [], {}

    async def tb(ctx):
        o = dut.o_stream
        for c in range(n):
            ctx.set(dut.vsync, pins[c] >> 9)
            ctx.set(dut.href, (pins[c] >> 8) & 1)
            ctx.set(dut.data, pins[c] & 0xFF)
            ctx.set(dut.start, int(start[min(c, len(start) - 1)]))
            ctx.set(dut.pause, int(pause[min(c, len(pause) - 1)]))
            if ctx.get(o.valid):
                ok = 1 if ready is None else int(ready(len(words)))
                ctx.set(o.ready, ok)
                p = o.payload
                words.append((c, ctx.get(p.sof), ctx.get(p.sol), ctx.get(p.luma),
                              ctx.get(p.chroma), ctx.get(dut.x), ctx.get(dut.y), ok))
            else:
                ctx.set(o.ready, 1)
            await ctx.tick()
        result.update(frames=ctx.get(dut.frames), overruns=ctx.get(dut.overruns))

    sim = Simulator(dut)
    sim.add_clock(CAM_NS * 1e-9)
    sim.add_testbench(tb)
    sim.run()
    return words, result


def _model_rows(model):
    return [(int(w["cycle"]) + CameraCapture.latency, int(w["sof"]), int(w["sol"]),
             int(w["luma"]), int(w["chroma"]), int(w["x"]) + 1, int(w["y"]), 1)
            for w in model]


def test_capture_model_of_a_clean_frame():
    """The golden model itself, against the frames: raster words, crop of x and y."""
    cams = _frames(2, 5, h=5, w=28)
    wave = camera_waveform(cams, CameraTiming(8, 0, 4, 0), start_delay=3)
    words = capture_words(wave, 24, 4)
    assert len(words) == 2 * 24 * 4
    for f in range(2):
        sel = words[f * 96:(f + 1) * 96]
        pairs = cams[f, :4, :48].reshape(4, 24, 2)
        assert (sel["luma"] == pairs[:, :, 0].ravel()).all()
        assert (sel["chroma"] == pairs[:, :, 1].ravel()).all()
        xs, ys = np.meshgrid(np.arange(24), np.arange(4))
        assert (sel["x"] == xs.ravel()).all() and (sel["y"] == ys.ravel()).all()
        assert (sel["sol"] == (xs.ravel() == 0)).all()
        assert sel["sof"].tolist() == [1] + [0] * 95


def test_capture_model_of_faults():
    cams = _frames(3, 6, h=4, w=8)
    wave = camera_waveform(cams, CameraTiming(6, 2, 3, 2))
    # HREF low on the Cr byte 5 of line 1: pixel 2 lost, bytes 6.. start line 2
    words = capture_words(href_glitch(wave, 0, 1, 5), 8, 4)
    words = words[words["cycle"] < wave.frame_end[0]]
    assert len(words) == 8 + 2 + 5 + 8  # line 3 of the camera is cropped (y = 4)
    line1 = words[(words["y"] == 1)]
    assert line1["x"].tolist() == [0, 1]
    line2 = words[(words["y"] == 2)]
    assert line2["sol"][0] == 1 and line2["luma"][0] == cams[0, 1, 6]
    assert line2["chroma"][0] == cams[0, 1, 7] and len(line2) == 5
    # VSYNC inside line 2 of frame 1: the frame ends there and no frame starts after it
    words = capture_words(vsync_in_line(wave, 1, 2, 4), 8, 4)
    assert (words["sof"] == 1).sum() == 3
    f1 = words[(words["cycle"] > wave.vsync_start[1]) & (words["cycle"] < wave.frame_end[1])]
    assert len(f1) == 2 * 8 + 2
    # frame cut at line 2, frame stopped: the others complete
    words = capture_words(stop_frame(cut_frame(wave, 0, 2), 1), 8, 4)
    assert len(words) == 2 * 8 + 32 and (words["sof"] == 1).sum() == 2


def test_capture_model_of_a_stopped_clock():
    """PCLK stopped: the receiver sees nothing of those cycles. In a line the
    bytes are lost (the line comes short); in the blanking nothing is; the pins
    carry the stop as CLOCK_STOPPED."""
    cams = _frames(2, 8, h=4, w=8)
    wave = camera_waveform(cams, CameraTiming(6, 2, 3, 2))
    clean = capture_words(wave, 8, 4)
    c = wave.cycle(0, 1, 4)
    stopped = stop_clock(wave, c, 4)            # pixels 2 and 3 of line 1
    words = capture_words(stopped, 8, 4)
    assert len(words) == len(clean) - 2
    assert stopped.faults == [f"stop_clock(cycle={c}, length=4)"]
    line1 = words[(words["y"] == 1) & (words["cycle"] < wave.frame_end[0])]
    assert line1["x"].tolist() == list(range(6))
    assert line1["luma"][2] == cams[0, 1, 8]     # pixel 4's bytes arrive as pixel 2
    pins = pack_pins(stopped)
    assert ((pins & CLOCK_STOPPED) != 0).sum() == 4 and pins[c] & CLOCK_STOPPED
    assert not (pack_pins(wave) & CLOCK_STOPPED).any()
    # inside the vertical blanking the frame is untouched
    blank = stop_clock(wave, int(wave.vsync_start[1]) + 1, 3)
    same = capture_words(blank, 8, 4)
    assert (same[["sof", "sol", "luma", "chroma", "x", "y"]]
            == clean[["sof", "sol", "luma", "chroma", "x", "y"]]).all()
    with pytest.raises(ValueError, match="length"):
        stop_clock(wave, len(wave) - 2, 3)


def test_capture_matches_model_with_crop_and_faults():
    cams = _frames(6, 7, h=5, w=14)
    wave = camera_waveform(cams, CameraTiming(12, 3, 5, 4), start_delay=5)
    wave = href_glitch(wave, 0, 1, 7)          # odd byte: a lone luma dropped
    wave = href_glitch(wave, 0, 3, 12)         # even byte
    wave = vsync_in_line(wave, 1, 2, 9, 4)
    wave = cut_frame(wave, 2, 3)
    wave = stop_frame(wave, 3)
    wave = href_glitch(wave, 4, 4, 0)
    words, result = _run_capture(wave, 12, 4)
    model = capture_words(wave, 12, 4)
    assert len(model) > 150
    assert words == _model_rows(model)
    assert result == {"frames": 5, "overruns": 0}


def test_capture_start_and_pause():
    cams = _frames(5, 8, h=3, w=8)
    wave = camera_waveform(cams, CameraTiming(10, 2, 4, 3))
    n = len(wave)
    mid = [int(wave.line_start[f, 1]) for f in range(5)]
    start = np.zeros(n, int)
    start[mid[0]:mid[4]] = 1                   # rises in frame 0, falls in frame 4
    pause = np.zeros(n, int)
    pause[mid[1]:mid[2]] = 1                   # raised in frame 1, dropped in frame 2
    words, result = _run_capture(wave, 8, 3, start=start, pause=pause)
    ref = _model_rows(capture_words(wave, 8, 3))
    per_frame = 24
    # frame 1 completes despite the pause, frame 2 is skipped, frame 3 captured whole
    expect = ref[per_frame:2 * per_frame] + ref[3 * per_frame:4 * per_frame]
    assert words[:2 * per_frame] == expect
    # start falls during line 1 of frame 4: line 0 and at most a pair more get through
    tail = words[2 * per_frame:]
    assert tail == ref[4 * per_frame:4 * per_frame + len(tail)]
    assert 8 <= len(tail) <= 9
    assert result == {"frames": 3, "overruns": 0}


def test_capture_overrun_waits_for_next_frame():
    cams = _frames(3, 9, h=3, w=8)
    wave = camera_waveform(cams, CameraTiming(10, 2, 4, 3))
    ref = _model_rows(capture_words(wave, 8, 3))
    words, result = _run_capture(wave, 8, 3, ready=lambda k: k != 5)
    # word 5 of frame 0 is refused: the rest of frame 0 is not emitted at all
    assert [w[-1] for w in words] == [1] * 5 + [0] + [1] * 48
    assert [w[:-1] for w in words[:6]] == [r[:-1] for r in ref[:6]]
    assert [w[:-1] for w in words[6:]] == [r[:-1] for r in ref[24:]]
    assert words[6][1] == 1  # a clean sof next
    assert result == {"frames": 3, "overruns": 1}


# ------------------------------------------------------------------ waveform model


def test_waveform_layout_and_pins():
    cams = _frames(2, 10, h=2, w=4)
    t = CameraTiming(vsync_cycles=3, front_porch=2, hblank=1, back_porch=4)
    wave = camera_waveform(cams, t, start_delay=5)
    period = 3 + 2 + 2 * 8 + 1 + 4
    assert t.frame_cycles(4, 2) == period
    assert len(wave) == 5 + 2 * period + 3
    assert wave.vsync_start.tolist() == [5, 5 + period]
    assert wave.line_start[0].tolist() == [10, 19]
    assert (wave.data[wave.valid] == cams.reshape(-1)).all()
    expect_vsync = np.r_[[1] * 8, [0] * 23, [1] * 3, [0] * 23, [1] * 3].astype(bool)
    assert (wave.vsync == expect_vsync).all()
    pins = pack_pins(wave)
    assert pins.dtype == np.uint16
    assert ((pins >> 9) == wave.vsync).all() and (((pins >> 8) & 1) == wave.href).all()
    assert ((pins & 0xFF) == wave.data).all()
    # faults keep the length and the schedule of the following frame
    for damaged in (cut_frame(wave, 0, 1), href_glitch(wave, 0, 0, 3),
                    vsync_in_line(wave, 0, 1, 2), stop_frame(wave, 0)):
        assert len(damaged) == len(wave)
        sl = slice(int(wave.vsync_start[1]), None)
        assert (damaged.vsync[sl] == wave.vsync[sl]).all()
        assert (damaged.href[sl] == wave.href[sl]).all()
        assert damaged.faults and not wave.faults
    assert cut_frame(wave, 0, 1).vsync[19:wave.frame_end[0]].all()
    assert vsync_in_line(wave, 0, 1, 2).vsync[21:24].all()
    assert not href_glitch(wave, 0, 0, 3).href[13]


# ------------------------------------------------------------------ parameters


@pytest.mark.parametrize("make, name", [
    (lambda: CameraCapture(9, 4), "width must be even"),
    (lambda: CameraCapture(6, 4), "width"),
    (lambda: CameraCapture(16, 1), "height"),
    (lambda: CameraTiming(vsync_cycles=0), "vsync_cycles"),
    (lambda: CameraTiming(front_porch=-1), "front_porch"),
    (lambda: CameraTiming(hblank=0), "hblank"),
    (lambda: CameraTiming(back_porch=1.5), "back_porch"),
    (lambda: camera_waveform(np.zeros((2, 6), np.uint8)), "multiple of 4"),
    (lambda: camera_waveform(np.zeros((2, 8), np.int16) - 1), "frames"),
    (lambda: camera_waveform([np.zeros((2, 8), np.uint8), np.zeros((3, 8), np.uint8)]),
     "same shape|share one shape"),
    (lambda: camera_waveform(np.zeros((2, 8), np.uint8), start_delay=-1), "start_delay"),
    (lambda: camera_waveform(np.zeros((2, 8), np.uint8), timing=(1, 2)), "timing"),
    (lambda: cut_frame(camera_waveform(np.zeros((2, 8), np.uint8)), 1, 0), "frame"),
    (lambda: href_glitch(camera_waveform(np.zeros((2, 8), np.uint8)), 0, 2, 0), "line"),
    (lambda: href_glitch(camera_waveform(np.zeros((2, 8), np.uint8)), 0, 0, 8), "byte"),
    (lambda: vsync_in_line(camera_waveform(np.zeros((2, 8), np.uint8)), 0, 0, 6, 3),
     "length"),
])
def test_bad_parameters_raise_naming_them(make, name):
    with pytest.raises(ValueError, match=name):
        make()
