# amaranth: UnusedElaboratable=no
"""Amaranth-simulator tests of the camera-side pixel stages (hdl/): 4:2:2 ->
4:4:4, the beat delay line, hand segmentation, binary morphology and the opening,
each bit for bit against its golden-model stage, on two frames streamed back to
back with idle cycles (valid low) inside and between rows."""
import numpy as np
import pytest
from amaranth.hdl import Elaboratable, Module, Signal
from amaranth.sim import Simulator

from hdl.delay_line import MEMORY_MIN_BEATS, BeatDelay
from hdl.morphology import BinaryMorphology
from hdl.opening import Opening
from hdl.segmentation import HandSegmentation
from verif.streams import field, frame_beats, gap_pattern, pack, run_stream, split_frames
from hdl.ycbcr422 import YCbCr422To444
from sim.model.morphology import dilate, erode, opening
from sim.model.segmentation import disparity_band, hand_mask, skin_mask
from sim.model.ycbcr import ycbcr422_to_444

IDLE = 0.25


def _run(dut, frames, idle=IDLE, seed=1, setup=None):
    beats = frame_beats(dut.i_stream.payload.shape(), frames, dut.lag)
    out = run_stream(dut, beats, idle=idle, seed=seed, setup=setup)
    layout = dut.o_stream.payload.shape()
    return layout, out, split_frames(layout, out, dut.width, dut.height, len(frames))


# ------------------------------------------------------------------ 4:2:2 -> 4:4:4


@pytest.mark.parametrize("w, h", [(24, 12), (8, 3)])
def test_ycbcr422_to_444(w, h):
    rng = np.random.default_rng(w)
    cams = [rng.integers(0, 256, (h, 2 * w)).astype(np.uint8) for _ in range(2)]
    dut = YCbCr422To444(w, h)
    frames = [[{"luma": cam[y, 2 * k], "chroma": cam[y, 2 * k + 1]}
               for y in range(h) for k in range(w)] for cam in cams]
    layout, out, sels = _run(dut, frames)
    got = {name: field(layout, out, name) for name in ("y", "cb", "cr")}
    for cam, sel in zip(cams, sels):
        for name, ref in zip(("y", "cb", "cr"), ycbcr422_to_444(cam)):
            assert (got[name][sel].reshape(h, w) == ref).all(), name


# ------------------------------------------------------------------ beat delay


class _Clocked(Elaboratable):
    """A component plus a register, so the simulator has a clock domain even
    when the component is a plain wire (no delay)."""

    def __init__(self, dut):
        self.dut, self.i_stream, self.o_stream = dut, dut.i_stream, dut.o_stream

    def elaborate(self, platform):
        m = Module()
        m.submodules.dut = self.dut
        toggle = Signal()
        m.d.sync += toggle.eq(~toggle)
        return m


@pytest.mark.parametrize("bits, beats, cycles", [
    (1, 0, 0), (8, 0, 3), (5, 1, 0), (3, 7, 2), (4, MEMORY_MIN_BEATS - 1, 1),
    (1, MEMORY_MIN_BEATS, 0), (20, 45, 0), (9, 70, 4)])
def test_beat_delay(bits, beats, cycles):
    n = 3 * beats + 40
    rng = np.random.default_rng(beats * 10 + cycles)
    values = [int(v) for v in rng.integers(0, 1 << bits, n)]
    dut = BeatDelay(bits, beats, cycles)
    assert dut.uses_memory == (beats >= MEMORY_MIN_BEATS)
    assert dut.memory_bits == (beats - 1) * bits * dut.uses_memory
    out_cycles = []
    out = run_stream(_Clocked(dut),
                     [pack(dut.i_stream.payload.shape(), {"data": v}) for v in values],
                     idle=0.4, seed=beats, out_cycles=out_cycles)
    expect = [0] * beats + values[:n - beats]
    assert list(field(dut.o_stream.payload.shape(), out, "data")) == expect
    # Output of beat t comes exactly `cycles` clock cycles after beat t.
    idle = gap_pattern(4 * n + 16, 0.4, beats)
    in_cycles = np.flatnonzero(~idle)[:n]
    assert list(np.array(out_cycles) - in_cycles) == [cycles] * n


# ------------------------------------------------------------------ segmentation


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
    (16, (0, 40), (200, 255), 0, 15, 40, 0),              # memory, no cycle; band edges 0, D-1
    (64, (100, 100), (0, 255), 10, 11, 1, 1),              # one-value box, empty band
    (3, (0, 255), (128, 128), 0, None, 3, 7),              # D = 3: band 0 < d < 1 is empty
]


@pytest.mark.parametrize("nd, cb_r, cr_r, low, high, nb, nc", SEGMENTATION_CASES)
def test_hand_segmentation(nd, cb_r, cr_r, low, high, nb, nc):
    w, h = 24, 12
    rng = np.random.default_rng(nd + nb)
    dut = HandSegmentation(w, h, nd, cb_r, cr_r, low, high, nb, nc)
    assert dut.disparity_bits == max(1, (nd - 1).bit_length())
    assert dut.memory_bits == (nb - 1 if nb >= MEMORY_MIN_BEATS else 0)
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


