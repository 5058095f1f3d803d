# amaranth: UnusedElaboratable=no
"""hdl/centroid.py: Centroid, bit for bit against sim.model.centroid.centroid (thesis §7.1)."""
import numpy as np
import pytest
from amaranth.sim import Simulator

from hdl.centroid import Centroid
from verif.streams import field, pack
from sim.model.centroid import centroid, moment_widths


def _masks(h, w, seed):
    rng = np.random.default_rng(seed)
    masks = [rng.random((h, w)) < density for density in (0.5, 0.05, 0.9)]
    masks.append(np.zeros((h, w), bool))
    masks.append(np.ones((h, w), bool))
    for y, x in [(0, 0), (h - 1, w - 1), (int(rng.integers(h)), int(rng.integers(w)))]:
        single = np.zeros((h, w), bool)
        single[y, x] = True
        masks.append(single)
    row, col = np.zeros((h, w), bool), np.zeros((h, w), bool)
    row[int(rng.integers(h))] = True
    col[:, int(rng.integers(w))] = True
    blob = np.zeros((h, w), bool)  # a hand-like blob in a corner
    blob[h // 2:, w // 3:w - 1] = rng.random((h - h // 2, w - 1 - w // 3)) < 0.8
    return masks + [row, col, blob]


def _mask_beats(layout, masks, seed, before=(0, 9), after=(0, 9)):
    """A window stage's output: per frame some non-real beats (random payload,
    as flush of the previous frame or look-ahead of this one), the real pixels
    with ``first`` on the first, more non-real beats."""
    rng = np.random.default_rng(seed)
    beats, last = [], []

    def junk(count):
        for _ in range(count):
            beats.append(pack(layout, dict(pixel=int(rng.integers(2)), real=0,
                                           first=int(rng.random() < 0.2))))

    for mask in masks:
        junk(int(rng.integers(*before)) if before[1] else 0)
        for k, v in enumerate(mask.ravel()):
            beats.append(pack(layout, dict(pixel=int(v), real=1, first=int(k == 0))))
        last.append(len(beats) - 1)
        junk(int(rng.integers(*after)) if after[1] else 0)
    return beats, last


def _drive(dut, beats, gaps):
    """Feed ``beats`` with ``gaps[k]`` idle cycles (valid low) before beat k; return
    the output words and their clock cycles (beat k without gaps is cycle k)."""
    i, o = dut.i_stream, dut.o_stream
    words, cycles = [], []

    async def tb(ctx):
        schedule = [None] * int(gaps[0])
        for k, beat in enumerate(beats):
            schedule += [None] * int(gaps[k] if k else 0) + [beat]
        schedule += [None] * (dut.cycles_after_frame + 8)
        for cycle, beat in enumerate(schedule):
            ctx.set(i.valid, int(beat is not None))
            if beat is not None:
                ctx.set(i.payload.as_value(), beat)
            if ctx.get(o.valid):
                words.append(ctx.get(o.payload.as_value()))
                cycles.append(cycle)
            await ctx.tick()

    sim = Simulator(dut)
    sim.add_clock(1e-8)
    sim.add_testbench(tb)
    sim.run()
    return words, cycles


def _gaps(n, idle, seed):
    """Mostly short gaps (probability ``idle`` per beat), now and then one longer
    than a division (e.g. right before a frame's last pixel)."""
    rng = np.random.default_rng(seed)
    gaps = np.where(rng.random(n) < idle, rng.integers(1, 4, n), 0)
    return np.where(rng.random(n) < 0.02, rng.integers(20, 80, n), gaps)


def _centroids(dut, words):
    layout = dut.o_stream.payload.shape()
    # the hand flag is the area's own: nonzero area
    assert [int(v) for v in field(layout, words, "hand")] == \
        [int(v != 0) for v in field(layout, words, "area")]
    return [tuple(int(v) for v in t) for t in
            zip(*(field(layout, words, name) for name in ("x", "y", "area")))]


@pytest.mark.parametrize("width, height, idle", [(24, 12, 0.3), (40, 20, 0.2), (8, 2, 0.5)])
def test_centroid_frames_with_gaps_and_flush(width, height, idle):
    dut = Centroid(width, height)
    assert dut.widths == moment_widths(width, height)
    masks = _masks(height, width, width)
    beats, last = _mask_beats(dut.i_stream.payload.shape(), masks, seed=height)
    gaps = _gaps(len(beats), idle, width)
    gaps[last] = 3 * dut.cycles_after_frame  # a long wait for some frames' last pixel
    gaps[last[::2]] = 0
    out, _ = _drive(dut, beats, gaps)
    assert _centroids(dut, out) == [tuple(centroid(mask)) for mask in masks]


def test_centroid_next_frame_right_after_last_pixel_exact_timing():
    width, height = 24, 12
    dut = Centroid(width, height)
    masks = _masks(height, width, 5)
    # No gaps, no flush between frames: the next frame's first pixel follows the
    # last pixel of the previous one (while its division runs).
    beats, last = _mask_beats(dut.i_stream.payload.shape(), masks, seed=6, before=(3, 4),
                              after=(0, 0))
    out, cycles = _drive(dut, beats, np.zeros(len(beats), int))
    assert _centroids(dut, out) == [tuple(centroid(mask)) for mask in masks]
    assert dut.cycles_after_frame == max(dut.widths.m10, dut.widths.m01) + 3
    assert cycles == [k + dut.cycles_after_frame for k in last]


@pytest.mark.parametrize("make, name", [
    (lambda: Centroid(4, 8), r"width must be in \[8, 4096\]"),
    (lambda: Centroid(16, 1), r"height must be in \[2, 4096\]"),
    (lambda: Centroid(16, 8, track_gate=-1), r"track_gate must be in \[0, 4095\]"),
    (lambda: Centroid(16, 8, hand_rows=4097), r"hand_rows must be in \[0, 4096\]"),
])
def test_bad_parameters_raise_value_error_naming_them(make, name):
    with pytest.raises(ValueError, match=name):
        make()


def _tracking_masks(h, w, seed, frames=14):
    """A hand (a blob) moving across the frame with a forearm (a strip below it),
    a second blob (the intruder) now and then, some empty frames (the gate opens
    again) and noise; the hand leaves the gate once (a jump)."""
    rng = np.random.default_rng(seed)
    masks = []
    for n in range(frames):
        mask = rng.random((h, w)) < 0.02
        if n in (4, 9):
            masks.append(np.zeros((h, w), bool) if n == 4 else mask)
            continue
        cx = 3 + (n * 3) % (w - 8) if n != 11 else w - 4      # a jump at frame 11
        cy = 2 + (n * 2) % max(1, h // 2)
        mask[cy:cy + 3, cx - 2:cx + 3] |= rng.random((3, 5)) < 0.9
        mask[cy + 3:, cx - 1:cx + 2] = True                   # the forearm, down to the edge
        if n % 3:
            iy, ix = int(rng.integers(h)), int(rng.integers(w))
            mask[iy:iy + 3, ix:ix + 3] = True                 # the intruder
        masks.append(mask)
    return masks


def _tracked(masks, **tracking):
    out, previous = [], None
    for mask in masks:
        previous = centroid(mask, previous=previous, **tracking)
        out.append(tuple(previous))
    return out


@pytest.mark.parametrize("tracking", [dict(track_gate=4), dict(hand_rows=3),
                                      dict(track_gate=5, hand_rows=4),
                                      dict(track_gate=40, hand_rows=1)])
def test_centroid_hand_tracking_against_the_model(tracking):
    width, height = 24, 12
    dut = Centroid(width, height, **tracking)
    masks = _tracking_masks(height, width, seed=sum(tracking.values()))
    expected = _tracked(masks, **tracking)
    # The tracking changes the result (else this test could not fail).
    assert expected != _tracked(masks)
    # The next frame starts once the gate is loaded (the pipeline's flush).
    wait = dut.cycles_after_frame + 1
    beats, last = _mask_beats(dut.i_stream.payload.shape(), masks, seed=7,
                              before=(0, 5), after=(wait, wait + 9))
    gaps = _gaps(len(beats), 0.2, 3)
    out, _ = _drive(dut, beats, gaps)
    assert _centroids(dut, out) == expected


def test_centroid_hand_rows_alone_allows_back_to_back_frames():
    width, height = 24, 12
    dut = Centroid(width, height, hand_rows=2)
    masks = _tracking_masks(height, width, seed=11)
    beats, last = _mask_beats(dut.i_stream.payload.shape(), masks, seed=6, before=(0, 0),
                              after=(0, 0))
    out, cycles = _drive(dut, beats, np.zeros(len(beats), int))
    assert _centroids(dut, out) == _tracked(masks, hand_rows=2)
    # The gate's comparisons' and the decision's registers: two cycles more.
    assert dut.cycles_after_frame == Centroid(width, height).cycles_after_frame + 2
    assert cycles == [k + dut.cycles_after_frame for k in last]
