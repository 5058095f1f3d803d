# amaranth: UnusedElaboratable=no
"""The whole GesturePipeline (camera pins to per-frame records) against the
golden model: a small frame in Amaranth's simulator with three clock domains,
and (tests/test_hdl_pipeline_verilator.py) full frames under Verilator."""
import dataclasses

import numpy as np
import pytest
from amaranth.hdl import ClockDomain, Module
from amaranth.sim import Simulator

from hdl.gesture_pipeline import VIDEO_STAGES, GesturePipeline
from sim.camera import CameraTiming, camera_waveform
from sim.model.pipeline import PipelineParams, process_frame, track
from soc.hps_interface import POSTURE_WORD_COUNT
from sim.model.ycbcr import ycbcr444_to_422

SMALL = PipelineParams(census_window=3, hamming_window=3, max_disparity=8, lrcc_threshold=2,
                       band_low=1, band_high=6, opening_size=3, average_window=2,
                       spot_window=2, spot_threshold=1, spot_hold=2)


def small_frames(n, width=32, height=16, seed=0):
    """Textured stereo pairs (right = left shifted by 3 pixels) with a skin-coloured
    rectangle that moves; returns the cameras' 4:2:2 byte frames."""
    rng = np.random.default_rng(seed)
    lefts, rights = [], []
    for k in range(n):
        texture = rng.integers(0, 256, (height, width + 8)).astype(np.uint8)
        y_left = texture[:, 3:3 + width]
        y_right = texture[:, :width]
        cb = np.full((height, width), 150, np.uint8)
        cr = np.full((height, width), 100, np.uint8)
        x0, y0 = 6 + 3 * k, 4 + (k % 2)
        cb[y0:y0 + 8, x0:x0 + 10] = 100
        cr[y0:y0 + 8, x0:x0 + 10] = 150
        lefts.append(ycbcr444_to_422(y_left, cb, cr))
        rights.append(ycbcr444_to_422(y_right, np.full_like(cb, 128), np.full_like(cr, 128)))
    return lefts, rights


def golden(lefts, rights, params, rectification=None):
    """Model records: per-frame centroid and area, then moving average and spotting."""
    stages = []
    for left, right in zip(lefts, rights):
        stages.append(process_frame(left, right, params, rectification=rectification,
                                    **(stages[-1].following() if stages else {})))
    cents = np.array([[s.centroid.x, s.centroid.y] for s in stages])
    areas = np.array([s.centroid.area for s in stages])
    return stages, cents, areas, track(cents, areas, params)


def run_amaranth(dut, left_wave, right_wave, sync_cycles, video=False):
    m = Module()
    m.domains += [ClockDomain("sync"), ClockDomain("cam_left"), ClockDomain("cam_right")]
    m.submodules.dut = dut
    sim = Simulator(m)
    sim.add_clock(10e-9, domain="sync")
    sim.add_clock(5e-9, phase=1.3e-9, domain="cam_left")
    sim.add_clock(5e-9, phase=3.7e-9, domain="cam_right")
    records, pixels, words = [], [], []
    layout = dut.o_stream.payload.shape()

    def driver(pins, wave, domain):
        async def bench(ctx):
            for v, h, d in zip(wave.vsync, wave.href, wave.data):
                ctx.set(pins.vsync, int(v))
                ctx.set(pins.href, int(h))
                ctx.set(pins.data, int(d))
                await ctx.tick(domain)
            ctx.set(pins.vsync, 1)
        return bench

    async def collect(ctx):
        payload = dut.o_stream.payload
        for _ in range(sync_cycles):
            await ctx.tick()
            if ctx.get(dut.o_stream.valid):
                records.append({name: ctx.get(getattr(payload, name))
                                for name in layout.members})
            if ctx.get(dut.o_posture.valid):
                words.append((ctx.get(dut.o_posture.payload.index),
                              ctx.get(dut.o_posture.payload.word)))
            if video and ctx.get(dut.o_video.valid):
                pixels.append((ctx.get(dut.o_video.payload.first),
                               ctx.get(dut.o_video.payload.pixel)))

    sim.add_testbench(driver(dut.left, left_wave, "cam_left"), background=True)
    sim.add_testbench(driver(dut.right, right_wave, "cam_right"), background=True)
    sim.add_testbench(collect)
    sim.run()
    run_amaranth.posture_words = words
    return records, pixels


