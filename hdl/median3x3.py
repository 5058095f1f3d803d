"""3x3 median filter (thesis §6.1, Figs. 36-37), generic in the pixel width so the
camera pipeline (8-bit luma) and the stereo matcher (disparities) share it.

A :class:`~hdl.window.WindowGenerator` (two row buffers) provides the nine
taps; an odd-even transposition sorting network of nine layers of
compare-and-swap cells, one register stage per layer, sorts them and the fifth
is the median. Border policy (as the golden model): a pixel whose 3x3 window
leaves the frame passes through unchanged.
"""
from __future__ import annotations

from amaranth.hdl import Module, Mux, Signal
from amaranth.lib import wiring
from amaranth.lib.wiring import In, Out

from ._util import PIXEL_BITS_RANGE, check_geometry, check_int, delay
from .stage import StageTiming
from .streams import pixel_signature
from .window import WindowGenerator, window_memory_bits, window_timing

__all__ = ["Median3x3", "median_timing", "median_memory_bits"]

TAPS = 9


def median_timing(width: int) -> StageTiming:
    """The 3x3 window's look-ahead; its cycles, the network's 9 layers and the
    output register."""
    window = window_timing(width, 3)
    return StageTiming(lag=window.lag, cycles=window.cycles + TAPS + 1)


def median_memory_bits(width: int, pixel_bits: int) -> int:
    """The row buffers of the 3x3 window (two rows of ``width - 3`` pixels)."""
    return window_memory_bits(width, window=3, pixel_bits=pixel_bits)


class Median3x3(wiring.Component):
    """Median of each 3x3 neighbourhood of a pixel stream.

    Parameters
    ----------
    width : int in [8, 4096]
    height : int in [2, 4096]
    pixel_bits : int in [1, 16]

    Ports
    -----
    i_stream : payload ``{first, pixel}``
    o_stream : payload ``{first, real, pixel}``, ``lag`` = width + 1 raster
        positions behind the input, ``cycles`` = 2 + 9 + 1.
    """

    def __init__(self, width: int, height: int, pixel_bits: int = 8):
        self.width, self.height = check_geometry(width, height)
        self.pixel_bits = check_int("pixel_bits", pixel_bits, *PIXEL_BITS_RANGE)
        self.lag, self.cycles = median_timing(self.width)
        self.memory_bits = median_memory_bits(self.width, pixel_bits=self.pixel_bits)
        super().__init__({
            "i_stream": In(pixel_signature(pixel_bits)),
            "o_stream": Out(pixel_signature(pixel_bits, real=True)),
        })

    def elaborate(self, platform):
        m = Module()
        m.submodules.window = win = WindowGenerator(self.width, self.height,
                                                    pixel_bits=self.pixel_bits, window=3)
        wiring.connect(m, wiring.flipped(self.i_stream), win.i_stream)
        wp = win.o_stream.payload
        pb = self.pixel_bits
        values = [wp.v1[i][j] for i in range(3) for j in range(3)]
        for layer in range(TAPS):
            nxt = [Signal(pb, name=f"sort_l{layer}_{k}", reset_less=True) for k in range(TAPS)]
            for k in range(TAPS):
                m.d.sync += nxt[k].eq(values[k])
            for low in range(layer % 2, TAPS - 1, 2):
                a, b = values[low], values[low + 1]
                m.d.sync += [nxt[low].eq(Mux(b < a, b, a)), nxt[low + 1].eq(Mux(b < a, a, b))]
            values = nxt
        interior = (wp.rows1 == 0b111) & (wp.cols == 0b111)
        centre = delay(m, wp.v1[1][1], TAPS, "centre")
        interior = delay(m, interior, TAPS, "interior")
        out = self.o_stream.payload
        m.d.sync += [
            self.o_stream.valid.eq(delay(m, win.o_stream.valid, TAPS, "valid")),
            out.first.eq(delay(m, wp.first, TAPS, "first")),
            out.real.eq(delay(m, wp.real, TAPS, "real")),
            out.pixel.eq(Mux(interior, values[TAPS // 2], centre)),
        ]
        return m