# ------------------------------------------------------------------ morphology


def _masks(h, w, seed):
    """Blobs plus salt-and-pepper noise, and an almost-full mask whose holes
    and frame borders matter to the erosion."""
    rng = np.random.default_rng(seed)
    blobs = np.zeros((h, w), bool)
    for _ in range(4):
        y, x = rng.integers(0, h), rng.integers(0, w)
        blobs[max(0, y - rng.integers(1, 6)):y + rng.integers(2, 7),
              max(0, x - rng.integers(1, 8)):x + rng.integers(2, 9)] = True
    blobs ^= rng.random((h, w)) < 0.08
    full = rng.random((h, w)) > 0.03
    return [blobs, full]


def _morph_run(dut, masks, select, seed):
    frames = [[{"pixel": v} for v in np.ravel(m_)] for m_ in masks]
    setup = None if select is None else (lambda ctx: ctx.set(dut.dilate, select))
    layout, out, sels = _run(dut, frames, seed=seed, setup=setup)
    pix = field(layout, out, "pixel")
    return [pix[sel].reshape(dut.height, dut.width).astype(bool) for sel in sels]


@pytest.mark.parametrize("shape", ["cross", "square", "diamond"])
@pytest.mark.parametrize("size", [3, 5, 7, 11])
@pytest.mark.parametrize("op", ["erode", "dilate"])
def test_binary_morphology(shape, size, op):
    w, h = max(12, size + 2), 9
    dut = BinaryMorphology(w, h, shape, size)
    masks = _masks(h, w, size * 7 + len(shape))
    if op == "dilate":
        masks[1] = ~masks[1]  # sparse: dilation's borders matter
    got = _morph_run(dut, masks, int(op == "dilate"), seed=size)
    model = erode if op == "erode" else dilate
    for mask, g in zip(masks, got):
        ref = model(mask, shape, size=size)
        assert (g == ref).all()
    # the operation changes the masks (the comparison is not trivially equal)
    assert any((model(m_, shape, size=size) != m_).any() for m_ in masks)


def test_binary_morphology_explicit_asymmetric_element():
    # An asymmetric element catches a reflected window; 1x1 is the identity.
    element = np.array([[1, 1, 0, 0, 0], [0, 0, 0, 0, 1], [0, 0, 1, 0, 0],
                        [0, 0, 0, 0, 0], [0, 1, 0, 0, 0]], bool)
    w, h = 14, 8
    masks = _masks(h, w, 3)
    for select, model in ((0, erode), (1, dilate)):
        dut = BinaryMorphology(w, h, element)
        assert dut.size == 5 and dut.taps == 5 and dut.tree_levels == 1
        for mask, g in zip(masks, _morph_run(dut, masks, select, seed=select)):
            assert (g == model(mask, element)).all()
    dut = BinaryMorphology(w, h, np.ones((1, 1), bool))
    assert dut.lag == 0
    for mask, g in zip(masks, _morph_run(dut, masks, 1, seed=5)):
        assert (g == mask).all()


@pytest.mark.parametrize("shape, size, w, h", [("cross", 11, 32, 16), ("square", 3, 24, 10)])
def test_opening(shape, size, w, h):
    dut = Opening(w, h, shape, size)
    r = size // 2
    assert dut.lag == 2 * (r * w + r)
    assert dut.memory_bits == 2 * ((size - 1) * (w - size))
    masks = _masks(h, w, size)
    refs = [opening(mask, shape, size=size) for mask in masks]
    for ref, g in zip(refs, _morph_run(dut, masks, None, seed=2)):
        assert (g == ref).all()
    # the opening keeps some pixels and removes others
    assert all(ref.any() for ref in refs) and any((r != m_).any() for r, m_ in zip(refs, masks))


# ------------------------------------------------------------------ validation


@pytest.mark.parametrize("make, name", [
    (lambda: YCbCr422To444(25, 8), r"width must be even in \[8, 4096\]"),
    (lambda: YCbCr422To444(24, 1), r"height must be in \[2, 4096\]"),
    (lambda: BeatDelay(0, 4), r"bits must be in \[1, 1024\]"),
    (lambda: BeatDelay(8, -1), r"beats must be in \[0, 65537\]"),
    (lambda: BeatDelay(8, 4, -2), r"cycles must be in \[0, 4096\]"),
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
    (lambda: BinaryMorphology(24, 12, "disc"), r"element must be one of"),
    (lambda: BinaryMorphology(24, 12, "cross", 4), r"size must be odd in \[3, 63\]"),
    (lambda: BinaryMorphology(24, 12, np.ones((2, 2), bool)), r"element must be a square array"),
    (lambda: BinaryMorphology(24, 12, np.zeros((3, 3), bool)), r"element must contain"),
    (lambda: BinaryMorphology(12, 12, "square", 11), r"width must be in \[13, 4096\]"),
    (lambda: Opening(16, 8, "diamond", 65), r"size must be in \[3, 63\]"),
])
def test_bad_parameters_name_the_parameter(make, name):
    with pytest.raises(ValueError, match=name):
        make()