def posture_records(words):
    """The o_posture beats ``(index, word)`` as one list of words per frame."""
    indices = [i for i, _ in words]
    assert indices == list(range(POSTURE_WORD_COUNT)) * (len(words) // POSTURE_WORD_COUNT)
    flat = [w for _, w in words]
    return [flat[k:k + POSTURE_WORD_COUNT] for k in range(0, len(flat), POSTURE_WORD_COUNT)]


def small_rectification(width=32, height=16):
    """Both cameras rolled and shifted by a pixel or two (tests/test_model_rectify.py)."""
    from sim.model.rectify import StereoRectification
    from tests.test_model_rectify import grid_of, rotation_homography
    return StereoRectification(
        grid_of(rotation_homography(width, height, 0.8, 0.4, 0.6), width, height, 4, 4),
        grid_of(rotation_homography(width, height, -0.6, -0.3, -0.5), width, height, 4, 4))


#: SMALL with the centroid's hand tracking (sim.model.centroid): a gate the
#: moving rectangle stays in, and its top rows; the posture's window about it.
TRACKING = dataclasses.replace(SMALL, track_gate=7, hand_rows=3, posture_gate=6)


@pytest.mark.parametrize("rectified, params", [(False, SMALL), (True, SMALL),
                                               (False, TRACKING)])
def test_small_pipeline_equals_golden_model(rectified, params):
    width, height, n = 32, 16, 4
    lefts, rights = small_frames(n, width, height)
    rectification = small_rectification(width, height) if rectified else None
    dut = GesturePipeline(width, height, params, rectification=rectification, fifo_depth=256,
                          sync_threshold=8)
    timing = CameraTiming(vsync_cycles=8, front_porch=2 * dut.flush + 64, hblank=12,
                          back_porch=2 * dut.flush)
    left_wave = camera_waveform(lefts, timing, start_delay=40)
    right_wave = camera_waveform(rights, timing, start_delay=130)
    cycles = len(left_wave.vsync) // 2 + dut.record_cycles + 400
    records, _ = run_amaranth(dut, left_wave, right_wave, cycles)
    stages, cents, areas, traj = golden(lefts, rights, params, rectification)
    if rectified or params.hand_tracking:     # it changes what the pipeline sees
        assert (golden(lefts, rights, SMALL)[1] != cents).any()
    assert len(records) == n
    assert (areas > 0).sum() >= n - 1, "the test frames must contain a hand"
    for k, rec in enumerate(records):
        assert (rec["centroid_x"], rec["centroid_y"], rec["area"]) == \
            (cents[k][0], cents[k][1], areas[k]), k
        assert (rec["x"], rec["y"], rec["flag"]) == \
            (traj.smoothed[k][0], traj.smoothed[k][1], int(traj.flag[k])), k
    assert traj.flag.any(), "the test track must trigger the spotting"
    # the posture record of every frame, about the previous frame's reference
    assert posture_records(run_amaranth.posture_words) == [st.posture_words() for st in stages]
    assert any(st.posture_reference.width for st in stages)


def test_parameters_are_validated_before_building():
    with pytest.raises(ValueError, match="width"):
        GesturePipeline(33, 16, SMALL)
    with pytest.raises(ValueError, match="opening_size"):
        GesturePipeline(32, 16, PipelineParams(census_window=3, hamming_window=3,
                                               max_disparity=8, band_low=1, band_high=6,
                                               opening_size=4))
    with pytest.raises(ValueError, match="params"):
        GesturePipeline(32, 16, {"census_window": 3})
    assert VIDEO_STAGES == ("right", "left", "disparity", "skin", "band", "opening")
    # (the synchroniser's, checked without building it)
    with pytest.raises(ValueError, match="fifo_depth must be a power of two"):
        GesturePipeline(32, 16, SMALL, fifo_depth=100)
    with pytest.raises(ValueError, match=r"threshold must be in \[1, 16\]"):
        GesturePipeline(32, 16, SMALL, fifo_depth=16, sync_threshold=17)


def test_stages_are_built_alone_on_request():
    """``stage(name)`` (and ``pipeline_stage`` from the parameters alone) builds
    one stage, or one of the matcher's, with the parameters the pipeline's
    ``elaborate`` gives it; the pipeline builds nothing until it is elaborated."""
    from amaranth.hdl import Fragment

    from hdl.gesture_pipeline import PIPELINE_STAGES, pipeline_stage
    dut = GesturePipeline(32, 16, TRACKING, fifo_depth=256, sync_threshold=8)
    assert dut.stage_names == tuple(n for n in PIPELINE_STAGES if not n.startswith("rectify"))
    assert dut.pixel_stage_names == ("to444_left", "median_left", "matcher", "segmentation",
                                     "opening")
    stages = {"centroid": dut.stage("centroid"), "synchronizer": dut.stage("synchronizer"),
              "segmentation": dut.stage("segmentation"),
              "census": pipeline_stage("matcher.census_left", 32, 16, TRACKING),
              "columns": dut.stage("matcher.shd.columns")}
    for stage in stages.values():
        Fragment.get(stage, None)               # each elaborates alone
    assert (stages["centroid"].track_gate, stages["centroid"].hand_rows) == (7, 3)
    sync = stages["synchronizer"]
    assert (sync.fifo_depth, sync.threshold, sync.flush) == (256, 8, dut.flush)
    median, matcher = dut.stage("median_left"), dut.stage("matcher")
    for stage in (median, matcher):
        Fragment.get(stage, None)
    assert stages["segmentation"].skin_delay_beats == median.lag + matcher.lag
    assert stages["census"].census_window == 3 and stages["columns"].max_disparity == 8
    with pytest.raises(ValueError, match="stage must be one of capture_left, .*, spotting, "
                                         "posture_opening, posture or matcher.<stage>, got "
                                         "'rectify_left'"):
        dut.stage("rectify_left")
    with pytest.raises(ValueError, match="census_window"):
        pipeline_stage("centroid", 32, 16, dataclasses.replace(SMALL, census_window=4))
    rectified = GesturePipeline(32, 16, SMALL, rectification=small_rectification(32, 16))
    assert rectified.stage_names == PIPELINE_STAGES
    assert rectified.pixel_stage_names[:2] == ("to444_left", "rectify_left")
    left = rectified.stage("rectify_left")
    Fragment.get(left, None)
    assert left.lanes == 3 and left.max_shift_y == small_rectification(32, 16).max_shift[1]


@pytest.mark.parametrize("width, height, params", [
    (32, 16, SMALL), (640, 480, PipelineParams()),
    (96, 64, PipelineParams(census_window=5, hamming_window=9, max_disparity=16,
                            lrcc_threshold=4, band_low=4, opening_shape="square",
                            opening_size=5)),
])
def test_pipeline_timing_without_building(width, height, params):
    """hdl.gesture_pipeline.pipeline_timing from the parameters alone equals the
    sums over the built pipeline's stages (what the simulations feed and drain),
    each built and elaborated alone as the pipeline builds it."""
    from amaranth.hdl import Fragment

    from hdl.gesture_pipeline import pipeline_memory_bits, pipeline_timing, pixel_stage_timing
    timing = pipeline_timing(width, height, params)
    built = GesturePipeline(width, height, params)

    def stage(name):
        component = built.stage(name)
        Fragment.get(component, None)           # it elaborates
        return component
    stages = [stage(name) for name in built.pixel_stage_names]
    assert tuple(pixel_stage_timing(width, height, params)) == built.pixel_stage_names
    assert list(pixel_stage_timing(width, height, params).values()) == \
        [(s.lag, s.cycles) for s in stages]
    # the windows' look-ahead, or what the posture descriptor needs on small frames
    descriptor = stage("posture")
    flush = max(sum(s.lag for s in stages), descriptor.cycles_after_frame - 1)
    assert timing.flush == flush == built.flush
    assert timing.pixel_cycles == sum(s.cycles for s in stages)
    assert timing.frame_cycles == width * height + flush
    assert timing.record_cycles == (flush + timing.pixel_cycles
                                    + stage("centroid").cycles_after_frame
                                    + stage("moving_average").cycles
                                    + stage("spotting").cycles + 1)
    # the memory of each stage, from the stages' memory functions
    median, matcher = stage("median_left"), stage("matcher")
    assert built.memory_bits == pipeline_memory_bits(width, height, params) == {
        "median row buffers": 2 * median.memory_bits,
        **{f"matcher {k}": v for k, v in matcher.memory_bits.items()},
        "skin delay line": stage("segmentation").memory_bits,
        "opening row buffers": stage("opening").memory_bits,
        "posture opening row buffers": stage("posture_opening").memory_bits}
    # independently, from the stream convention: a window of radius r looks
    # r * width + r beats ahead (4:2:2 one beat; the census and Hamming windows,
    # D - 1 for the consistency check, the disparity and camera medians, the
    # erosion and the dilation)
    rc, rh, ro = params.census_window // 2, params.hamming_window // 2, params.opening_size // 2
    assert flush == (1 + 2 * (width + 1) + (rc + rh) * (width + 1) + params.max_disparity - 1
                     + 2 * (ro * width + ro))
    if (width, height) == (640, 480):
        assert timing.frame_cycles == 325_837       # docs/figures/fpga.md (eq. 40: 325,293)
    with pytest.raises(ValueError, match="width"):
        pipeline_timing(33, height, params)
