# amaranth: UnusedElaboratable=no
"""Hand centroid from the image moments of the mask (thesis §7.1, eq. 23-24, Fig. 72).

While the opened hand mask streams past, three accumulators sum the moments
``M00`` (set pixels), ``M10`` (their x) and ``M01`` (their y) (eq. 23). The beat of
the frame's last pixel starts two :class:`~hdl.divider.UnsignedDivider` in
parallel, ``x = M10 // M00`` and ``y = M01 // M00`` (eq. 24); they latch the
moments, so the accumulators are free for the next frame at once, and finish
long before that frame ends.
"""
from __future__ import annotations

from amaranth.hdl import Module, Mux, Signal
from amaranth.lib import data, stream, wiring
from amaranth.lib.wiring import In, Out

from sim.model.centroid import moment_widths

from ._util import bits_for, check_geometry
from .divider import UnsignedDivider, divider_cycles
from .raster_position import RasterPosition
from .streams import pixel_signature

__all__ = ["Centroid", "centroid_cycles_after_frame"]


def centroid_cycles_after_frame(width: int, height: int) -> int:
    """Clock cycles from the frame's last pixel beat to the centroid's beat: one
    to see the beat, the wider division, one output register."""
    widths = moment_widths(width, height)
    return divider_cycles(max(widths.m10, widths.m01)) + 2


class Centroid(wiring.Component):
    """One centroid ``(x, y, area)`` per frame of a binary mask stream.

    Equal to :func:`sim.model.centroid.centroid` of the frame's mask:
    ``x = M10 // M00``, ``y = M01 // M00``, ``area = M00``; an empty mask gives
    (0, 0, 0). Accumulator widths are :func:`sim.model.centroid.moment_widths`.

    Parameters
    ----------
    width : int in [8, 4096]
    height : int in [2, 4096]

    Ports
    -----
    i_stream : payload ``{first, real, pixel: 1}`` (always ready)
        The mask as a window stage emits it: only beats with ``real`` high are
        frame pixels (``width * height`` of them in raster order, ``first`` on the
        first); non-real beats (flush) are ignored. Idle cycles may occur anywhere.
    o_stream : payload ``{x: bits_for(width - 1), y: bits_for(height - 1),
        area: moment_widths(width, height).m00}`` (always ready)
        One beat per frame, ``cycles_after_frame`` clock cycles after the beat of
        the frame's last pixel. The next frame may start right after that beat.

    Attributes
    ----------
    cycles_after_frame : int
        ``dividend_bits + 3`` with ``dividend_bits = max(M10, M01 widths)``: one
        cycle to see the last pixel's beat, the divider's ``cycles``, one output
        register.
    widths : MomentWidths
        Accumulator widths.
    """

    def __init__(self, width: int, height: int):
        self.width, self.height = check_geometry(width, height)
        self.widths = moment_widths(self.width, self.height)
        self._div_x = UnsignedDivider(dividend_bits=self.widths.m10, divisor_bits=self.widths.m00)
        self._div_y = UnsignedDivider(dividend_bits=self.widths.m01, divisor_bits=self.widths.m00)
        self.cycles_after_frame = centroid_cycles_after_frame(self.width, self.height)
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
                {"x": self.x_bits, "y": self.y_bits, "area": self.widths.m00}),
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
        y = pos.y[:self.y_bits]  # inside the frame y >= 0
        with m.If(beat):
            m.d.sync += [
                m00.eq(Mux(p.first, 0, m00) + p.pixel),
                m10.eq(Mux(p.first, 0, m10) + Mux(p.pixel, pos.x, 0)),
                m01.eq(Mux(p.first, 0, m01) + Mux(p.pixel, y, 0)),
            ]
        # The cycle after the last pixel's beat the accumulators hold the frame's
        # moments (even if the next frame's first beat overwrites them at the end
        # of that cycle): the dividers and the area register sample them then.
        start = Signal()
        m.d.sync += start.eq(beat & is_last)
        area = Signal(self.widths.m00)
        with m.If(start):
            m.d.sync += area.eq(m00)

        m.submodules.div_x = div_x = self._div_x
        m.submodules.div_y = div_y = self._div_y
        for div, dividend in ((div_x, m10), (div_y, m01)):
            m.d.comb += [div.start.eq(start), div.dividend.eq(dividend), div.divisor.eq(m00)]
        # The slower divider's done: both quotients are ready (and held).
        done = div_x.done if div_x.cycles >= div_y.cycles else div_y.done
        empty = area == 0  # no hand: (0, 0, 0) instead of the divide-by-0 quotient
        out = self.o_stream.payload
        m.d.sync += [
            self.o_stream.valid.eq(done),
            out.x.eq(Mux(empty, 0, div_x.quotient)),
            out.y.eq(Mux(empty, 0, div_y.quotient)),
            out.area.eq(area),
        ]
        return m
