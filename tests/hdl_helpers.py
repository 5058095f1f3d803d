# amaranth: UnusedElaboratable=no
"""Helpers shared by the hardware-block tests (tests/test_hdl_<block>.py): test
images, frames streamed through a block, masks for the morphology blocks and
one beat per frame for the feature blocks."""
from pathlib import Path

import numpy as np

from hdl.moving_average import MovingAverage
from verif.streams import field, frame_beats, pack, run_stream, split_frames
from sim.images import read_grey

MIDDLEBURY = Path(__file__).resolve().parent.parent / "data" / "middlebury"
IDLE = 0.25


def random_image(h, w, seed, hi=256):
    """An h x w image of uniform random values in [0, hi)."""
    return np.random.default_rng(seed).integers(0, hi, (h, w))


def crop(scene, side, h, w, y0=100, x0=120):
    """An h x w crop of a Middlebury image (``side``: left or right)."""
    return read_grey(MIDDLEBURY / scene / f"{side}.png")[y0:y0 + h, x0:x0 + w].astype(np.int64)


def run_frames(dut, frames, idle=IDLE, seed=1, flush_values=None, setup=None, flush=None):
    """Stream ``frames`` (lists of payload dicts) through a window stage back to
    back, each followed by ``flush`` flush beats (default ``dut.lag``), with idle
    cycles; return the output layout, the output words and each frame's beats."""
    flush = dut.lag if flush is None else flush
    beats = frame_beats(dut.i_stream.payload.shape(), frames, flush, flush_values)
    out = run_stream(dut, beats, idle=idle, seed=seed, setup=setup)
    layout = dut.o_stream.payload.shape()
    h, w = dut.height, dut.width
    return layout, out, split_frames(layout, out, w, h, len(frames))


def pixels(img, name="pixel"):
    """An image as one frame of payload dicts, raster order."""
    return [{name: v} for v in np.ravel(img)]


def morphology_masks(h, w, seed):
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


def run_morphology(dut, masks, select, seed):
    """The masks through a morphology stage (``select``: its ``dilate`` input, or None)."""
    frames = [[{"pixel": v} for v in np.ravel(m_)] for m_ in masks]
    setup = None if select is None else (lambda ctx: ctx.set(dut.dilate, select))
    layout, out, sels = run_frames(dut, frames, seed=seed, setup=setup)
    pix = field(layout, out, "pixel")
    return [pix[sel].reshape(dut.height, dut.width).astype(bool) for sel in sels]


def feed_frames(dut, rows, idle, seed):
    """One beat per frame (``rows``: payload dicts), random idle gaps."""
    layout = dut.i_stream.payload.shape()
    beats = [pack(layout, row) for row in rows]
    out = run_stream(dut, beats, idle=idle, seed=seed, extra_cycles=dut.cycles + 4)
    assert len(out) == len(rows)
    return dut.o_stream.payload.shape(), out


def run_moving_average(points, valid, window, frac_bits, coord_bits=10, idle=0.4, seed=0):
    """The MovingAverage's smoothed points and ``primed`` flags for a track."""
    dut = MovingAverage(coord_bits, window, frac_bits)
    rows = [dict(x=int(x), y=int(y), valid=int(v)) for (x, y), v in zip(points, valid)]
    layout, out = feed_frames(dut, rows, idle, seed)
    got = np.stack([field(layout, out, "x"), field(layout, out, "y")], axis=1)
    return got, field(layout, out, "primed")
