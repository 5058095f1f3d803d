# amaranth: UnusedElaboratable=no
"""hdl/segmentation.py: HandSegmentation, bit for bit against skin_mask, disparity_band
and hand_mask of sim.model.segmentation."""
import numpy as np
import pytest
from amaranth.sim import Simulator

from hdl.delay_line import MEMORY_MIN_BEATS
from hdl.segmentation import HandSegmentation
from verif.streams import field, gap_pattern, pack, split_frames
from sim.model.segmentation import disparity_band, hand_mask, skin_mask
from tests.hdl_helpers import IDLE


def _edge_values(rng, shape, ranges, hi):
    """Values at and around the edges of ``ranges`` mixed with uniform ones."""
    edges = sorted({v for lo_hi in ranges for e in lo_hi for v in (e - 1, e, e + 1)
                    if 0 <= v <= hi})
    pick = rng.choice(edges, shape)
    uniform = rng.integers(0, hi + 1, shape)
    return np.where(rng.random(shape) < 0.6, pick, uniform)


def _run_segmentation(dut, chroma_frames, disparities, gap_beats, seed):
    """Feed chroma frames (``gap_beats`` junk beats after each) to ``i_chroma``
    and, as the stereo matcher would, the disparity of chroma beat t -
    ``skin_delay_beats`` on ``i_disparity`` ``skin_delay_cycles`` clock cycles
    after chroma beat t. Return the output words."""
    rng = np.random.default_rng(seed)
    nb, nc = dut.skin_delay_beats, dut.skin_delay_cycles
    cl = dut.i_chroma.payload.shape()
    dl = dut.i_disparity.payload.shape()
    chroma, pixel = [], []  # chroma words; pixel (frame, index) or None per beat
    for f, (cb, cr) in enumerate(chroma_frames):
        for k, (b, r) in enumerate(zip(cb.ravel(), cr.ravel())):
            chroma.append(pack(cl, {"first": int(k == 0), "cb": b, "cr": r}))
            pixel.append((f, k))
        # junk beats (a misaligned delay would pick them up); after the last
        # frame also the skin_delay_beats that bring its last disparities
        tail = gap_beats + (nb if f == len(chroma_frames) - 1 else 0)
        for _ in range(tail):
            chroma.append(pack(cl, {"cb": rng.integers(0, 256), "cr": rng.integers(0, 256)}))
            pixel.append(None)
    disp = []
    for t in range(len(chroma)):
        src = pixel[t - nb] if t >= nb else None
        if src is None:
            disp.append(pack(dl, {"disparity": rng.integers(0, 1 << dut.disparity_bits)}))
        else:
            f, k = src
            disp.append(pack(dl, {"first": int(k == 0), "real": 1,
                                  "disparity": disparities[f].ravel()[k]}))
    n = len(chroma)
    idle = gap_pattern(4 * n, IDLE, seed)
    beat_cycle = np.flatnonzero(~idle)[:n]
    last = int(beat_cycle[-1]) + nc + dut.cycles + 4
    chroma_at = dict(zip(beat_cycle.tolist(), chroma))
    disp_at = {int(c) + nc: word for c, word in zip(beat_cycle, disp)}
    out = []

    async def testbench(ctx):
        ci, di, o = dut.i_chroma, dut.i_disparity, dut.o_stream
        for cycle in range(last):
            ctx.set(ci.valid, int(cycle in chroma_at))
            ctx.set(ci.payload.as_value(), chroma_at.get(cycle, 0))
            ctx.set(di.valid, int(cycle in disp_at))
            ctx.set(di.payload.as_value(), disp_at.get(cycle, 0))
            if ctx.get(o.valid):
                out.append(ctx.get(o.payload.as_value()))
            await ctx.tick()

    sim = Simulator(dut)
    sim.add_clock(1e-8)
    sim.add_testbench(testbench)
    sim.run()
    assert len(out) == n
    return out


