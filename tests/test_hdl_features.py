# amaranth: UnusedElaboratable=no
"""Amaranth-simulator tests of the feature hardware (thesis §7.1-7.3): the
restoring divider, the centroid unit, the moving average and gesture spotting,
each bit for bit against its golden-model function, streamed with idle cycles
(valid low) and, for the centroid, flush beats around every frame."""
import numpy as np
import pytest
from amaranth.sim import Simulator
from hypothesis import given, settings
from hypothesis import strategies as st

from hdl.centroid import Centroid
from hdl.divider import UnsignedDivider
from hdl.gesture_spotting import GestureSpotting
from hdl.moving_average import MovingAverage
from verif.streams import field, pack, run_stream
from sim.model.centroid import centroid, moment_widths
from sim.model.features import gesture_spotting, moving_average

# ------------------------------------------------------------------ divider


def _divide(dut, ops):
    """Run ``ops`` = [(dividend, divisor, idle cycles before the start)], each start
    as soon as the previous done (in the done cycle itself when idle is 0); check
    busy/done timing to the cycle and return [(quotient, remainder)]."""
    results = []

    async def tb(ctx):
        for dividend, divisor, idle in ops:
            for _ in range(idle):
                assert not ctx.get(dut.busy)
                await ctx.tick()
                assert not ctx.get(dut.done)
            ctx.set(dut.start, 1)
            ctx.set(dut.dividend, dividend)
            ctx.set(dut.divisor, divisor)
            await ctx.tick()
            ctx.set(dut.start, 0)
            for _ in range(dut.cycles - 1):
                assert ctx.get(dut.busy) and not ctx.get(dut.done)
                await ctx.tick()
            assert ctx.get(dut.done) and not ctx.get(dut.busy)
            results.append((ctx.get(dut.quotient), ctx.get(dut.remainder)))
        await ctx.tick()
        assert not ctx.get(dut.done)  # a one-cycle pulse
        assert results[-1] == (ctx.get(dut.quotient), ctx.get(dut.remainder))  # held

    sim = Simulator(dut)
    sim.add_clock(1e-8)
    sim.add_testbench(tb)
    sim.run()
    return results


def _expected_division(dividend, divisor, dividend_bits, divisor_bits):
    if divisor == 0:  # documented: all-ones quotient, low dividend bits as remainder
        return (1 << dividend_bits) - 1, dividend % (1 << divisor_bits)
    return divmod(dividend, divisor)


@pytest.mark.parametrize("dividend_bits, divisor_bits", [(1, 1), (4, 3), (3, 5), (6, 2)])
def test_divider_exhaustive_back_to_back(dividend_bits, divisor_bits):
    dut = UnsignedDivider(dividend_bits, divisor_bits)
    assert dut.cycles == dividend_bits + 1
    ops = [(a, b, 0) for a in range(1 << dividend_bits) for b in range(1 << divisor_bits)]
    got = _divide(dut, ops)
    assert got == [_expected_division(a, b, dividend_bits, divisor_bits) for a, b, _ in ops]


@pytest.mark.parametrize("dividend_bits, divisor_bits", [(36, 19), (27, 19), (64, 64)])
def test_divider_random_wide(dividend_bits, divisor_bits):
    rng = np.random.default_rng(dividend_bits)
    top_a, top_b = (1 << dividend_bits) - 1, (1 << divisor_bits) - 1
    ops = [(top_a, 1, 0), (top_a, top_b, 2), (0, top_b, 0), (top_b, top_b, 0), (5, 0, 1)]
    for _ in range(60):
        # divisors of every size, so quotients of every size
        size = int(rng.integers(1, divisor_bits + 1))
        b = max(1, int.from_bytes(rng.bytes(8), "little") % (1 << size))
        a = int.from_bytes(rng.bytes(8), "little") % (top_a + 1)
        ops.append((a, b, int(rng.integers(0, 3))))
    got = _divide(UnsignedDivider(dividend_bits, divisor_bits), ops)
    assert got == [_expected_division(a, b, dividend_bits, divisor_bits) for a, b, _ in ops]


