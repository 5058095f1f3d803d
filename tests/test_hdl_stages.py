# amaranth: UnusedElaboratable=no
"""Amaranth-simulator tests of the stereo components (hdl/), each bit for bit
against its golden-model stage, on two frames streamed back to back with idle
cycles (valid low) inside and between rows."""
from pathlib import Path

import numpy as np
import pytest

from hdl.census import SparseCensus
from hdl.hamming import HammingDistances
from hdl.lrcc import LeftRightCheck
from hdl.median3x3 import Median3x3
from hdl.row_buffer import RowBuffer
from hdl.selectors import DisparitySelectors
from hdl.shd import SumOfHammingDistances
from verif.streams import field, frame_beats, run_stream, split_frames
from hdl.window import WindowGenerator
from sim.images import read_grey
from sim.model.census import census_bits, sparse_census
from sim.model.matching import lr_consistency, shd_volume, winner_take_all
from sim.model.median import median3x3

MIDDLEBURY = Path(__file__).resolve().parent.parent / "data" / "middlebury"


def _random(h, w, seed, hi=256):
    return np.random.default_rng(seed).integers(0, hi, (h, w))


def _crop(scene, side, h, w, y0=100, x0=120):
    return read_grey(MIDDLEBURY / scene / f"{side}.png")[y0:y0 + h, x0:x0 + w].astype(np.int64)


def _run(dut, frames, idle=0.25, seed=1, flush_values=None, setup=None, flush=None):
    flush = dut.lag if flush is None else flush
    beats = frame_beats(dut.i_stream.payload.shape(), frames, flush, flush_values)
    out = run_stream(dut, beats, idle=idle, seed=seed, setup=setup)
    layout = dut.o_stream.payload.shape()
    h, w = dut.height, dut.width
    return layout, out, split_frames(layout, out, w, h, len(frames))


def _pixels(img, name="pixel"):
    return [{name: v} for v in np.ravel(img)]


# ------------------------------------------------------------------ row buffer / window


def test_row_buffer_delays_by_length_beats_with_gaps():
    from amaranth.sim import Simulator
    length, lanes, n = 7, 3, 60
    dut = RowBuffer(length, lanes, 8)
    rng = np.random.default_rng(0)
    values = rng.integers(0, 256, (n, lanes))
    idle = rng.random(4 * n) < 0.4
    seen = []

    async def tb(ctx):
        k, cycle, pending = 0, 0, False
        while k < n or pending:
            if pending:  # the cycle after a beat: read the lines, write the new values
                seen.append([ctx.get(dut.o_data[i]) for i in range(lanes)])
                for i in range(lanes):
                    ctx.set(dut.i_data[i], int(values[k - 1, i]))
            beat = k < n and not idle[cycle]
            ctx.set(dut.beat, int(beat))
            await ctx.tick()
            cycle += 1
            pending = beat
            k += int(beat)

    sim = Simulator(dut)
    sim.add_clock(1e-8)
    sim.add_testbench(tb)
    sim.run()
    seen = np.array(seen)
    assert (seen[length:] == values[:n - length]).all()


@pytest.mark.parametrize("window, separation", [(3, 0), (5, 4), (3, 7)])
def test_window_generator_taps_and_masks(window, separation):
    w, h = 16, 12
    imgs = [_random(h, w, 1), _random(h, w, 2)]
    dut = WindowGenerator(w, h, 8, window, separation)
    layout, out, frames = _run(dut, [_pixels(i) for i in imgs])
    r = window // 2
    v1 = field(layout, out, "v1", window * window)
    rows1, cols = field(layout, out, "rows1"), field(layout, out, "cols")
    v2 = field(layout, out, "v2", window * window) if separation else None
    rows2 = field(layout, out, "rows2") if separation else None
    for img, sel in zip(imgs, frames):
        pad = np.full((h + 2 * r + separation, w + 2 * r), -1)
        pad[r + separation:r + separation + h, r:r + w] = img
        for k, (y, x) in zip(sel, np.ndindex(h, w)):
            for i in range(window):
                for j in range(window):
                    inside = bool((rows1[k] >> i) & 1 and (cols[k] >> j) & 1)
                    expect = pad[y + separation + i, x + j]
                    assert inside == (expect >= 0)
                    if inside:
                        assert v1[k, i * window + j] == expect
                    if separation:
                        inside2 = bool((rows2[k] >> i) & 1 and (cols[k] >> j) & 1)
                        expect2 = pad[y + i, x + j]
                        assert inside2 == (expect2 >= 0)
                        if inside2:
                            assert v2[k, i * window + j] == expect2


