"""Left-right consistency check (thesis eq. 21, Figs. 43 and 56).

Left pixel x with L2R disparity d keeps d when ``|d - R2L(x - d)| < Th`` or when
its partner x - d lies left of the frame (nothing to check), else it becomes 0
(invalid). R2L(x - d) for every d in 0 .. D-1 needs the R2L values of right
pixels x - D + 1 .. x: the selectors emit R2L(x) together with L2R(x + D - 1),
so the check runs D - 1 beats behind, with a delay line of D - 1 L2R values
and one of D - 1 R2L values (the R2L delay line of Fig. 56); a D:1 multiplexer
picks R2L(x - d). The threshold Th is an input port (run-time register).
"""
from __future__ import annotations

from amaranth.hdl import Array, Module, Mux, Signal
from amaranth.lib import data, stream, wiring
from amaranth.lib.wiring import In, Out

from sim.model.matching import MAX_DISPARITY_RANGE

from ._util import bits_for, check_geometry, check_int, delay, register_input
from .raster_position import RasterPosition
from .stage import StageTiming

__all__ = ["LeftRightCheck", "lrcc_timing", "disparity_bits"]


def disparity_bits(max_disparity: int) -> int:
    """Bits of a disparity 0 .. D - 1 (0 also means rejected) as the matcher emits it."""
    return bits_for(max_disparity - 1)


def lrcc_timing(max_disparity: int) -> StageTiming:
    """Look-ahead D - 1 (the R2L disparities of the pixels to the right) and
    :attr:`LeftRightCheck.cycles`."""
    return StageTiming(lag=max_disparity - 1, cycles=LeftRightCheck.cycles)


class LeftRightCheck(wiring.Component):
    """Consistency-checked disparity map.

    Parameters
    ----------
    width, height : frame size (width in [max(8, D), 4096], height in [2, 4096])
    max_disparity : int in [1, 256]

    Ports
    -----
    threshold : In, Th in 1 .. D (0 rejects every pixel that has a partner)
    i_stream : payload ``{first, l2r, r2l}`` as emitted by
        :class:`~hdl.selectors.DisparitySelectors`
    o_stream : payload ``{first, real, disparity}``, ``lag`` = D - 1,
        ``cycles`` = 5 (an input register whose beat is copied once per
        history, the D:1 multiplexer in two steps, the difference, the check).

    Attributes
    ----------
    memory_bits : int
        0: the D - 1 deep L2R and R2L histories are registers (the check reads
        any of them in one cycle).
    """

    cycles = 5
    memory_bits = 0
    #: d bits of the first multiplexer step (8 R2L values per group)
    MUX_LOW_BITS = 3

    def __init__(self, width: int, height: int, max_disparity: int):
        self.max_disparity = check_int("max_disparity", max_disparity, *MAX_DISPARITY_RANGE)
        self.width, self.height = check_geometry(width, height, min_width=max_disparity)
        self.disparity_bits = disparity_bits(self.max_disparity)
        self.lag = lrcc_timing(self.max_disparity).lag
        db = self.disparity_bits
        super().__init__({
            "threshold": In(bits_for(self.max_disparity)),
            "i_stream": In(stream.Signature(data.StructLayout({
                "first": 1, "l2r": db, "r2l": db}), always_ready=True)),
            "o_stream": Out(stream.Signature(data.StructLayout({
                "first": 1, "real": 1, "disparity": db}), always_ready=True)),
        })

    def elaborate(self, platform):
        m = Module()
        nd, db = self.max_disparity, self.disparity_bits
        # An input register; the beat once per history (one net for both
        # histories spanned them)
        p, (beat, l2r_beat, r2l_beat) = register_input(m, self.i_stream, 3, "pair")
        pos = RasterPosition(self.width, self.height, self.lag, "pix").attach(m, beat, p.first)

        l2r_hist = [p.l2r]
        r2l_hist = [p.r2l]
        for k in range(1, nd):
            a = Signal(db, name=f"l2r_dl{k}", reset_less=True)
            b = Signal(db, name=f"r2l_dl{k}", reset_less=True)
            with m.If(l2r_beat):
                m.d.sync += a.eq(l2r_hist[k - 1])
            with m.If(r2l_beat):
                m.d.sync += b.eq(r2l_hist[k - 1])
            l2r_hist.append(a)
            r2l_hist.append(b)
        d = l2r_hist[nd - 1]

        # Stage 1: R2L of the partner in two steps of the D:1 multiplexer (by the
        # low bits of d, then the high: one 48:1 step ran at 8.7 ns routed), and
        # whether the partner is outside.
        low = min(self.MUX_LOW_BITS, db)
        groups = [r2l_hist[k:k + (1 << low)] for k in range(0, nd, 1 << low)]
        parts = [Signal(db, name=f"r2l_part{g}") for g in range(len(groups))]
        d0, outside0 = Signal(db), Signal()
        m.d.sync += [part.eq(Array(group)[d[:low]]) for part, group in zip(parts, groups)]
        m.d.sync += [d0.eq(d), outside0.eq(pos.x < d)]
        d1 = Signal(db)
        seen = Signal(db)
        outside = Signal()
        m.d.sync += [d1.eq(d0), outside.eq(outside0),
                     seen.eq(Array(parts)[d0[low:]] if len(parts) > 1 else parts[0])]
        # Stage 2: |d - R2L(x - d)| (both differences in parallel, one multiplexer).
        d2 = Signal(db)
        mag = Signal(db)
        outside2 = Signal()
        m.d.sync += [d2.eq(d1), outside2.eq(outside),
                     mag.eq(Mux(d1 >= seen, d1 - seen, seen - d1))]
        # Stage 3: the check against the threshold.
        keep = outside2 | (mag < self.threshold)
        out = self.o_stream.payload
        m.d.sync += out.disparity.eq(Mux(keep, d2, 0))
        m.d.comb += [
            self.o_stream.valid.eq(delay(m, beat, 4, "valid")),
            out.first.eq(delay(m, pos.is_first, 4, "first")),
            out.real.eq(delay(m, pos.real, 4, "real")),
        ]
        return m
