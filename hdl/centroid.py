"""Hand centroid from the image moments of the mask (thesis §7.1, eq. 23-24, Fig. 72).

While the opened hand mask streams past, three accumulators sum the moments
``M00`` (set pixels), ``M10`` (their x) and ``M01`` (their y) (eq. 23). The beat of
the frame's last pixel starts two :class:`~hdl.divider.UnsignedDivider` in
parallel, ``x = M10 // M00`` and ``y = M01 // M00`` (eq. 24); they latch the
moments, so the accumulators are free for the next frame at once, and finish
long before that frame ends.

Hand tracking (``track_gate``, ``hand_rows``; off by default, see
:mod:`sim.model.centroid`) decides per beat whether a pixel counts: the gate's
bounds are registers loaded from each output beat (the whole frame after reset or
a frame without hand), the row limit a register loaded at the frame's first
counted pixel. The next frame's first pixel must therefore come after the output
beat, which the pipeline's flush beats guarantee (``GesturePipeline`` checks).
"""
from __future__ import annotations

from amaranth.hdl import Module, Mux, Signal
from amaranth.lib import data, stream, wiring
from amaranth.lib.wiring import In, Out

from sim.model.centroid import HAND_ROWS_RANGE, TRACK_GATE_RANGE, moment_widths
from sim.model.validation import check_int

from ._util import bits_for, check_geometry
from .divider import UnsignedDivider, divider_cycles
from .raster_position import RasterPosition
from .streams import pixel_signature

__all__ = ["Centroid", "centroid_cycles_after_frame", "GATE_LOAD_CYCLES"]

#: Hand tracking: cycles from the output beat until the gate holds its bounds.
GATE_LOAD_CYCLES = 1


def centroid_cycles_after_frame(width: int, height: int, tracking: bool = False) -> int:
    """Clock cycles from the frame's last pixel beat to the centroid's beat: one
    to see the beat, the wider division, one output register; two more with
    hand tracking (the gate's comparisons' register, the decision's)."""
    widths = moment_widths(width, height)
    return divider_cycles(max(widths.m10, widths.m01)) + 2 + 2 * bool(tracking)


