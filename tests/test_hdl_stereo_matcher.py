# amaranth: UnusedElaboratable=no
"""The whole StereoMatcher in the Amaranth simulator against
sim.model.stereo.stereo_match, bit for bit with border pixels, two frames back
to back with idle cycles inside and between rows, over a covering sweep of
census window {3, 5, 7} x Hamming window {3, 5, 13} x disparities {4, 16, 32}
(every value of each parameter and every pair of census/Hamming windows' sizes
appears; the SHD stage alone runs the full Hamming x disparity product in
test_hdl_shd.py and the Verilator test the full Middlebury frame)."""
from pathlib import Path

import numpy as np
import pytest

from verif.streams import field, pack, run_stream
from hdl.lrcc import LeftRightCheck
from hdl.median3x3 import Median3x3
from hdl.selectors import DisparitySelectors
from hdl.shd import SumOfHammingDistances
from hdl.stereo_matcher import StereoMatcher
from hdl.window import WindowGenerator
from sim.images import read_grey
from sim.model.stereo import stereo_match

MIDDLEBURY = Path(__file__).resolve().parent.parent / "data" / "middlebury"


def _pair(kind, h, w, seed):
    if kind == "random":
        rng = np.random.default_rng(seed)
        left = rng.integers(0, 256, (h, w))
        right = np.clip(np.roll(left, -(seed % 5) - 1, axis=1) + rng.integers(-12, 12, (h, w)),
                        0, 255)
        return left.astype(np.uint8), right.astype(np.uint8)
    scene, y0, x0 = kind
    left = read_grey(MIDDLEBURY / scene / "left.png")[y0:y0 + h, x0:x0 + w]
    right = read_grey(MIDDLEBURY / scene / "right.png")[y0:y0 + h, x0:x0 + w]
    return left, right


def run_matcher(pairs, census_window, hamming_window, max_disparity, threshold,
                idle=0.2, seed=0, **kwargs):
    h, w = pairs[0][0].shape
    dut = StereoMatcher(w, h, census_window, hamming_window, max_disparity, **kwargs)
    layout = dut.i_stream.payload.shape()
    beats = [pack(layout, {"left": a, "right": b})
             for left, right in pairs for a, b in zip(left.ravel(), right.ravel())]
    out = run_stream(dut, beats, idle=idle, seed=seed, use_ready=True,
                     setup=lambda ctx: ctx.set(dut.threshold, threshold),
                     extra_cycles=dut.latency + 16)
    disp = field(dut.o_stream.payload.shape(), out, "disparity")
    assert len(disp) == len(pairs) * w * h
    return dut, [disp[k * w * h:(k + 1) * w * h].reshape(h, w) for k in range(len(pairs))]


CASES = [
    # census, hamming, D, size (w, h), frames, threshold
    (3, 3, 4, (24, 16), ["random", ("tsukuba", 150, 150)], 1),
    (5, 13, 16, (32, 24), [("tsukuba", 120, 100), "random"], 2),
    (7, 5, 32, (48, 32), [("cones", 150, 200), ("cones", 300, 40)], 8),
    (3, 5, 16, (24, 16), ["random", ("venus", 200, 200)], 3),
    (5, 3, 32, (40, 20), [("venus", 100, 250), "random"], 1),
    (7, 13, 4, (24, 16), [("cones", 100, 100), "random"], 2),
]


@pytest.mark.parametrize("census_window, hamming_window, max_disparity, size, kinds, th", CASES)
def test_matcher_equals_golden_model(census_window, hamming_window, max_disparity, size,
                                     kinds, th):
    w, h = size
    pairs = [_pair(k, h, w, 11 + i) for i, k in enumerate(kinds)]
    dut, got = run_matcher(pairs, census_window, hamming_window, max_disparity, th,
                           seed=census_window)
    for (left, right), disp in zip(pairs, got):
        ref = stereo_match(left, right, census_window=census_window,
                           hamming_window=hamming_window, max_disparity=max_disparity,
                           lrcc_threshold=th).disparity
        assert (disp == ref).all(), np.argwhere(disp != ref)[:8]


def test_matcher_options_no_median_and_no_match_cost():
    w, h = 24, 16
    pairs = [_pair(("cones", 200, 300), h, w, 0), _pair("random", h, w, 3)]
    for median, cost in ((False, 0), (True, 8)):
        dut, got = run_matcher(pairs, 5, 5, 8, 2, idle=0.4, seed=5,
                               disparity_median=median, no_match_cost=cost)
        for (left, right), disp in zip(pairs, got):
            ref = stereo_match(left, right, census_window=5, hamming_window=5,
                               max_disparity=8, lrcc_threshold=2, no_match_cost=cost,
                               disparity_median=median).disparity
            assert (disp == ref).all()


def test_matcher_without_gaps_takes_frame_cycles():
    w, h = 24, 16
    pairs = [_pair("random", h, w, 1)] * 2
    dut = StereoMatcher(w, h, 3, 3, 4)
    layout = dut.i_stream.payload.shape()
    beats = [pack(layout, {"left": a, "right": b})
             for left, right in pairs for a, b in zip(left.ravel(), right.ravel())]
    cycles = []
    out = run_stream(dut, beats, use_ready=True, extra_cycles=dut.latency + 16,
                     setup=lambda ctx: ctx.set(dut.threshold, 8), out_cycles=cycles)
    assert len(out) == 2 * w * h
    # census r*w + r, SHD r*w + r, LRCC D - 1, median w + 1 (r = 1, D = 4)
    assert dut.flush == (1 + 1 + 1) * w + 1 + 1 + 3 + 1
    assert dut.frame_cycles == w * h + dut.flush
    # pixel k of frame f enters at cycle f * frame_cycles + k, leaves latency later
    expect = [f * dut.frame_cycles + k + dut.latency for f in range(2) for k in range(w * h)]
    assert cycles == expect


