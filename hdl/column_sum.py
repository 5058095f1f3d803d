"""Column sums of the SHD window (thesis Figs. 49 and 51): for every disparity,
the sum of the Hamming distances over the ``hamming_window`` rows of the
aggregation window, kept in one memory of ``width`` words (eq. 20's
``width * D * bits`` term) and updated once per pixel:

    C_d(x, y) = C_d(x, y - 1) + H_d(x, y + r) - H_d(x, y - r - 1)

with r = Wh // 2. The entering row ``y + r`` and the leaving row ``y - r - 1``
are ``Wh`` rows apart: the dual window V1/V2 of Fig. 53 provides both. A row
outside the frame contributes 0 (its term is masked), and the first row of a
frame starts from 0, so frames never mix.

A pixel with x < d has no right partner: every term of its column is
``no_match_cost``, so its column sum is ``no_match_cost`` times the number of
window rows inside the frame, one register for the whole row (the memory's
sum there is kept but never output).

The sums of :attr:`ColumnSum.GROUP` disparities share one memory word at
address x, so a group has one address register instead of a counter per
disparity (x - d in a memory of ``width - d`` words, until issue 27): the
same M10K count at 640x480 (8 memories of 60 bits against 48 of 10) and 4 %
more bits (``width * D`` sums, eq. 20's term, against the triangle without
the x < d columns); the registers saved are in docs/figures/fpga.md.
"""
from __future__ import annotations

from amaranth.hdl import Cat, Module, Mux, Signal, signed
from amaranth.lib import data, memory, stream, wiring
from amaranth.lib.wiring import In, Out

from ._util import (KEEP_REGISTER, NO_RW_COLLISION, bits_for, check_geometry, check_int,
                    check_odd_window, delay, registered_read, replicate)
from .raster_position import RasterPosition
from .stage import StageTiming

__all__ = ["ColumnSum", "column_sum_timing", "column_sum_memory_bits"]


