"""Moving average of the centroid trajectory in fixed point (thesis §7.2, eq. 27, Fig. 75).

A shift register keeps the last ``window`` valid centroids; a running sum
(``sum += new - oldest``) replaces the adder tree of Fig. 75, and the division by
the power-of-two ``window`` together with the ``frac_bits`` scaling is a fixed
shift, i.e. wiring.
"""
from __future__ import annotations

from amaranth.hdl import Module, Mux, Signal
from amaranth.lib import data, stream, wiring
from amaranth.lib.wiring import In, Out

from ._util import check_int, register_input

__all__ = ["MovingAverage", "COORD_BITS_RANGE", "WINDOW_RANGE", "FRAC_BITS_RANGE"]

COORD_BITS_RANGE = (1, 16)
WINDOW_RANGE = (1, 16)   # powers of two only (the model's range)
FRAC_BITS_RANGE = (0, 16)


class MovingAverage(wiring.Component):
    """Per-frame smoothing of the centroid, bit for bit
    :func:`sim.model.moving_average.moving_average`.

    Parameters
    ----------
    coord_bits : int in [1, 16]
        Width of the input coordinates (10 for 640x480).
    window : int, power of two in [1, 16]
        Number of valid centroids averaged (thesis: 4).
    frac_bits : int in [0, 16]
        Fraction bits of the output (thesis 10.8 format: 8).

    Ports
    -----
    i_stream : payload ``{x, y: coord_bits, valid: 1}`` (always ready)
        One beat per frame; ``valid`` low (no hand, area 0) leaves the register
        unchanged. The first valid centroid fills the whole register.
    o_stream : payload ``{x, y: coord_bits + frac_bits, primed: 1}`` (always ready)
        One beat per input beat, ``cycles`` clock cycles later:
        ``(sum(history) << frac_bits) >> log2(window)`` (0 before the first valid
        frame) and ``primed`` = a valid frame was seen so far.

    Attributes
    ----------
    cycles : int
        2: the input is registered, with a copy of its valid per axis and one
        for the rest (the centroid's output valid reached every history
        register of both axes: 77 sinks, 8 ns routed on an ECP5), and the
        output is wired from the state registers.
    """

    cycles = 2

    def __init__(self, coord_bits: int = 10, window: int = 4, frac_bits: int = 8):
        self.coord_bits = check_int("coord_bits", coord_bits, *COORD_BITS_RANGE)
        self.window = check_int("window", window, *WINDOW_RANGE)
        if self.window & (self.window - 1):
            raise ValueError(f"window must be a power of two in [1, 16] "
                             f"(the hardware divides by shifting), got {window}")
        self.frac_bits = check_int("frac_bits", frac_bits, *FRAC_BITS_RANGE)
        self.shift = self.window.bit_length() - 1
        self.out_bits = self.coord_bits + self.frac_bits
        super().__init__({
            "i_stream": In(stream.Signature(data.StructLayout(
                {"x": self.coord_bits, "y": self.coord_bits, "valid": 1}), always_ready=True)),
            "o_stream": Out(stream.Signature(data.StructLayout(
                {"x": self.out_bits, "y": self.out_bits, "primed": 1}), always_ready=True)),
        })

    def _scaled(self, total):
        """``(total << frac_bits) >> shift`` as wiring (floor when frac_bits < shift)."""
        if self.frac_bits >= self.shift:
            return total << (self.frac_bits - self.shift)
        return total >> (self.shift - self.frac_bits)

    def elaborate(self, platform):
        m = Module()
        cb, n = self.coord_bits, self.window
        p, beats = register_input(m, self.i_stream, 3, "input")
        primed = Signal()
        with m.If(beats[2] & p.valid):
            m.d.sync += primed.eq(1)
        out = self.o_stream.payload
        for axis, beat in zip(("x", "y"), beats):
            update = beat & p.valid
            new = getattr(p, axis)
            history = [Signal(cb, name=f"{axis}_hist{k}") for k in range(n)]
            total = Signal(cb + self.shift, name=f"{axis}_sum")  # at most window * (2**cb - 1)
            with m.If(update):
                for k in range(n):
                    m.d.sync += history[k].eq(Mux(primed, history[k - 1] if k else new, new))
                m.d.sync += total.eq(Mux(primed, total + new - history[n - 1],
                                         new << self.shift))
            m.d.comb += getattr(out, axis).eq(self._scaled(total))
        m.d.comb += out.primed.eq(primed)
        m.d.sync += self.o_stream.valid.eq(beats[2])
        return m
