"""Window sums of the SHD (thesis Figs. 49 and 51): for every disparity, the sum
of ``hamming_window`` consecutive column sums along the row,

    S_d(x, y) = S_d(x - 1, y) + C_d(x + r, y) - C_d(x - r - 1, y),

from ring buffers of ``Wh`` column-sum vectors (RAM, one per group of
disparities) and an accumulator per disparity. Columns outside the frame count 0. The window of a row's last r
pixels overlaps, in the stream, the first r columns of the next row, so a
second accumulator per disparity gathers the next row's first r column sums
while the first finishes the row (the frame border costs no idle cycles).
"""
from __future__ import annotations

from amaranth.hdl import Cat, Module, Mux, Signal, signed
from amaranth.lib import data, memory, stream, wiring
from amaranth.lib.wiring import In, Out

from ._util import (KEEP_REGISTER, NO_RW_COLLISION, bits_for, check_geometry, check_int,
                    check_odd_window, delay, registered_read, replicate)
from .raster_position import RasterPosition
from .stage import StageTiming

#: Disparities whose delay lines and accumulators share one copy of the beat
#: and of the row flags.
FLAG_GROUP = 2

__all__ = ["WindowSum", "window_sum_timing", "window_sum_ring_depth", "window_sum_memory_bits",
           "window_sum_bits"]