# ------------------------------------------------------------------ census


@pytest.mark.parametrize("census_window", [3, 5, 7])
def test_sparse_census_with_dual_window(census_window):
    w, h, sep = 24, 16, 5
    imgs = [_random(h, w, 3), _crop("cones", "left", h, w)]
    dut = SparseCensus(w, h, census_window, 8, separation=sep)
    layout, out, frames = _run(dut, [_pixels(i) for i in imgs])
    code, code2 = field(layout, out, "code"), field(layout, out, "code2")
    for img, sel in zip(imgs, frames):
        ref = sparse_census(img.astype(np.uint8), census_window).astype(np.int64)
        assert (code[sel].reshape(h, w) == ref).all()
        assert (code2[sel].reshape(h, w)[sep:] == ref[:-sep]).all()


def test_census_bits_and_validation():
    assert len(sparse_census(np.zeros((3, 3), np.uint8), 7).shape) == 2
    assert census_bits(7) == 24
    with pytest.raises(ValueError, match="census_window"):
        SparseCensus(16, 8, 4)
    with pytest.raises(ValueError, match=r"width must be in \[8, 4096\]"):
        SparseCensus(4, 8, 3)


# ------------------------------------------------------------------ median


@pytest.mark.parametrize("pixel_bits", [8, 6])
def test_median3x3(pixel_bits):
    w, h = 24, 16
    imgs = [_random(h, w, 4, 1 << pixel_bits), _random(h, w, 5, 4)]
    dut = Median3x3(w, h, pixel_bits)
    layout, out, frames = _run(dut, [_pixels(i) for i in imgs])
    pix = field(layout, out, "pixel")
    for img, sel in zip(imgs, frames):
        ref = median3x3(img.astype(np.uint16))
        assert (pix[sel].reshape(h, w) == ref).all()


# ------------------------------------------------------------------ Hamming


@pytest.mark.parametrize("bits, codes", [(4, 1), (12, 3), (24, 1), (46, 7), (60, 2)])
def test_hamming_distances_pipeline(bits, codes):
    from amaranth.sim import Simulator
    rng = np.random.default_rng(bits * 10 + codes)
    steps = 200
    a = [int(v) for v in rng.integers(0, 1 << min(bits, 62), steps)] + [(1 << bits) - 1, 0]
    b = [[int(v) for v in rng.integers(0, 1 << min(bits, 62), codes)] for _ in range(steps)]
    b += [[0] * codes, [(1 << bits) - 1] * codes]
    dut = HammingDistances(bits, codes=codes)
    width = len(dut.distance[0])
    got = []

    def planes(row):        # bit k of word j: bit j of code k
        return sum(((code >> j) & 1) << (j * codes + k) for k, code in enumerate(row)
                   for j in range(bits))

    async def tb(ctx):
        for t in range(len(a) + dut.cycles):
            if t < len(a):
                ctx.set(dut.a, a[t])
                ctx.set(dut.b.as_value(), planes(b[t]))
            await ctx.tick()
            if t + 1 >= dut.cycles:
                out = ctx.get(dut.distance.as_value())
                got.append([(out >> (k * width)) & ((1 << width) - 1) for k in range(codes)])

    sim = Simulator(dut)
    sim.add_clock(1e-8)
    sim.add_testbench(tb)
    sim.run()
    assert got[:len(a)] == [[bin(x ^ y).count("1") for y in row] for x, row in zip(a, b)]


@pytest.mark.parametrize("bits, cycles", [(1, 1), (3, 1), (6, 2), (12, 2), (24, 3), (48, 3),
                                          (64, 4)])
def test_hamming_distances_latency(bits, cycles):
    """The adder tree's depth (the SHD's and so the pipeline's timing)."""
    assert HammingDistances(bits, codes=4).cycles == cycles


# ------------------------------------------------------------------ SHD