class Centroid(wiring.Component):
    """One centroid ``(x, y, area)`` per frame of a binary mask stream.

    Equal to :func:`sim.model.centroid.centroid` of the frame's mask (with the
    previous output as ``previous``):
    ``x = M10 // M00``, ``y = M01 // M00``, ``area = M00``; an empty mask gives
    (0, 0, 0). Accumulator widths are :func:`sim.model.centroid.moment_widths`.

    Parameters
    ----------
    width : int in [8, 4096]
    height : int in [2, 4096]
    track_gate : int in [0, 4095]
        Hand tracking's gate half-size in pixels around the previous frame's
        centroid; 0 (the thesis) counts the whole frame.
    hand_rows : int in [0, 4096]
        Hand tracking's rows counted from the first counted pixel's row; 0 (the
        thesis) counts every row.

    Ports
    -----
    i_stream : payload ``{first, real, pixel: 1}`` (always ready)
        The mask as a window stage emits it: only beats with ``real`` high are
        frame pixels (``width * height`` of them in raster order, ``first`` on the
        first); non-real beats (flush) are ignored. Idle cycles may occur anywhere.
    o_stream : payload ``{x: bits_for(width - 1), y: bits_for(height - 1),
        area: moment_widths(width, height).m00, hand: 1}`` (always ready)
        ``hand`` is ``area != 0`` from a register of its own, so a stage
        behind that needs only whether a hand was seen has no comparison of
        ``area``'s bits in front of its input register (routed, that comparison
        and the way to the moving average cost 9.2 ns on a placement).
        One beat per frame, ``cycles_after_frame`` clock cycles after the beat of
        the frame's last pixel. The next frame may start right after that beat.

    Attributes
    ----------
    cycles_after_frame : int
        ``dividend_bits + 3`` with ``dividend_bits = max(M10, M01 widths)``: one
        cycle to see the last pixel's beat, the divider's ``cycles``, one output
        register; two more with hand tracking.
    widths : MomentWidths
        Accumulator widths.
    """

    def __init__(self, width: int, height: int, *, track_gate: int = 0, hand_rows: int = 0):
        self.width, self.height = check_geometry(width, height)
        self.track_gate = check_int("track_gate", track_gate, *TRACK_GATE_RANGE)
        self.hand_rows = check_int("hand_rows", hand_rows, *HAND_ROWS_RANGE)
        self.widths = moment_widths(self.width, self.height)
        self.tracking = bool(self.track_gate or self.hand_rows)
        self.cycles_after_frame = centroid_cycles_after_frame(self.width, self.height,
                                                              self.tracking)
        # The dividers latch the moments on the start; the next start (one frame
        # later) must find them idle, so a frame must outlast a division.
        if self.width * self.height <= self.cycles_after_frame:
            raise ValueError(
                f"width * height must exceed cycles_after_frame = {self.cycles_after_frame} "
                f"(frames would overlap the division), got {self.width * self.height}")
        self.x_bits = bits_for(self.width - 1)
        self.y_bits = bits_for(self.height - 1)
        super().__init__({
            "i_stream": In(pixel_signature(1, real=True)),
            "o_stream": Out(stream.Signature(data.StructLayout(
                {"x": self.x_bits, "y": self.y_bits, "area": self.widths.m00, "hand": 1}),
                always_ready=True)),
        })

    def elaborate(self, platform):
        m = Module()
        w, h = self.width, self.height
        p = self.i_stream.payload
        beat = self.i_stream.valid & p.real  # flush beats do not move the position
        pos = RasterPosition(w, h, 0, "pix").attach(m, beat, p.first)
        is_last = pos.registered(lambda x, y: (x == w - 1) & (y == h - 1), "last")

        # Moment accumulators (eq. 23); ``first`` restarts them (x = y = 0 there).
        m00 = Signal(self.widths.m00)
        m10 = Signal(self.widths.m10)
        m01 = Signal(self.widths.m01)
        x = pos.x[:self.x_bits]  # inside the frame 0 <= x < width
        y = pos.y[:self.y_bits]
        first, count = p.first, p.pixel
        gate = None
        if self.track_gate:     # x_lo, x_hi, y_lo, y_hi: the whole frame after reset
            gate = [Signal(self.x_bits, name="gate_x_lo"),
                    Signal(self.x_bits, name="gate_x_hi", init=self.width - 1),
                    Signal(self.y_bits, name="gate_y_lo"),
                    Signal(self.y_bits, name="gate_y_hi", init=self.height - 1)]
        if self.tracking:
            # Two register stages: the gate's comparisons, then the decision
            # (the row limit and whether the pixel counts), so that neither a
            # comparison nor the decision lies in front of the adders, and the
            # row limit's update follows a register (two cycles later; routed,
            # the comparisons into that update were the calibrated pipeline's
            # limit on one placement).
            in_gate = Signal(name="in_gate")
            m.d.sync += in_gate.eq(self._in_gate(gate, x, y))
            names = ("beat", "first", "pixel", "x", "y", "last")
            staged = [Signal.like(v, name=f"{name}_staged") for name, v in
                      zip(names, (beat, first, count, x, y, is_last))]
            m.d.sync += [s.eq(v) for s, v in zip(staged, (beat, first, count, x, y, is_last))]
            beat, first, count, x, y, is_last = staged
            decided = [Signal.like(v, name=f"{name}_decided") for name, v in
                       zip(names, (beat, first, count, x, y, is_last))]
            m.d.sync += [d.eq(v) for d, v in zip(decided, (
                beat, first, self._counted(m, in_gate, beat, first, count, y), x, y, is_last))]
            beat, first, count, x, y, is_last = decided
        with m.If(beat):
            m.d.sync += [
                m00.eq(Mux(first, 0, m00) + count),
                m10.eq(Mux(first, 0, m10) + Mux(count, x, 0)),
                m01.eq(Mux(first, 0, m01) + Mux(count, y, 0)),
            ]
        # The cycle after the last pixel's beat the accumulators hold the frame's
        # moments (even if the next frame's first beat overwrites them at the end
        # of that cycle): the dividers and the area register sample them then.
        start = Signal()
        m.d.sync += start.eq(beat & is_last)
        area = Signal(self.widths.m00)
        hand = Signal()
        with m.If(start):
            m.d.sync += [area.eq(m00), hand.eq(m00 != 0)]

        m.submodules.div_x = div_x = UnsignedDivider(dividend_bits=self.widths.m10,
                                                     divisor_bits=self.widths.m00)
        m.submodules.div_y = div_y = UnsignedDivider(dividend_bits=self.widths.m01,
                                                     divisor_bits=self.widths.m00)
        for div, dividend in ((div_x, m10), (div_y, m01)):
            m.d.comb += [div.start.eq(start), div.dividend.eq(dividend), div.divisor.eq(m00)]
        # The slower divider's done: both quotients are ready (and held).
        done = div_x.done if div_x.cycles >= div_y.cycles else div_y.done
        out = self.o_stream.payload
        m.d.sync += [   # no hand: (0, 0, 0) instead of the divide-by-0 quotient
            self.o_stream.valid.eq(done),
            out.x.eq(Mux(hand, div_x.quotient, 0)),
            out.y.eq(Mux(hand, div_y.quotient, 0)),
            out.area.eq(area),
            out.hand.eq(hand),
        ]
        if gate is not None:
            self._update_gate(m, gate)
        return m

    @staticmethod
    def _in_gate(gate, x, y):
        """Whether (x, y) lies inside the ``gate`` registers (always without a gate)."""
        if gate is None:
            return 1
        x_lo, x_hi, y_lo, y_hi = gate
        return (x >= x_lo) & (x <= x_hi) & (y >= y_lo) & (y <= y_hi)

    def _counted(self, m, in_gate, beat, first, pixel, y):
        """Whether the beat's pixel counts: set, inside the gate (``in_gate``) and
        within the row limit (if ``hand_rows``)."""
        count = pixel & in_gate
        if self.hand_rows:
            seen = Signal()        # a pixel of this frame has counted
            row_end = Signal(bits_for(self.height + self.hand_rows))
            fresh = first | ~seen
            with m.If(beat):
                # (the first counted pixel needs no comparison: no row limit yet)
                with m.If(count & fresh):
                    m.d.sync += [seen.eq(1), row_end.eq(y + self.hand_rows)]
                with m.Elif(first):
                    m.d.sync += seen.eq(0)
            count = count & (fresh | (y < row_end))
        return count

    def _update_gate(self, m, gate):
        """Load the ``gate`` registers from the output beat: the square around the
        centroid, clipped to the frame, or the whole frame when there was no hand.

        The new bounds are registered first, and the load waits for a copy of
        the output's valid (:data:`GATE_LOAD_CYCLES` after the beat): the gate
        sits by the pixel stream, the output by the stages behind, and one
        net from the output's valid to both spanned the chip (11.7 ns routed)."""
        r, out = self.track_gate, self.o_stream.payload
        load = Signal(name="gate_load")
        m.d.sync += load.eq(self.o_stream.valid)
        bounds = []
        for axis, c, top, bits in (("x", out.x, self.width - 1, self.x_bits),
                                   ("y", out.y, self.height - 1, self.y_bits)):
            lo, hi = (Signal(bits, name=f"gate_next_{axis}_{end}") for end in ("lo", "hi"))
            m.d.sync += [lo.eq(Mux(out.hand, Mux(c > r, c - r, 0), 0)),
                         hi.eq(Mux(~out.hand | (c + r >= top), top, c + r))]
            bounds += [lo, hi]
        with m.If(load):
            m.d.sync += [g.eq(b) for g, b in zip(gate, bounds)]
