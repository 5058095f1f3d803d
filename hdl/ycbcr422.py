"""YCbCr 4:2:2 -> 4:4:4 conversion of the camera stream (thesis §5.4, Table 11).

The camera sends a row as bytes ``Y0 Cb0 Y1 Cr0 Y2 Cb1 Y3 Cr1 ...``; the stream
here carries one 16-bit word per pixel (``luma``, ``chroma``): word k is bytes
2k and 2k+1, so an even pixel brings the Cb and an odd pixel the Cr of its pair.
Chroma is replicated to both pixels of the pair, as the golden model
:func:`sim.model.ycbcr.ycbcr422_to_444` does. An even pixel needs the Cr of the
next word, so the output runs one raster position behind the input (``lag`` = 1):
on the beat of word t the stage emits pixel t - 1 from three beat-gated
registers (the luma and chroma of word t - 1, the chroma of word t - 2) and the
chroma of word t.
"""
from __future__ import annotations

from amaranth.hdl import Module, Mux, Signal
from amaranth.lib import data, stream, wiring
from amaranth.lib.wiring import In, Out

from ._util import check_geometry, delay
from .raster_position import RasterPosition

__all__ = ["YCbCr422To444"]


class YCbCr422To444(wiring.Component):
    """Full-resolution Y, Cb, Cr of a 4:2:2 word stream.

    Parameters
    ----------
    width : even int in [8, 4096]
        Pixels per row (a row is ``2 * width`` camera bytes, ``width`` words).
    height : int in [2, 4096]

    Ports
    -----
    i_stream : payload ``{first, luma: 8, chroma: 8}``, one word per pixel in
        raster order (chroma is Cb on even pixels, Cr on odd ones).
    o_stream : payload ``{first, real, y: 8, cb: 8, cr: 8}`` for the raster
        position ``lag`` = 1 beat before the input beat; ``cycles`` = 1 (one
        output register). One flush beat after a frame emits its last pixel.

    Raises
    ------
    ValueError
        If ``width`` is odd or outside [8, 4096], or ``height`` outside [2, 4096].
    """

    lag = 1
    cycles = 1
    memory_bits = 0

    def __init__(self, width: int, height: int):
        self.width, self.height = check_geometry(width, height)
        if self.width % 2:
            raise ValueError(f"width must be even in [8, 4096] (pixels come in Cb/Cr "
                             f"pairs), got {self.width}")
        super().__init__({
            "i_stream": In(stream.Signature(data.StructLayout(
                {"first": 1, "luma": 8, "chroma": 8}), always_ready=True)),
            "o_stream": Out(stream.Signature(data.StructLayout(
                {"first": 1, "real": 1, "y": 8, "cb": 8, "cr": 8}), always_ready=True)),
        })

    def elaborate(self, platform):
        m = Module()
        beat = self.i_stream.valid
        p = self.i_stream.payload
        pos = RasterPosition(self.width, self.height, self.lag, "pix").attach(m, beat, p.first)

        # Words t - 1 and t - 2 (beat-gated, so idle cycles change nothing).
        luma1 = Signal(8)
        chroma1 = Signal(8)
        chroma2 = Signal(8)
        with m.If(beat):
            m.d.sync += [luma1.eq(p.luma), chroma1.eq(p.chroma), chroma2.eq(chroma1)]

        # The output pixel t - 1: even (x even, width even so rows start even)
        # pairs with the next word, odd with the previous one.
        even = ~pos.x[0]
        out = self.o_stream.payload
        m.d.sync += [
            out.y.eq(luma1),
            out.cb.eq(Mux(even, chroma1, chroma2)),
            out.cr.eq(Mux(even, p.chroma, chroma1)),
            out.first.eq(pos.is_first),
            out.real.eq(pos.real),
        ]
        m.d.comb += self.o_stream.valid.eq(delay(m, beat, self.cycles, "valid"))
        return m
