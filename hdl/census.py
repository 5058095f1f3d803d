"""50 % sparse census transform (thesis §6.2.1, Figs. 7b, 40 and 54).

Bit ``i`` of a code compares the neighbour at ``census_offsets(Wc)[i]`` (the
checkerboard of offsets with odd dy + dx, raster order: the bit order of the
golden model) with the window centre: 1 when ``neighbour >= centre``, 0 when the
neighbour lies outside the frame. One comparator per bit, one register stage.
"""
from __future__ import annotations

from amaranth.hdl import Cat, Module
from amaranth.lib import data, stream, wiring
from amaranth.lib.wiring import In, Out

from sim.model.census import CENSUS_WINDOW_RANGE, census_offsets

from ._util import PIXEL_BITS_RANGE, check_geometry, check_int, check_odd_window
from .stage import StageTiming
from .window import WindowGenerator, window_memory_bits, window_timing

__all__ = ["SparseCensus", "census_timing", "census_memory_bits"]


def census_timing(width: int, census_window: int) -> StageTiming:
    """The census window's look-ahead; its cycles and the comparison register."""
    window = window_timing(width, census_window)
    return StageTiming(lag=window.lag, cycles=window.cycles + 1)


def census_memory_bits(width: int, census_window: int, pixel_bits: int = 8,
                       separation: int = 0) -> int:
    """The row buffers of the census window (and of the rows up to V2)."""
    return window_memory_bits(width, window=census_window, pixel_bits=pixel_bits,
                              separation=separation)


class SparseCensus(wiring.Component):
    """Census codes of a pixel stream.

    Parameters
    ----------
    width, height : frame size (width in [max(8, Wc + 2), 4096], height in [2, 4096])
    census_window : odd int in [3, 11]
        Wc, the side of the census window; codes have ``Wc*Wc // 2`` bits.
    pixel_bits : int in [1, 16]
    separation : int in [0, 200]
        If non-zero, also output ``code2``: the census code of the pixel
        ``separation`` rows above (window V2 of Fig. 53), from the same row buffer.

    Ports
    -----
    i_stream : payload ``{first, pixel}``
    o_stream : payload ``{first, real, code[, code2]}``, ``lag`` = ``r*width + r``
        raster positions behind the input (r = Wc // 2), ``cycles`` = 3.
    """

    def __init__(self, width: int, height: int, census_window: int = 7, pixel_bits: int = 8,
                 separation: int = 0):
        self.census_window = check_odd_window("census_window", census_window,
                                              *CENSUS_WINDOW_RANGE)
        self.width, self.height = check_geometry(width, height, min_width=census_window + 2)
        self.pixel_bits = check_int("pixel_bits", pixel_bits, *PIXEL_BITS_RANGE)
        self.separation = check_int("separation", separation, 0, 200)
        self.offsets = census_offsets(self.census_window)
        self.bits = len(self.offsets)
        self.lag, self.cycles = census_timing(self.width, census_window)
        self.memory_bits = census_memory_bits(self.width, census_window=self.census_window,
                                              pixel_bits=self.pixel_bits,
                                              separation=self.separation)
        fields = {"first": 1, "real": 1, "code": self.bits}
        if separation:
            fields["code2"] = self.bits
        super().__init__({
            "i_stream": In(stream.Signature(data.StructLayout(
                {"first": 1, "pixel": pixel_bits}), always_ready=True)),
            "o_stream": Out(stream.Signature(data.StructLayout(fields), always_ready=True)),
        })

    def _code(self, taps, rows, cols):
        r = self.census_window // 2
        centre = taps[r][r]
        return Cat(*[rows[dy + r] & cols[dx + r] & (taps[dy + r][dx + r] >= centre)
                     for dy, dx in self.offsets])

    def elaborate(self, platform):
        m = Module()
        m.submodules.window = win = WindowGenerator(
            self.width, self.height, pixel_bits=self.pixel_bits, window=self.census_window,
            separation=self.separation)
        wiring.connect(m, wiring.flipped(self.i_stream), win.i_stream)
        wp = win.o_stream.payload
        out = self.o_stream.payload
        m.d.sync += [
            self.o_stream.valid.eq(win.o_stream.valid),
            out.first.eq(wp.first),
            out.real.eq(wp.real),
            out.code.eq(self._code(wp.v1, wp.rows1, wp.cols)),
        ]
        if self.separation:
            m.d.sync += out.code2.eq(self._code(wp.v2, wp.rows2, wp.cols))
        return m