def test_divider_start_while_busy_restarts():
    dut = UnsignedDivider(12, 6)
    seen = []

    async def tb(ctx):
        ctx.set(dut.start, 1)
        ctx.set(dut.dividend, 4000)
        ctx.set(dut.divisor, 7)
        await ctx.tick()
        ctx.set(dut.start, 0)
        await ctx.tick().repeat(4)
        ctx.set(dut.start, 1)
        ctx.set(dut.dividend, 3001)
        ctx.set(dut.divisor, 60)
        await ctx.tick()
        ctx.set(dut.start, 0)
        for cycle in range(1, 3 * dut.cycles):
            if ctx.get(dut.done):
                seen.append((cycle, ctx.get(dut.quotient), ctx.get(dut.remainder)))
            await ctx.tick()

    sim = Simulator(dut)
    sim.add_clock(1e-8)
    sim.add_testbench(tb)
    sim.run()
    assert seen == [(dut.cycles, 3001 // 60, 3001 % 60)]


# ------------------------------------------------------------------ centroid


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


# ------------------------------------------------------------------ moving average


def _feed(dut, rows, idle, seed):
    """One beat per frame (``rows``: payload dicts), random idle gaps."""
    layout = dut.i_stream.payload.shape()
    beats = [pack(layout, row) for row in rows]
    out = run_stream(dut, beats, idle=idle, seed=seed, extra_cycles=dut.cycles + 4)
    assert len(out) == len(rows)
    return dut.o_stream.payload.shape(), out


def _run_moving_average(points, valid, window, frac_bits, coord_bits=10, idle=0.4, seed=0):
    dut = MovingAverage(coord_bits, window, frac_bits)
    rows = [dict(x=int(x), y=int(y), valid=int(v)) for (x, y), v in zip(points, valid)]
    layout, out = _feed(dut, rows, idle, seed)
    got = np.stack([field(layout, out, "x"), field(layout, out, "y")], axis=1)
    return got, field(layout, out, "primed")


def _check_moving_average(points, valid, window, frac_bits, coord_bits=10, idle=0.4, seed=0):
    got, primed = _run_moving_average(points, valid, window, frac_bits, coord_bits, idle, seed)
    assert np.array_equal(got, moving_average(points, valid, window, frac_bits))
    assert np.array_equal(primed.astype(bool), np.logical_or.accumulate(valid))


def _random_track(rng, frames, coord_bits, invalid=0.3):
    points = rng.integers(0, 1 << coord_bits, (frames, 2))
    valid = rng.random(frames) >= invalid
    valid[:int(rng.integers(0, 6))] = False  # no hand yet
    return points, valid


@pytest.mark.parametrize("window", [1, 2, 4, 8, 16])
@pytest.mark.parametrize("frac_bits", [0, 4, 8])
def test_moving_average_sweep(window, frac_bits):
    rng = np.random.default_rng(window * 100 + frac_bits)
    points, valid = _random_track(rng, 70, 10)
    # extremes: every register at its maximum (the sum's width), then 0
    points[-20:-10], points[-10:] = 1023, 0
    valid[-20:] = True
    _check_moving_average(points, valid, window, frac_bits, seed=window + frac_bits)


def test_moving_average_small_coordinates_and_no_valid_frame():
    rng = np.random.default_rng(3)
    points, valid = _random_track(rng, 40, 3)
    _check_moving_average(points, valid, 8, 1, coord_bits=3)
    got, primed = _run_moving_average(points, np.zeros(40, bool), 4, 8)
    assert not got.any() and not primed.any()


@settings(max_examples=40, deadline=None)
@given(st.data())
def test_moving_average_hypothesis(data):
    window = data.draw(st.sampled_from([1, 2, 4, 8, 16]), "window")
    frac_bits = data.draw(st.integers(0, 16), "frac_bits")
    coord_bits = data.draw(st.integers(1, 16), "coord_bits")
    frames = data.draw(st.integers(1, 40), "frames")
    top = (1 << coord_bits) - 1
    points = np.array(data.draw(st.lists(st.tuples(st.integers(0, top), st.integers(0, top)),
                                         min_size=frames, max_size=frames)), dtype=np.int64)
    valid = np.array(data.draw(st.lists(st.booleans(), min_size=frames, max_size=frames)))
    idle = data.draw(st.sampled_from([0.0, 0.5]), "idle")
    _check_moving_average(points, valid, window, frac_bits, coord_bits, idle)


# ------------------------------------------------------------------ gesture spotting


def _gesture_track(rng, frames=120):
    """A hand (10-bit coordinates) resting with jitter, swiping, pausing,
    swiping back and resting, with dropouts; as raw centroids."""
    pos = np.array([300.0, 240.0])
    points, valid = [], []
    plan = []
    for _ in range(4):
        plan += [("rest", int(rng.integers(5, 25)))]
        plan += [("move", int(rng.integers(4, 15)))]
    velocity = np.zeros(2)
    for kind, length in plan:
        if kind == "move":
            velocity = rng.uniform(-25, 25, 2)
        for _ in range(length):
            if kind == "move":
                pos = np.clip(pos + velocity, 0, 1023)
            jitter = rng.integers(-2, 3, 2)
            points.append(np.clip(np.round(pos) + jitter, 0, 1023))
            valid.append(rng.random() > 0.1)
    points = np.array(points, dtype=np.int64)[:frames]
    valid = np.array(valid)[:frames]
    valid[:3] = False
    return points, valid


def _run_spotting(points, primed, point_bits=18, window=8, threshold=30, hold=16,
                  frac_bits=8, idle=0.4, seed=0):
    dut = GestureSpotting(point_bits, window, threshold, hold, frac_bits)
    rows = [dict(x=int(x), y=int(y), primed=int(p)) for (x, y), p in zip(points, primed)]
    layout, out = _feed(dut, rows, idle, seed)
    assert np.array_equal(field(layout, out, "x"), points[:, 0])  # passed through
    assert np.array_equal(field(layout, out, "y"), points[:, 1])
    flags = field(layout, out, "flag").astype(bool)
    ref = gesture_spotting(points, primed, window, threshold, hold, frac_bits)
    assert np.array_equal(flags, ref)
    return flags


@pytest.mark.parametrize("window, threshold, hold, frac_bits", [
    (1, 0, 1, 8), (1, 10, 16, 8), (8, 0, 16, 8), (8, 30, 1, 8), (8, 30, 16, 8),
    (8, 30, 16, 4), (3, 10, 5, 0), (64, 30, 16, 8)])
def test_gesture_spotting_gesture_like(window, threshold, hold, frac_bits):
    rng = np.random.default_rng(window * 7 + threshold + hold)
    points, valid = _gesture_track(rng)
    smooth = moving_average(points, valid, 4, frac_bits)
    primed = np.logical_or.accumulate(valid)
    flags = _run_spotting(smooth, primed, 10 + frac_bits, window, threshold, hold, frac_bits,
                          seed=window + hold)
    # The track has both gestures and rests at these settings (the test can fail).
    assert flags.any() and not flags.all()


@pytest.mark.parametrize("window", [1, 2, 8])
def test_gesture_spotting_random_full_range(window):
    rng = np.random.default_rng(window)
    point_bits, frames = 18, 80
    points = rng.integers(0, 1 << point_bits, (frames, 2))
    points[40:60] = points[40]  # a still stretch to end the gesture
    points[70], points[71] = (0, (1 << point_bits) - 1), ((1 << point_bits) - 1, 0)
    primed = np.arange(frames) >= 4
    _run_spotting(points, primed, point_bits, window, 1023, 8, 8, idle=0.3, seed=window)


@settings(max_examples=40, deadline=None)
@given(st.data())
def test_gesture_spotting_hypothesis(data):
    window = data.draw(st.sampled_from([1, 2, 5, 8]), "window")
    threshold = data.draw(st.sampled_from([0, 1, 3, 30]), "threshold")
    hold = data.draw(st.sampled_from([1, 2, 16]), "hold")
    frac_bits = data.draw(st.sampled_from([0, 4, 8]), "frac_bits")
    point_bits = 6 + frac_bits
    frames = data.draw(st.integers(1, 50), "frames")
    top = (1 << point_bits) - 1
    points = np.array(data.draw(st.lists(st.tuples(st.integers(0, top), st.integers(0, top)),
                                         min_size=frames, max_size=frames)), dtype=np.int64)
    primed = np.arange(frames) >= data.draw(st.integers(0, frames), "first primed")
    idle = data.draw(st.sampled_from([0.0, 0.5]), "idle")
    _run_spotting(points, primed, point_bits, window, threshold, hold, frac_bits, idle)


def test_moving_average_into_gesture_spotting_thesis_parameters():
    rng = np.random.default_rng(11)
    points, valid = _gesture_track(rng, 150)
    smooth, primed = _run_moving_average(points, valid, 4, 8, idle=0.2, seed=3)
    flags = _run_spotting(smooth, primed.astype(bool), idle=0.2, seed=4)
    assert flags.any() and not flags.all()


# ------------------------------------------------------------------ validation


@pytest.mark.parametrize("make, name", [
    (lambda: UnsignedDivider(0, 4), r"dividend_bits must be in \[1, 64\]"),
    (lambda: UnsignedDivider(8, 65), r"divisor_bits must be in \[1, 64\]"),
    (lambda: UnsignedDivider(8.0, 4), "dividend_bits must be an integer"),
    (lambda: Centroid(4, 8), r"width must be in \[8, 4096\]"),
    (lambda: Centroid(16, 1), r"height must be in \[2, 4096\]"),
    (lambda: MovingAverage(0, 4, 8), r"coord_bits must be in \[1, 16\]"),
    (lambda: MovingAverage(10, 3, 8), "window must be a power of two"),
    (lambda: MovingAverage(10, 32, 8), r"window must be in \[1, 16\]"),
    (lambda: MovingAverage(10, 4, 17), r"frac_bits must be in \[0, 16\]"),
    (lambda: GestureSpotting(point_bits=33), r"point_bits must be in \[1, 32\]"),
    (lambda: GestureSpotting(window=0), r"window must be in \[1, 64\]"),
    (lambda: GestureSpotting(window=65), r"window must be in \[1, 64\]"),
    (lambda: GestureSpotting(threshold=1024), r"threshold must be in \[0, 1023\]"),
    (lambda: GestureSpotting(hold=0), r"hold must be in \[1, 255\]"),
    (lambda: GestureSpotting(frac_bits=-1), r"frac_bits must be in \[0, 16\]"),
])
def test_bad_parameters_raise_value_error_naming_them(make, name):
    with pytest.raises(ValueError, match=name):
        make()
