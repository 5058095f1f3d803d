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
window rows inside the frame, one register for the whole row. Disparity d
therefore keeps only the ``width - d`` columns x >= d, in a memory of its own
(address x - d): ``D * width - D * (D - 1) / 2`` words in all.
"""
from __future__ import annotations

from amaranth.hdl import Cat, Module, Mux, Signal, signed
from amaranth.lib import data, memory, stream, wiring
from amaranth.lib.wiring import In, Out

from ._util import bits_for, check_geometry, check_int, check_odd_window, delay, replicate
from .raster_position import RasterPosition
from .stage import StageTiming

__all__ = ["ColumnSum", "column_sum_timing", "column_sum_memory_bits"]


def column_sum_timing(width: int, hamming_window: int) -> StageTiming:
    """Look-ahead r * width rows (r = Wh // 2) and :attr:`ColumnSum.cycles`."""
    return StageTiming(lag=(hamming_window // 2) * width, cycles=ColumnSum.cycles)


def column_sum_memory_bits(width: int, hamming_window: int, max_disparity: int,
                           max_term: int) -> int:
    """Bits of the memories of a :class:`ColumnSum` (its ``memory_bits``):
    ``width - d`` column sums for disparity d."""
    return (sum(width - d for d in range(max_disparity))
            * bits_for(hamming_window * max_term))


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

    Cycles: the input is registered and the beat copied once per :attr:`GROUP`
    disparities and once per position counter (1), each copy steers its group's
    address counters, the memories read every cycle (2), the read words are
    registered (3), then added to the difference of the terms and written back
    (4). So no beat net reaches all 48 memories or every counter (routed on an
    ECP5 such nets cost up to 13 ns), and a memory's output (4.3 ns from the
    clock on an ECP5) has a cycle to itself before the adder.
    """

    cycles = 4
    #: disparities per copy of the beat
    GROUP = 8

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
        beats = replicate(m, beat, -(-nd // self.GROUP) + 3, "beat")
        beat_1, pos_beat_1, out_beat_1 = beats[-3:]
        first_1 = delay(m, p.first, 1, "first1")
        p_1 = data.View(self.i_stream.payload.shape(), delay(m, p.as_value(), 1, "terms",
                                                             reset_less=True))
        pos = RasterPosition(w, h, 0, "row").attach(m, pos_beat_1, first_1)
        out_pos = RasterPosition(w, h, self.lag, "out").attach(m, out_beat_1, first_1)
        enter_ok = pos.registered(lambda x, y: (y >= 0) & (y < h), "enter")
        leave_ok = pos.registered(lambda x, y: (y >= wh) & (y < h + wh), "leave")
        restart = pos.registered(lambda x, y: y <= 0, "restart")

        # Cycle 2: the difference of the entering and leaving terms.
        deltas = []
        for d in range(nd):
            delta = Signal(signed(self.term_bits + 1), name=f"delta_{d}", reset_less=True)
            m.d.sync += delta.eq(Mux(enter_ok, p_1.enter[d], 0) - Mux(leave_ok, p_1.leave[d], 0))
            deltas.append(delta)
        # (waiting for the read as one word: a simulator copies it in one go)
        waited = delay(m, Cat(*deltas), 1, "deltas", reset_less=True)
        db = self.term_bits + 1
        deltas = [waited[d * db:(d + 1) * db].as_signed() for d in range(nd)]
        restart_3 = delay(m, restart, 2, "restart")
        valid_4 = delay(m, beat_1, 3, "valid")
        # The column sum of the positions without partner: no_match_cost per row inside.
        nmc = self.no_match_cost
        no_match = Signal(cb)
        with m.If(beat_1 & pos.registered(lambda x, y: x == 0, "row_start")):
            m.d.sync += no_match.eq(Mux(restart, 0, no_match) + Mux(enter_ok, nmc, 0)
                                    - Mux(leave_ok, nmc, 0))
        # (as it stood after this beat: the next row's may already be counted)
        no_match_4 = delay(m, no_match, 2, "no_match")
        partners_1 = pos.thermometer(nd, "partner")                   # bit d: x >= d
        partners_4 = delay(m, partners_1, 3, "partner4")
        x_1 = pos.x
        # Cycles 2-4: read (every cycle), register, add and write back.
        for d in range(nd):
            m.submodules[f"mem_{d}"] = mem = memory.Memory(shape=cb, depth=w - d, init=[])
            rd = mem.read_port()
            wr = mem.write_port()
            addr = Signal(range(w - d), name=f"addr_{d}")
            if d:
                # x - d as its own counter (+1 per beat from x = d on): an incrementer
                # and a multiplexer in front of the register, no subtractor; it
                # moves on the copied beat, so in cycle 1 it holds the beat's address
                with m.If(beats[d // self.GROUP]):
                    m.d.sync += addr.eq(Mux(partners_1[d], addr + 1, 0))
            else:
                m.d.comb += addr.eq(x_1)
            m.d.comb += [rd.addr.eq(addr), rd.en.eq(1)]
            stored = Signal(cb, name=f"stored_{d}", reset_less=True)
            m.d.sync += stored.eq(rd.data)
            partner_4 = partners_4[d] if d else 1
            s_new = Signal(cb, name=f"csum_{d}", reset_less=True)
            m.d.sync += s_new.eq(Mux(restart_3, 0, stored) + deltas[d])
            m.d.comb += [
                wr.addr.eq(delay(m, addr, 3, f"waddr_{d}", reset_less=True)),
                wr.en.eq(valid_4 & partner_4),
                wr.data.eq(s_new),
                self.o_stream.payload.csum[d].eq(Mux(partner_4, s_new, no_match_4) if d else s_new),
            ]
        m.d.comb += [
            self.o_stream.valid.eq(valid_4),
            self.o_stream.payload.first.eq(delay(m, out_pos.is_first, 3, "first")),
            self.o_stream.payload.real.eq(delay(m, out_pos.real, 3, "real")),
        ]
        return m