@pytest.mark.parametrize("kwargs, name", [
    (dict(census_window=4), "census_window"),
    (dict(census_window=13), "census_window"),
    (dict(hamming_window=0), "hamming_window"),
    (dict(max_disparity=0), "max_disparity"),
    (dict(max_disparity=300), "max_disparity"),
    (dict(width=30, max_disparity=32), "width"),
    (dict(height=1), "height"),
    (dict(pixel_bits=17), "pixel_bits"),
    (dict(no_match_cost=25), "no_match_cost"),
])
def test_matcher_validation(kwargs, name):
    params = dict(width=64, height=32, census_window=7, hamming_window=13, max_disparity=16)
    params.update(kwargs)
    with pytest.raises(ValueError, match=name):
        StereoMatcher(**params)


@pytest.mark.parametrize("census_window", [3, 5, 7])
@pytest.mark.parametrize("hamming_window", [3, 5, 13])
@pytest.mark.parametrize("max_disparity", [4, 16, 32])
def test_matcher_full_sweep_one_frame(census_window, hamming_window, max_disparity):
    """The whole product, one 34x10 cones crop each (two frames: the cases above)."""
    w, h = 34, 10
    pair = _pair(("cones", 120 + 7 * census_window, 60 + 3 * hamming_window), h, w, 0)
    dut, got = run_matcher([pair], census_window, hamming_window, max_disparity, 4,
                           idle=0.15, seed=max_disparity)
    ref = stereo_match(*pair, census_window=census_window, hamming_window=hamming_window,
                       max_disparity=max_disparity, lrcc_threshold=4).disparity
    assert (got[0] == ref).all()


def test_external_flush_mode_is_a_plain_pipeline_stage():
    """With ``external_flush`` the frame source supplies the flush beats (here
    with random payloads, as an upstream window stage would leave them) and the
    output carries ``first`` / ``real`` on every beat."""
    from verif.streams import frame_beats, split_frames
    w, h = 24, 16
    pairs = [_pair(("tsukuba", 140, 120), h, w, 0), _pair("random", h, w, 4)]
    dut = StereoMatcher(w, h, 5, 5, 8, external_flush=True)
    assert dut.lag == dut.flush
    layout = dut.i_stream.payload.shape()
    rng = np.random.default_rng(2)
    junk = [[{"left": a, "right": b} for a, b in rng.integers(0, 256, (dut.flush, 2))]
            for _ in pairs]
    frames = [[{"left": a, "right": b} for a, b in zip(l.ravel(), r.ravel())] for l, r in pairs]
    out = run_stream(dut, frame_beats(layout, frames, dut.flush, junk), idle=0.3, seed=3,
                     setup=lambda ctx: ctx.set(dut.threshold, 2))
    olayout = dut.o_stream.payload.shape()
    disp = field(olayout, out, "disparity")
    for (left, right), sel in zip(pairs, split_frames(olayout, out, w, h, len(pairs))):
        ref = stereo_match(left, right, census_window=5, hamming_window=5, max_disparity=8,
                           lrcc_threshold=2).disparity
        assert (disp[sel].reshape(h, w) == ref).all()


# The matcher's stages (hdl/shd.py, selectors.py, lrcc.py, median3x3.py, window.py):
# one test for the parameter checks of the five.
def test_stage_validation_names_the_parameter():
    with pytest.raises(ValueError, match="hamming_window"):
        SumOfHammingDistances(32, 8, 24, 4, 8)
    with pytest.raises(ValueError, match="max_disparity"):
        DisparitySelectors(32, 8, 0, 10)
    with pytest.raises(ValueError, match=r"width must be in \[16, 4096\]"):
        LeftRightCheck(10, 8, 16)
    with pytest.raises(ValueError, match="pixel_bits"):
        Median3x3(16, 8, 0)
    with pytest.raises(ValueError, match="height"):
        WindowGenerator(16, 1, 8, 3)


def test_stages_are_built_alone_on_request():
    """``stage(name)`` builds that stage alone, with the parameters the matcher's
    ``elaborate`` gives it (the SHD's parts as ``shd.<part>``); the matcher and its
    figures build nothing."""
    from amaranth.hdl import Fragment

    from hdl.census import SparseCensus
    from hdl.column_sum import ColumnSum
    from hdl.stereo_matcher import MATCHER_STAGES, matcher_stage
    dut = StereoMatcher(32, 8, 5, 7, 8, no_match_cost=3)
    assert dut.stage_names == MATCHER_STAGES
    kinds = {"census_left": SparseCensus, "census_right": SparseCensus,
             "shd": SumOfHammingDistances, "select": DisparitySelectors,
             "check": LeftRightCheck, "median": Median3x3, "shd.columns": ColumnSum}
    stages = {name: dut.stage(name) for name in kinds}
    for name, stage in stages.items():
        assert type(stage) is kinds[name]
        Fragment.get(stage, None)               # each elaborates alone
    assert stages["census_left"].separation == 7 and stages["census_left"].census_window == 5
    assert stages["shd"].no_match_cost == stages["shd.columns"].no_match_cost == 3
    assert stages["select"].cost_bits == stages["shd"].cost_bits
    assert stages["median"].pixel_bits == dut.disparity_bits
    no_median = StereoMatcher(32, 8, 5, 7, 8, disparity_median=False)
    assert no_median.stage_names == MATCHER_STAGES[:-1]
    for bad in ("median", "shd.census", "lrcc"):
        with pytest.raises(ValueError, match="stage must be one of census_left, .*, check or"):
            no_median.stage(bad)
    with pytest.raises(ValueError, match="stage must be one of .*, median or"):
        matcher_stage("left", 32, 8)