def window_sum_timing(hamming_window: int) -> StageTiming:
    """Look-ahead r = Wh // 2 columns and 3 cycles."""
    return StageTiming(lag=hamming_window // 2, cycles=WindowSum.cycles)


def window_sum_ring_depth(hamming_window: int) -> int:
    """Words of the ring buffer of column-sum vectors: the power of two >= Wh
    (0 for Wh = 1, a register)."""
    return 1 << (hamming_window - 1).bit_length() if hamming_window >= 3 else 0


def window_sum_bits(hamming_window: int, max_term: int) -> int:
    """Bits of a window sum: ``Wh`` column sums of at most ``max_term``."""
    return bits_for(hamming_window * max_term)


def window_sum_memory_bits(hamming_window: int, max_disparity: int, max_term: int) -> int:
    """Bits of the ring buffer of a :class:`WindowSum` (its ``memory_bits``)."""
    return window_sum_ring_depth(hamming_window) * max_disparity * bits_for(max_term)


class WindowSum(wiring.Component):
    """Sums of ``hamming_window`` consecutive column sums per disparity.

    Parameters
    ----------
    width, height : frame size (width in [max(8, Wh + 1), 4096], height in [2, 4096])
    hamming_window : odd int in [1, 63]
    max_disparity : int in [1, 256]
    max_term : int in [1, 4096]
        Largest column sum.

    Ports
    -----
    i_stream : payload ``{first, csum}`` at raster position (x', y)
    o_stream : payload ``{first, real, cost}``: ``cost[d]`` = S_d(x' - r, y);
        ``lag`` = r, ``cycles`` = 3 (an input register, whose beat is copied once
        per :data:`FLAG_GROUP` disparities: one beat steering every accumulator
        cannot be routed at 100 MHz on an ECP5).

    Attributes
    ----------
    ring_depth : int
        Words of the ring buffer of column-sum vectors (the power of two >= Wh;
        0 for Wh = 1, a register). Routed, ``Wh x D`` beat-gated delay-line
        registers instead ran at 88.7 MHz on an ECP5 (their enable's net).
    memory_bits : int
        ``ring_depth * max_disparity * term_bits``.
    """

    cycles = 3

    def __init__(self, width: int, height: int, hamming_window: int, max_disparity: int,
                 max_term: int):
        self.hamming_window = check_odd_window("hamming_window", hamming_window, 1, 63)
        self.width, self.height = check_geometry(width, height, min_width=hamming_window + 1)
        self.max_disparity = check_int("max_disparity", max_disparity, 1, 256)
        self.max_term = check_int("max_term", max_term, 1, 4096)
        self.term_bits = bits_for(self.max_term)
        self.sum_bits = window_sum_bits(self.hamming_window, self.max_term)
        self.radius = self.hamming_window // 2
        self.lag = window_sum_timing(self.hamming_window).lag
        #: words of the ring buffer of leaving column sums (0: a register, Wh = 1)
        self.ring_depth = window_sum_ring_depth(self.hamming_window)
        #: bits of that ring buffer
        self.memory_bits = window_sum_memory_bits(self.hamming_window, self.max_disparity,
                                                  self.max_term)
        nd = self.max_disparity
        super().__init__({
            "i_stream": In(stream.Signature(data.StructLayout({
                "first": 1, "csum": data.ArrayLayout(self.term_bits, nd)}),
                always_ready=True)),
            "o_stream": Out(stream.Signature(data.StructLayout({
                "first": 1, "real": 1,
                "cost": data.ArrayLayout(self.sum_bits, nd)}), always_ready=True)),
        })

    def elaborate(self, platform):
        m = Module()
        w, h, wh, r, nd = self.width, self.height, self.hamming_window, self.radius, \
            self.max_disparity
        # Input register: the beat once per FLAG_GROUP disparities, each copy
        # steering their delay lines and accumulators.
        copies = -(-nd // FLAG_GROUP)
        beats = replicate(m, self.i_stream.valid, copies, "beat")
        beat = beats[0]
        p = self.i_stream.payload
        first = delay(m, self.i_stream.valid & p.first, 1, "first_in")
        tb = self.term_bits
        # the column sums registered per group (a simulator then slices each
        # sum out of a word of a few sums, not out of one of all D)
        spans = [(g * FLAG_GROUP, min(nd, (g + 1) * FLAG_GROUP)) for g in range(copies)]
        csums = [delay(m, p.csum.as_value()[lo * tb:hi * tb], 1, f"csum_in_{g}",
                       reset_less=True) for g, (lo, hi) in enumerate(spans)]
        # the position counters each on a copy of their own
        beat_pos, beat_out = replicate(m, self.i_stream.valid, 2, "beat_pos")
        pos = RasterPosition(w, h, 0, "col").attach(m, beat_pos, first)
        out_pos = RasterPosition(w, h, self.lag, "out").attach(m, beat_out, first)
        # Cycle 1 (the registered beat): the position flags, the column sum and the
        # one leaving the window, registered; the delay line advances.
        # Cycle-2 flags, one copy per group too:
        # finishing the previous row, starting this one
        tails = replicate(m, pos.registered(lambda x, y: x < r, "tail"), copies, "tail")
        # first output pixel (x = 0) of this row
        starts = replicate(m, pos.registered(lambda x, y: x == r, "start"), copies, "start")
        head0s = replicate(m, pos.registered(lambda x, y: x == 0, "head0"), copies, "head0")
        valid_1s = replicate(m, beat, copies, "valid_1")
        # the column leaving the window is in this row: one flag per group, with
        # its own frame start (one register steering every subtractor routed at
        # 5.5 ns on one hop)
        first_copies = replicate(m, self.i_stream.valid & p.first, copies, "first_leave")
        leave_oks = [pos.registered(lambda x, y: x >= wh, f"leave_{g}", first=first_copies[g],
                                    attrs=KEEP_REGISTER) for g in range(copies)]

        # The column sums leaving the window (written Wh beats ago): a ring buffer
        # of column-sum vectors (RAM, read two beats ahead into a beat-gated
        # register), one per group of disparities, each with its own copy of
        # the addresses; or a register for Wh = 1.
        if self.ring_depth:
            depth = self.ring_depth
            # read at beat j the word of beat j - (Wh - 2): held (en) until the
            # next beat loads it into its group's `leaving`, used at beat j + 2.
            # Each group counts its own pointer on its own beat, next to its ring
            # (one pointer whose next value fed every group's address registers
            # was routed at 7.9 ns).
            waddrs, raddrs = [], []
            for g in range(copies):
                ptr = Signal(range(depth), name=f"ptr_{g}")
                with m.If(beats[g]):
                    m.d.sync += ptr.eq(ptr + 1)     # wraps: the depth is a power of two
                ptr_next = Signal(range(depth), name=f"ptr_next_{g}")
                m.d.comb += ptr_next.eq(ptr + beats[g])
                waddr = Signal(range(depth), name=f"waddr_{g}", attrs=KEEP_REGISTER)
                raddr = Signal(range(depth), name=f"raddr_{g}", init=(2 - wh) % depth,
                               attrs=KEEP_REGISTER)
                m.d.sync += [waddr.eq(ptr_next), raddr.eq(ptr_next - (wh - 2))]
                waddrs.append(waddr)
                raddrs.append(raddr)
            ring_outs = []
            for g, (lo, hi) in enumerate(spans):
                # (read Wh - 2 >= 1 words behind the write)
                ring = memory.Memory(shape=(hi - lo) * tb, depth=depth, init=[],
                                     attrs=NO_RW_COLLISION)
                m.submodules[f"ring_{g}"] = ring
                wr = ring.write_port()
                m.d.comb += [wr.addr.eq(waddrs[g]), wr.data.eq(csums[g]),
                             wr.en.eq(beats[g])]
                ring_outs.append(registered_read(m, ring, raddrs[g], f"ring_word_{g}",
                                                 en=beats[g]))
        else:
            ring_outs = csums
        leavings = []
        for g, (lo, hi) in enumerate(spans):
            leaving = Signal((hi - lo) * tb, name=f"leaving_{g}", reset_less=True)
            with m.If(beats[g]):
                m.d.sync += leaving.eq(ring_outs[g])
            leavings.append(leaving)

        for d in range(nd):
            g = d // FLAG_GROUP
            k = d - spans[g][0]
            tail, start, head0, valid_1 = tails[g], starts[g], head0s[g], valid_1s[g]
            c = csums[g][k * tb:(k + 1) * tb]
            leaving = leavings[g][k * tb:(k + 1) * tb]
            c_1 = delay(m, c, 1, f"c_{d}", reset_less=True)
            leave_1 = delay(m, leaving, 1, f"leave_{d}", reset_less=True)
            diff_1 = Signal(signed(self.term_bits + 1), name=f"diff_{d}", reset_less=True)
            m.d.sync += diff_1.eq(c - Mux(leave_oks[g], leaving, 0))
            # Cycle 1: the accumulators (one adder each), on the delayed beat.
            acc = Signal(self.sum_bits, name=f"acc_{d}", reset_less=True)
            head = Signal(self.sum_bits, name=f"head_{d}", reset_less=True)
            with m.If(valid_1):
                if r:
                    with m.If(tail):
                        m.d.sync += head.eq(Mux(head0, 0, head) + c_1)
                        m.d.sync += acc.eq(acc - leave_1)
                    with m.Elif(start):
                        m.d.sync += acc.eq(head + c_1)
                    with m.Else():
                        m.d.sync += acc.eq(acc + diff_1)
                else:
                    m.d.sync += acc.eq(c_1)
            m.d.comb += self.o_stream.payload.cost[d].eq(acc)
        m.d.comb += [
            self.o_stream.valid.eq(delay(m, beat, 2, "valid")),
            self.o_stream.payload.first.eq(delay(m, out_pos.is_first, 2, "first")),
            self.o_stream.payload.real.eq(delay(m, out_pos.real, 2, "real")),
        ]
        return m
