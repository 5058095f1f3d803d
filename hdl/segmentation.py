"""Hand segmentation: skin colour AND a disparity band (thesis §6.3, eq. 22, Fig. 58).

The skin test (eq. 22) looks at the chroma of the left camera, which leaves the
4:2:2 -> 4:4:4 stage long before the disparity of the same pixel leaves the
stereo matcher. As in Fig. 58, the one-bit skin result goes through a delay line
(:class:`~hdl.delay_line.BeatDelay`) of ``skin_delay_beats`` beats (the matcher's
look-ahead) and ``skin_delay_cycles`` clock cycles (its pipeline), less the
register stage of the skin comparators, so it meets the disparity of its pixel
exactly; there the band test ``low < d < high`` and the AND give the hand mask.
"""
from __future__ import annotations

from amaranth.hdl import Module, Signal
from amaranth.lib import data, stream, wiring
from amaranth.lib.wiring import In, Out

from sim.model.segmentation import check_band
from sim.model.validation import check_byte_range

from ._util import bits_for, check_geometry, check_int, delay
from .delay_line import BEATS_RANGE, CYCLES_RANGE, MEMORY_MIN_BEATS, BeatDelay, \
    delay_memory_bits
from .row_buffer import RowBuffer

__all__ = ["HandSegmentation", "segmentation_memory_bits"]


def segmentation_memory_bits(skin_delay_beats: int) -> int:
    """The memory of the skin delay line (one bit per beat, when it is long
    enough to be a memory)."""
    return delay_memory_bits(bits=1, beats=skin_delay_beats)


class HandSegmentation(wiring.Component):
    """Skin, band and hand bits of each pixel of the disparity stream.

    Parameters
    ----------
    width : int in [8, 4096]
    height : int in [2, 4096]
    max_disparity : int in [2, 255]
        D, disparities 0 .. D-1 (thesis 48); ``disparity`` has
        ``bits_for(D - 1)`` bits.
    skin_cb, skin_cr : pair ``(lo, hi)`` with 0 <= lo <= hi <= 255
        Inclusive skin box of eq. 22 (thesis Cb in [77, 127], Cr in [133, 173]).
    band_low : int in [0, D - 2]
        Exclusive lower disparity threshold TL (thesis 33).
    band_high : int in [band_low + 1, D - 1] or None
        Exclusive upper threshold TH; None means D - 2 (thesis 46).
    skin_delay_beats : int in [0, 65536]
        Beats between a chroma beat and the disparity beat of the same pixel.
    skin_delay_cycles : int in [0, 4096]
        Clock cycles between beat t of ``i_chroma`` and beat t of
        ``i_disparity``. When at least 1, the skin comparators get a register
        stage of their own, taken out of the delay line.

    Ports
    -----
    i_chroma : In, payload ``{first, cb: 8, cr: 8}``, the left chroma stream
        (``first`` is not used: positions come from ``i_disparity``).
    i_disparity : In, payload ``{first, real, disparity}``: beat t arrives
        ``skin_delay_cycles`` clock cycles after beat t of ``i_chroma`` and
        belongs to the pixel of chroma beat t - ``skin_delay_beats``.
    o_stream : Out, payload ``{first, real, skin, band, hand}``, one beat per
        ``i_disparity`` beat, ``cycles`` = 1 clock cycle later, ``lag`` = 0
        raster positions behind ``i_disparity`` (``first`` and ``real`` are
        its own).

    Attributes
    ----------
    lag, cycles : int (relative to ``i_disparity``)
    skin_stages : int, register stages of the skin test inside the delay (0 or 1)
    memory_bits : int, memory of the skin delay line
    """

    lag = 0
    cycles = 1

    def __init__(self, width: int, height: int, max_disparity: int = 48,
                 skin_cb=(77, 127), skin_cr=(133, 173), band_low: int = 33,
                 band_high: int | None = None, skin_delay_beats: int = 0,
                 skin_delay_cycles: int = 0):
        self.width, self.height = check_geometry(width, height)
        self.band_low, self.band_high, self.max_disparity = check_band(
            band_low, band_high, max_disparity, names=("band_low", "band_high"))
        self.skin_cb = check_byte_range("skin_cb", skin_cb)
        self.skin_cr = check_byte_range("skin_cr", skin_cr)
        self.skin_delay_beats = check_int("skin_delay_beats", skin_delay_beats, *BEATS_RANGE)
        # The implementation needs no cycle (the comparators can feed the line
        # directly); from one cycle on they get their own register.
        self.skin_delay_cycles = check_int("skin_delay_cycles", skin_delay_cycles,
                                           *CYCLES_RANGE)
        self.skin_stages = min(1, self.skin_delay_cycles)
        line_cycles = RowBuffer.cycles if self.skin_delay_beats >= MEMORY_MIN_BEATS else 0
        if self.skin_delay_cycles - self.skin_stages < line_cycles:
            raise ValueError(f"skin_delay_cycles must be at least {line_cycles + 1} for "
                             f"skin_delay_beats >= {MEMORY_MIN_BEATS} (the delay line's "
                             f"memory read and register, the comparators' register), got "
                             f"{self.skin_delay_cycles}")
        self.disparity_bits = bits_for(self.max_disparity - 1)
        self.memory_bits = segmentation_memory_bits(skin_delay_beats=self.skin_delay_beats)
        super().__init__({
            "i_chroma": In(stream.Signature(data.StructLayout(
                {"first": 1, "cb": 8, "cr": 8}), always_ready=True)),
            "i_disparity": In(stream.Signature(data.StructLayout(
                {"first": 1, "real": 1, "disparity": self.disparity_bits}), always_ready=True)),
            "o_stream": Out(stream.Signature(data.StructLayout(
                {"first": 1, "real": 1, "skin": 1, "band": 1, "hand": 1}), always_ready=True)),
        })

    def elaborate(self, platform):
        m = Module()
        c = self.i_chroma.payload
        (cb_lo, cb_hi), (cr_lo, cr_hi) = self.skin_cb, self.skin_cr
        skin = Signal()
        m.d.comb += skin.eq((c.cb >= cb_lo) & (c.cb <= cb_hi) & (c.cr >= cr_lo) & (c.cr <= cr_hi))

        # Skin bit of chroma beat t - beats, in the cycle of disparity beat t.
        m.submodules.skin_line = line = BeatDelay(
            bits=1, beats=self.skin_delay_beats,
            cycles=self.skin_delay_cycles - self.skin_stages)
        m.d.comb += [
            line.i_stream.valid.eq(delay(m, self.i_chroma.valid, self.skin_stages, "skin_valid")),
            line.i_stream.payload.data.eq(delay(m, skin, self.skin_stages, "skin_reg")),
        ]
        skin_aligned = line.o_stream.payload.data

        d = self.i_disparity.payload
        band = Signal()
        m.d.comb += band.eq((d.disparity > self.band_low) & (d.disparity < self.band_high))
        out = self.o_stream.payload
        m.d.sync += [
            out.first.eq(d.first),
            out.real.eq(d.real),
            out.skin.eq(skin_aligned),
            out.band.eq(band),
            out.hand.eq(skin_aligned & band),
        ]
        m.d.comb += self.o_stream.valid.eq(delay(m, self.i_disparity.valid, self.cycles, "valid"))
        return m
