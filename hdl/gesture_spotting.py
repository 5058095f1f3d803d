"""Gesture spotting: flag the frames that belong to a gesture (thesis §7.3, Figs. 78-79).

Motion is the larger coordinate change over the last ``window`` primed frames
(K); above the threshold Tm the REST/GESTURE state machine (Fig. 79) enters
GESTURE, and ``hold`` consecutive still frames bring it back to REST.

The last ``window`` points live in a ring buffer on a ``lib.memory.Memory`` (one
read and one write per frame). Instead of filling the buffer with the first
primed point (what the golden model does, ``window`` writes), a register keeps
that point and stands in for the buffer until ``window`` points were written.
"""
from __future__ import annotations

from amaranth.hdl import Cat, Module, Mux, Signal
from amaranth.lib import data, memory, stream, wiring
from amaranth.lib.wiring import In, Out

from ._util import check_int

__all__ = ["GestureSpotting", "POINT_BITS_RANGE", "WINDOW_RANGE", "THRESHOLD_RANGE",
           "HOLD_RANGE", "FRAC_BITS_RANGE"]

POINT_BITS_RANGE = (1, 32)
WINDOW_RANGE = (1, 64)
THRESHOLD_RANGE = (0, 1023)
HOLD_RANGE = (1, 255)
FRAC_BITS_RANGE = (0, 16)


class GestureSpotting(wiring.Component):
    """Per-frame gesture flag, bit for bit :func:`sim.model.gesture_spotting.gesture_spotting`.

    Parameters
    ----------
    point_bits : int in [1, 32]
        Width of the smoothed fixed-point coordinates (10.8 format: 18).
    window : int in [1, 64]
        K: motion is measured over this many primed frames (thesis: 8).
    threshold : int in [0, 1023]
        Tm in whole pixels (thesis: 30); compared with ``threshold << frac_bits``.
    hold : int in [1, 255]
        Consecutive still frames that end a gesture.
    frac_bits : int in [0, 16]
        Fraction bits of the coordinates.

    Ports
    -----
    i_stream : payload ``{x, y: point_bits, primed: 1}`` (always ready)
        One beat per frame, as :class:`~hdl.moving_average.MovingAverage` emits it.
        Unprimed beats change nothing.
    o_stream : payload ``{x, y: point_bits, flag: 1}`` (always ready)
        One beat per input beat, ``cycles`` clock cycles later: ``x``, ``y``
        passed through, ``flag`` high where the state is GESTURE after the frame.

    Attributes
    ----------
    cycles : int
        4: ring-buffer read, absolute differences, threshold, state machine.
    """

    cycles = 4

    def __init__(self, point_bits: int = 18, window: int = 8, threshold: int = 30,
                 hold: int = 16, frac_bits: int = 8):
        self.point_bits = check_int("point_bits", point_bits, *POINT_BITS_RANGE)
        self.window = check_int("window", window, *WINDOW_RANGE)
        self.threshold = check_int("threshold", threshold, *THRESHOLD_RANGE)
        self.hold = check_int("hold", hold, *HOLD_RANGE)
        self.frac_bits = check_int("frac_bits", frac_bits, *FRAC_BITS_RANGE)
        self.limit = self.threshold << self.frac_bits
        self.memory_bits = self.window * 2 * self.point_bits
        pb = self.point_bits
        super().__init__({
            "i_stream": In(stream.Signature(data.StructLayout(
                {"x": pb, "y": pb, "primed": 1}), always_ready=True)),
            "o_stream": Out(stream.Signature(data.StructLayout(
                {"x": pb, "y": pb, "flag": 1}), always_ready=True)),
        })

    def elaborate(self, platform):
        m = Module()
        pb, k = self.point_bits, self.window
        p = self.i_stream.payload
        beat = self.i_stream.valid
        update = beat & p.primed
        point = Cat(p.x, p.y)

        m.submodules.ring = ring = memory.Memory(shape=2 * pb, depth=k, init=[])
        wr = ring.write_port()
        # Transparent: with window 1 the point written by a beat is read back by
        # the very next beat in the same cycle.
        rd = ring.read_port(transparent_for=(wr,))
        ptr = Signal(range(k), name="oldest")
        seen = Signal(range(k + 1))   # primed points so far, saturating at window
        first_point = Signal(2 * pb)  # stands in for the buffer until it is full

        # Stage 1 (the beat): read the oldest entry, advance the pointer.
        s1_valid, s1_update, s1_full = Signal(), Signal(), Signal()
        s1_point = Signal(2 * pb)
        s1_addr = Signal(range(k))
        m.d.comb += [rd.addr.eq(ptr), rd.en.eq(update)]
        m.d.sync += [s1_valid.eq(beat), s1_update.eq(update), s1_point.eq(point),
                     s1_addr.eq(ptr), s1_full.eq(seen == k)]
        with m.If(update):
            m.d.sync += ptr.eq(Mux(ptr == k - 1, 0, ptr + 1))
            with m.If(seen != k):
                m.d.sync += seen.eq(seen + 1)
            with m.If(seen == 0):
                m.d.sync += first_point.eq(point)

        # Stage 2: write the point in place of the oldest; |dx|, |dy|.
        m.d.comb += [wr.addr.eq(s1_addr), wr.data.eq(s1_point), wr.en.eq(s1_update)]
        oldest = Mux(s1_full, rd.data, first_point)
        s2_valid, s2_update = Signal(), Signal()
        s2_point = Signal(2 * pb)
        s2_abs = [Signal(pb, name=f"abs_d{axis}") for axis in "xy"]
        m.d.sync += [s2_valid.eq(s1_valid), s2_update.eq(s1_update), s2_point.eq(s1_point)]
        for i, reg in enumerate(s2_abs):
            a, b = s1_point[i * pb:(i + 1) * pb], oldest[i * pb:(i + 1) * pb]
            m.d.sync += reg.eq(Mux(a >= b, a - b, b - a))

        # Stage 3: max(|dx|, |dy|) > Tm << frac_bits, i.e. either exceeds it. Its
        # own register: from |dy| to the state was a routed limit.
        s3_valid, s3_update, s3_moving = Signal(), Signal(), Signal()
        s3_point = Signal(2 * pb)
        m.d.sync += [s3_valid.eq(s2_valid), s3_update.eq(s2_update), s3_point.eq(s2_point),
                     s3_moving.eq((s2_abs[0] > self.limit) | (s2_abs[1] > self.limit))]

        # Stage 4: the REST/GESTURE state machine (Fig. 79) with its still-frame counter.
        gesture = Signal()
        still = Signal(range(self.hold))
        next_gesture = Signal()
        m.d.comb += next_gesture.eq(gesture)
        with m.If(s3_update):
            with m.If(s3_moving):
                m.d.comb += next_gesture.eq(1)
                m.d.sync += still.eq(0)
            with m.Elif(gesture):
                with m.If(still == self.hold - 1):
                    m.d.comb += next_gesture.eq(0)
                    m.d.sync += still.eq(0)
                with m.Else():
                    m.d.sync += still.eq(still + 1)
        m.d.sync += gesture.eq(next_gesture)
        out = self.o_stream.payload
        m.d.sync += [
            self.o_stream.valid.eq(s3_valid),
            out.x.eq(s3_point[:pb]), out.y.eq(s3_point[pb:]),
            out.flag.eq(next_gesture & s3_update),
        ]
        return m
