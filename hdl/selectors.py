"""Best-of selectors: the left-to-right (L2R) and right-to-left (R2L)
winner-take-all disparity maps (thesis Figs. 45 and 55).

Every best-of cell compares two (cost, disparity) candidates and keeps the
second only when its cost is strictly smaller ("C1 > C2 takes 2"), so ties keep
the smaller disparity, as the golden model does.

* L2R: a pipelined binary tree of cells over the D costs of one left pixel
  (one register stage per tree level).
* R2L: right pixel x needs the costs of left pixels x .. x + D - 1 at
  disparities 0 .. D - 1. A chain of D cells, one per disparity, advances one
  stage per beat: stage k holds the best of disparities 0 .. k for right pixel
  x - k and takes the cost of disparity k + 1 from the next left pixel. A
  candidate whose left pixel lies in the next row (x + d > width - 1) is
  masked, as the model's R2L range d <= width - 1 - x requires.
"""
from __future__ import annotations

from amaranth.hdl import Module, Mux, Signal
from amaranth.lib import data, stream, wiring
from amaranth.lib.wiring import In, Out

from sim.model.matching import MAX_DISPARITY_RANGE

from ._util import bits_for, check_geometry, check_int, delay, register_input
from .raster_position import RasterPosition
from .stage import StageTiming

__all__ = ["DisparitySelectors", "selectors_timing"]


def selectors_timing(max_disparity: int) -> StageTiming:
    """No look-ahead; the input register, then one cycle per level of the
    best-of tree over D (at least 1)."""
    return StageTiming(lag=0, cycles=1 + max(1, (max_disparity - 1).bit_length()))


class DisparitySelectors(wiring.Component):
    """L2R and R2L maps from the SHD costs.

    Parameters
    ----------
    width, height : frame size (width in [max(8, D), 4096], height in [2, 4096])
    max_disparity : int in [1, 256]
    cost_bits : int in [1, 32]

    Ports
    -----
    i_stream : payload ``{first, cost}`` (``cost[d]`` of one left pixel)
    o_stream : payload ``{first, real, l2r, r2l}``, ``cycles`` = 1 + tree depth
        (at least 1), ``lag`` = 0: ``l2r`` is the L2R disparity of the beat's left
        pixel, ``r2l`` the R2L disparity of the right pixel D - 1 raster
        positions before it.

    Attributes
    ----------
    memory_bits : int
        0: the best-of tree and the R2L chain are registers.
    """

    memory_bits = 0

    def __init__(self, width: int, height: int, max_disparity: int, cost_bits: int):
        self.max_disparity = check_int("max_disparity", max_disparity, *MAX_DISPARITY_RANGE)
        self.width, self.height = check_geometry(width, height, min_width=max_disparity)
        self.cost_bits = check_int("cost_bits", cost_bits, 1, 32)
        self.disparity_bits = bits_for(self.max_disparity - 1)
        self.levels = (self.max_disparity - 1).bit_length()
        self.lag, self.cycles = selectors_timing(self.max_disparity)
        db = self.disparity_bits
        super().__init__({
            "i_stream": In(stream.Signature(data.StructLayout({
                "first": 1, "cost": data.ArrayLayout(cost_bits, max_disparity)}),
                always_ready=True)),
            "o_stream": Out(stream.Signature(data.StructLayout({
                "first": 1, "real": 1, "l2r": db, "r2l": db}), always_ready=True)),
        })

    #: R2L cells per copy of the beat
    CELLS_PER_BEAT = 16

    def elaborate(self, platform):
        m = Module()
        nd, cb, db = self.max_disparity, self.cost_bits, self.disparity_bits
        # An input register, and the beat once per CELLS_PER_BEAT cells of the
        # R2L chain (and once for the rest): no single beat net steers the
        # whole chain.
        p, (beat, *cell_beats) = register_input(m, self.i_stream,
                                                1 + -(-nd // self.CELLS_PER_BEAT), "costs")
        pos = RasterPosition(self.width, self.height, 0, "pix").attach(m, beat, p.first)

        # L2R: pipelined tree; a pair's second (larger d) wins only if strictly cheaper.
        nodes = [(p.cost[d], d) for d in range(nd)]
        level = 0
        while len(nodes) > 1 or level == 0:
            nxt = []
            for k in range(0, len(nodes), 2):
                if k + 1 < len(nodes):
                    (ca, da), (cb_, db_) = nodes[k], nodes[k + 1]
                    take = cb_ < ca
                    cost, disp = Mux(take, cb_, ca), Mux(take, db_, da)
                else:
                    cost, disp = nodes[k]
                rc = Signal(cb, name=f"l2r_c{level}_{k // 2}", reset_less=True)
                rd = Signal(db, name=f"l2r_d{level}_{k // 2}", reset_less=True)
                m.d.sync += [rc.eq(cost), rd.eq(disp)]
                nxt.append((rc, rd))
            nodes = nxt
            level += 1
        l2r = nodes[0][1]

        # R2L: chain of best-of cells, advancing on beats.
        chain_c = [Signal(cb, name=f"r2l_c{k}", reset_less=True) for k in range(nd)]
        chain_d = [Signal(db, name=f"r2l_d{k}", reset_less=True) for k in range(nd)]
        same_rows = pos.thermometer(nd, "same_row")  # bit k: x >= k
        with m.If(cell_beats[0]):
            m.d.sync += [chain_c[0].eq(p.cost[0]), chain_d[0].eq(0)]
        for k in range(1, nd):
            same_row = same_rows[k]
            take = same_row & (p.cost[k] < chain_c[k - 1])
            with m.If(cell_beats[k // self.CELLS_PER_BEAT]):
                m.d.sync += [chain_c[k].eq(Mux(take, p.cost[k], chain_c[k - 1])),
                             chain_d[k].eq(Mux(take, k, chain_d[k - 1]))]
        # (the chain moves one cycle after the input register)
        r2l = delay(m, chain_d[nd - 1], self.cycles - 2, "r2l")

        out = self.o_stream.payload
        m.d.comb += [
            self.o_stream.valid.eq(delay(m, beat, self.cycles - 1, "valid")),
            out.first.eq(delay(m, pos.is_first, self.cycles - 1, "first")),
            out.real.eq(delay(m, pos.real, self.cycles - 1, "real")),
            out.l2r.eq(l2r),
            out.r2l.eq(r2l),
        ]
        return m