def _shd_case(w, h, census_window, hamming_window, max_disparity, imgs, no_match_cost=None):
    bits = census_bits(census_window)
    dut = SumOfHammingDistances(w, h, bits, hamming_window, max_disparity, no_match_cost)
    frames, flush, refs = [], [], []
    rows = h + hamming_window + dut.lag // w + 2
    for left, right in imgs:
        cl = sparse_census(left.astype(np.uint8), census_window).astype(np.int64)
        cr = sparse_census(right.astype(np.uint8), census_window).astype(np.int64)
        # The dual window gives the codes hamming_window rows above, also during the flush.
        cl2, cr2 = np.zeros((rows, w), np.int64), np.zeros((rows, w), np.int64)
        cl2[hamming_window:hamming_window + h], cr2[hamming_window:hamming_window + h] = cl, cr
        frames.append([dict(left=a, right=b, left2=c, right2=d) for a, b, c, d in
                       zip(cl.ravel(), cr.ravel(), cl2[:h].ravel(), cr2[:h].ravel())])
        flush.append([dict(left2=c, right2=d) for c, d in
                      zip(cl2[h:].ravel()[:dut.lag], cr2[h:].ravel()[:dut.lag])])
        refs.append(shd_volume(cl.astype(np.uint32), cr.astype(np.uint32), hamming_window,
                               max_disparity, bits, no_match_cost))
    layout, out, sels = _run(dut, frames, flush_values=flush)
    cost = field(layout, out, "cost", max_disparity)
    for ref, sel in zip(refs, sels):
        got = cost[sel].reshape(h, w, max_disparity).transpose(2, 0, 1)
        assert (got == ref).all()


@pytest.mark.parametrize("hamming_window", [3, 5, 13])
@pytest.mark.parametrize("max_disparity", [4, 16, 32])
def test_shd_sweep(hamming_window, max_disparity):
    w, h = 34, 14
    seed = hamming_window * 100 + max_disparity
    imgs = [(_random(h, w, seed), _random(h, w, seed + 1)),
            (_crop("tsukuba", "left", h, w), _crop("tsukuba", "right", h, w))]
    _shd_case(w, h, 5, hamming_window, max_disparity, imgs)


def test_shd_census7_window1_and_no_match_cost():
    w, h = 16, 10
    imgs = [(_random(h, w, 7), _random(h, w, 8))] * 2
    _shd_case(w, h, 7, 1, 8, imgs, no_match_cost=0)
    _shd_case(w, h, 3, 7, 16, imgs, no_match_cost=4)


# ------------------------------------------------------------------ selectors, LRCC


@pytest.mark.parametrize("max_disparity", [1, 5, 16])
def test_selectors_l2r_r2l(max_disparity):
    w, h, nd = 20, 6, max_disparity
    rng = np.random.default_rng(nd)
    # A small cost range makes ties frequent: ties must keep the smaller d.
    vols = [rng.integers(0, 6, (nd, h, w)), rng.integers(0, 1000, (nd, h, w))]
    dut = DisparitySelectors(w, h, nd, 10)
    frames = [[{"cost": vol[:, y, x]} for y in range(h) for x in range(w)] for vol in vols]
    layout, out, sels = _run(dut, frames, flush=nd - 1)
    l2r, r2l = field(layout, out, "l2r"), field(layout, out, "r2l")
    for vol, sel in zip(vols, sels):
        ref_l, ref_r = winner_take_all(vol)
        assert (l2r[sel].reshape(h, w) == ref_l).all()
        # r2l of right pixel p rides on the beat of left pixel p + D - 1.
        r_idx = np.arange(sel[0], sel[0] + w * h) + nd - 1
        assert (r2l[r_idx].reshape(h, w) == ref_r).all()


@pytest.mark.parametrize("max_disparity, threshold", [(1, 1), (8, 1), (8, 3), (16, 16)])
def test_lrcc(max_disparity, threshold):
    w, h, nd = 20, 6, max_disparity
    rng = np.random.default_rng(nd + threshold)
    maps = [(rng.integers(0, nd, (h, w)), rng.integers(0, nd, (h, w))) for _ in range(2)]
    dut = LeftRightCheck(w, h, nd)
    frames = []
    for l2r, r2l in maps:
        # The selectors' stream: l2r of pixel p with r2l of pixel p - (D - 1).
        flat_r = np.concatenate([np.zeros(nd - 1, np.int64), r2l.ravel()])
        frames.append([{"l2r": a, "r2l": b} for a, b in zip(l2r.ravel(), flat_r[:w * h])])
    flush = [[{"r2l": b} for b in r2l.ravel()[w * h - (nd - 1):]] for _, r2l in maps]
    layout, out, sels = _run(dut, frames, flush_values=flush,
                             setup=lambda ctx: ctx.set(dut.threshold, threshold))
    disp = field(layout, out, "disparity")
    for (l2r, r2l), sel in zip(maps, sels):
        ref = lr_consistency(l2r.astype(np.uint8), r2l.astype(np.uint8), threshold)
        assert (disp[sel].reshape(h, w) == ref).all()


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