SEGMENTATION_CASES = [
    # (max_disparity, skin_cb, skin_cr, band_low, band_high, delay beats, delay cycles)
    (48, (77, 127), (133, 173), 33, None, 0, 0),          # thesis values, aligned streams
    (48, (77, 127), (133, 173), 33, None, 5, 3),          # short delay line (registers)
    (48, (77, 127), (133, 173), 33, None, 2 * 24 + 7, 20),  # 2 rows + 7 beats (memory)
    (48, (77, 127), (133, 173), 20, 30, 0, 4),            # cycles only (skin register)
    (16, (0, 40), (200, 255), 0, 15, 40, 3),              # memory, fewest cycles; band edges 0, D-1
    (64, (100, 100), (0, 255), 10, 11, 1, 1),              # one-value box, empty band
    (3, (0, 255), (128, 128), 0, None, 3, 7),              # D = 3: band 0 < d < 1 is empty
]


@pytest.mark.parametrize("nd, cb_r, cr_r, low, high, nb, nc", SEGMENTATION_CASES)
def test_hand_segmentation(nd, cb_r, cr_r, low, high, nb, nc):
    w, h = 24, 12
    rng = np.random.default_rng(nd + nb)
    dut = HandSegmentation(w, h, nd, cb_r, cr_r, low, high, nb, nc)
    assert dut.disparity_bits == max(1, (nd - 1).bit_length())
    assert dut.memory_bits == (nb if nb >= MEMORY_MIN_BEATS else 0)
    hi = nd - 2 if high is None else high
    chroma = [(_edge_values(rng, (h, w), [cb_r], 255), _edge_values(rng, (h, w), [cr_r], 255))
              for _ in range(2)]
    disparities = [_edge_values(rng, (h, w), [(low, hi)], nd - 1) for _ in range(2)]
    out = _run_segmentation(dut, chroma, disparities, gap_beats=9, seed=nb + nc)
    layout = dut.o_stream.payload.shape()
    sels = split_frames(layout, out, w, h, 2)
    got = {k: field(layout, out, k) for k in ("skin", "band", "hand")}
    for (cb, cr), disp, sel in zip(chroma, disparities, sels):
        skin = skin_mask(cb.astype(np.uint8), cr.astype(np.uint8), cb_r, cr_r)
        band = disparity_band(disp.astype(np.uint8), low, high, nd)
        ref = {"skin": skin, "band": band, "hand": hand_mask(skin, band)}
        for k in ref:
            assert (got[k][sel].reshape(h, w) == ref[k]).all(), k
        # the sweep reaches both outcomes of every test
        assert 0 < ref["skin"].sum() < w * h and 0 <= ref["band"].sum() < w * h


@pytest.mark.parametrize("make, name", [
    (lambda: HandSegmentation(24, 12, max_disparity=1), r"max_disparity must be in \[2, 255\]"),
    (lambda: HandSegmentation(24, 12, skin_cb=(80, 70)), r"skin_cb\[1\] must be in \[80, 255\]"),
    (lambda: HandSegmentation(24, 12, skin_cr=(0, 256)), r"skin_cr\[1\] must be in"),
    (lambda: HandSegmentation(24, 12, skin_cr=5), r"skin_cr must be a pair"),
    (lambda: HandSegmentation(24, 12, band_low=47), r"band_low must be in \[0, 46\]"),
    (lambda: HandSegmentation(24, 12, band_low=20, band_high=20),
     r"band_high must be in \[21, 47\]"),
    (lambda: HandSegmentation(24, 12, skin_delay_beats=-1), r"skin_delay_beats must be in"),
    (lambda: HandSegmentation(24, 12, skin_delay_cycles=-1),
     r"skin_delay_cycles must be in \[0, 4096\]"),
    (lambda: HandSegmentation(24, 12, skin_delay_beats=32, skin_delay_cycles=2),
     r"skin_delay_cycles must be at least 3 for skin_delay_beats >= 32"),
])
def test_bad_parameters_name_the_parameter(make, name):
    with pytest.raises(ValueError, match=name):
        make()