def column_sum_timing(width: int, hamming_window: int) -> StageTiming:
    """Look-ahead r * width rows (r = Wh // 2) and :attr:`ColumnSum.cycles`."""
    return StageTiming(lag=(hamming_window // 2) * width, cycles=ColumnSum.cycles)


def column_sum_memory_bits(width: int, hamming_window: int, max_disparity: int,
                           max_term: int) -> int:
    """Bits of the memories of a :class:`ColumnSum` (its ``memory_bits``):
    ``width`` column sums per disparity (eq. 20's ``width * D * bits``)."""
    return width * max_disparity * bits_for(hamming_window * max_term)


class ColumnSum(wiring.Component):
    """Per-disparity column sums over ``hamming_window`` rows.

    Parameters
    ----------
    width, height : frame size (width in [8, 4096], height in [2, 4096])
    hamming_window : odd int in [1, 63]
        Wh, rows summed.
    max_disparity : int in [1, 256]
        D, the number of sums per pixel.
    max_term : int in [1, 64]
        Largest Hamming term (the census bits).
    no_match_cost : int in [0, max_term]
        The term of a pixel with x < d (the ``enter`` / ``leave`` inputs of those
        positions are not used).

    Ports
    -----
    i_stream : payload ``{first, enter, leave}`` at raster position (x, y'):
        ``enter[d]`` = H_d(x, y'), ``leave[d]`` = H_d(x, y' - Wh).
    o_stream : payload ``{first, real, csum}``: ``csum[d]`` = C_d(x, y' - r),
        the column sum of position (x, y' - r); ``lag`` = r * width, ``cycles`` = 4.

    Cycles: the input is registered, and the beat and the frame start are
    copied once per :attr:`GROUP` disparities (and the beat once per position
    counter) (1); each group's copies steer its address register and partner
    flags, its memory is read every cycle (2), the read word is registered
    (3), then its sums are added to the differences of the terms and written
    back (4). So no beat or frame-start net reaches every memory (routed on an
    ECP5 such nets cost up to 13 ns), and a memory's output (4.3 ns from the
    clock on an ECP5) has a cycle to itself before the adders.
    """

    cycles = 4
    #: disparities per memory word and per copy of the beat and the frame
    #: start: six 10-bit sums (the thesis parameters) fill a 64-bit word, one
    #: machine word for a simulator, four ECP5 blocks 18 bits wide
    GROUP = 6

    def __init__(self, width: int, height: int, hamming_window: int, max_disparity: int,
                 max_term: int, no_match_cost: int = 0):
        self.width, self.height = check_geometry(width, height)
        self.hamming_window = check_odd_window("hamming_window", hamming_window, 1, 63)
        self.max_disparity = check_int("max_disparity", max_disparity, 1, 256)
        self.max_term = check_int("max_term", max_term, 1, 64)
        self.no_match_cost = check_int("no_match_cost", no_match_cost, 0, self.max_term)
        if self.max_disparity > self.width:
            raise ValueError(f"max_disparity must be in [1, {self.width}] (the width), "
                             f"got {self.max_disparity}")
        self.term_bits = bits_for(self.max_term)
        self.sum_bits = bits_for(self.hamming_window * self.max_term)
        self.radius = self.hamming_window // 2
        self.lag = column_sum_timing(self.width, self.hamming_window).lag
        self.memory_bits = column_sum_memory_bits(self.width, self.hamming_window,
                                                  self.max_disparity, self.max_term)
        nd = self.max_disparity
        super().__init__({
            "i_stream": In(stream.Signature(data.StructLayout({
                "first": 1,
                "enter": data.ArrayLayout(self.term_bits, nd),
                "leave": data.ArrayLayout(self.term_bits, nd)}), always_ready=True)),
            "o_stream": Out(stream.Signature(data.StructLayout({
                "first": 1, "real": 1,
                "csum": data.ArrayLayout(self.sum_bits, nd)}), always_ready=True)),
        })

    def elaborate(self, platform):
        m = Module()
        w, h, wh, nd, cb = self.width, self.height, self.hamming_window, self.max_disparity, \
            self.sum_bits
        beat = self.i_stream.valid
        p = self.i_stream.payload
        # Cycle 1: the input registered, the beat in copies (one per GROUP
        # disparities, one per position counter, one for the rest), so the
        # input's valid steers registers only; the positions count the copied
        # beat, one cycle late, which the terms' wait for the read absorbs.
        groups = -(-nd // self.GROUP)
        spans = [range(g * self.GROUP, min(nd, (g + 1) * self.GROUP)) for g in range(groups)]
        beats = replicate(m, beat, groups + 3, "beat")
        beat_1, pos_beat_1, out_beat_1 = beats[-3:]
        first_1 = delay(m, p.first, 1, "first1")
        # the terms registered per group (a simulator then slices each term out
        # of a word of a few, not out of one of all 2 D)
        tb = self.term_bits
        enters, leaves = ([delay(m, terms.as_value()[ds.start * tb:ds.stop * tb], 1,
                                 f"terms_{kind}_{g}", reset_less=True)
                           for g, ds in enumerate(spans)]
                          for kind, terms in (("enter", p.enter), ("leave", p.leave)))
        pos = RasterPosition(w, h, 0, "row").attach(m, pos_beat_1, first_1)
        out_pos = RasterPosition(w, h, self.lag, "out").attach(m, out_beat_1, first_1)

        def entering(x, y):
            return (y >= 0) & (y < h)

        def leaving(x, y):
            return (y >= wh) & (y < h + wh)

        enter_ok = pos.registered(entering, "enter")
        leave_ok = pos.registered(leaving, "leave")
        # the copies of the frame start, one per group: each group's flags (the
        # terms' masks, the partner flags, the address) load from their own
        # (one register steering the masks of all 2 D terms was the routed limit)
        group_firsts = replicate(m, p.first, groups, "first_group")
        group_enter_ok, group_leave_ok = (
            [pos.registered(cond, f"{name}_{g}", first=group_firsts[g], beat=beats[g],
                            attrs=KEEP_REGISTER) for g in range(groups)]
            for cond, name in ((entering, "enter"), (leaving, "leave")))
        restart = pos.registered(lambda x, y: y <= 0, "restart")

        # Cycle 2: the difference of the entering and leaving terms.
        # (waiting for the read as one word per group: a simulator copies it in one go)
        db = tb + 1
        deltas = []
        for g, ds in enumerate(spans):
            group = []
            for k, d in enumerate(ds):
                delta = Signal(signed(db), name=f"delta_{d}", reset_less=True)
                m.d.sync += delta.eq(Mux(group_enter_ok[g], enters[g][k * tb:(k + 1) * tb], 0)
                                     - Mux(group_leave_ok[g], leaves[g][k * tb:(k + 1) * tb], 0))
                group.append(delta)
            waited = delay(m, Cat(*group), 1, f"deltas_{g}", reset_less=True)
            deltas += [waited[k * db:(k + 1) * db].as_signed() for k in range(len(ds))]
        # one copy per group: one register steering all 2 D sums' restart
        # multiplexers was routed at 8.1 ns (of routing) on a placement
        restart_3s = replicate(m, delay(m, restart, 1, "restart"), groups, "restart3")
        valid_4 = delay(m, beat_1, 3, "valid")
        # The column sum of the positions without partner: no_match_cost per row inside.
        nmc = self.no_match_cost
        no_match = Signal(cb)
        with m.If(beat_1 & pos.registered(lambda x, y: x == 0, "row_start")):
            m.d.sync += no_match.eq(Mux(restart, 0, no_match) + Mux(enter_ok, nmc, 0)
                                    - Mux(leave_ok, nmc, 0))
        # (as it stood after this beat: the next row's may already be counted)
        no_match_4 = delay(m, no_match, 2, "no_match")
        # bit d: x >= d, each GROUP's bits reset by its copy of first
        partners_1 = pos.thermometer(nd, "partner", firsts=group_firsts)
        partners_4 = delay(m, partners_1, 3, "partner4")
        # Cycles 2-4, per GROUP disparities: one memory word of their sums at
        # address x, read every cycle, registered, added to and written back;
        # the address is the group's own copy of x (its beat, its first).
        for g, ds in enumerate(spans):
            # (a word is written three cycles after its beat's read and read
            # again a row later; a read of it in between is an idle cycle's,
            # discarded)
            m.submodules[f"mem_{g}"] = mem = memory.Memory(shape=cb * len(ds), depth=w,
                                                           init=[], attrs=NO_RW_COLLISION)
            wr = mem.write_port()
            addr = pos.registered(lambda x, y: x, f"addr_{g}", range(w),
                                  first=group_firsts[g], beat=beats[g], attrs=KEEP_REGISTER)
            word = registered_read(m, mem, addr, f"read_{g}")
            stored = Signal(cb * len(ds), name=f"stored_{g}", reset_less=True)
            m.d.sync += stored.eq(word)
            sums = []
            for k, d in enumerate(ds):
                s_new = Signal(cb, name=f"csum_{d}", reset_less=True)
                m.d.sync += s_new.eq(Mux(restart_3s[g], 0, stored[k * cb:(k + 1) * cb]) + deltas[d])
                sums.append(s_new)
                # a sum at x < d is written but never output: no partner there
                m.d.comb += self.o_stream.payload.csum[d].eq(
                    Mux(partners_4[d], s_new, no_match_4) if d else s_new)
            m.d.comb += [
                wr.addr.eq(delay(m, addr, 3, f"waddr_{g}", reset_less=True)),
                wr.en.eq(delay(m, beats[g], 3, f"wen_{g}")),
                wr.data.eq(Cat(*sums)),
            ]
        m.d.comb += [
            self.o_stream.valid.eq(valid_4),
            self.o_stream.payload.first.eq(delay(m, out_pos.is_first, 3, "first")),
            self.o_stream.payload.real.eq(delay(m, out_pos.real, 3, "real")),
        ]
        return m
