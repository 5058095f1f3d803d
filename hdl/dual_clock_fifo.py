"""Dual-clock FIFO whose read side never routes ``r_en`` into a RAM address
(the camera FIFOs of the stereo synchroniser, thesis §5.3).

Amaranth's ``AsyncFIFOBuffered`` adds its read enable to the read pointer and
feeds the sum to the block RAM's address, and it decodes the Gray pointer and
subtracts in the cycle that registers ``r_level``. Routed on an ECP5 (issue 27)
those two paths limited the whole pipeline on half the placements: the
synchroniser's marker checks decide ``r_en`` in the same cycle. Here the RAM
is read ahead from a registered address into an output buffer of
:data:`OUTPUT_WORDS` registers, so ``r_en`` only shifts that buffer, and
``r_level`` takes two registered steps.

The write side and the Gray-pointer crossings are those of ``AsyncFIFO``,
with the same names (``produce_w_gry``, ``consume_r_gry``, submodules
``produce_cdc`` and ``consume_cdc``), which :func:`soc.generate.async_fifo_crossings`
finds to constrain them.
"""
from __future__ import annotations

from amaranth.hdl import Cat, Module, Mux, ResetSignal, Signal
from amaranth.lib import memory, wiring
from amaranth.lib.cdc import AsyncFFSynchronizer, FFSynchronizer
from amaranth.lib.wiring import In, Out

from sim.model.validation import check_power_of_two

from ._util import check_domain, check_int

__all__ = ["DualClockFIFO", "OUTPUT_WORDS", "DEPTH_RANGE"]

#: Registers of the read side's output buffer: the RAM is read one cycle
#: ahead on occupancy registered a cycle late, so three words keep one pop per
#: clock going (one in flight from the RAM, two waiting).
OUTPUT_WORDS = 3
DEPTH_RANGE = (4, 65536)
WIDTH_RANGE = (1, 4096)


def _gray_encode(value):
    return value ^ value[1:]


def _gray_decode(gray):
    bits = [gray[-1]]
    for i in reversed(range(len(gray) - 1)):
        bits.insert(0, bits[0] ^ gray[i])
    return Cat(*bits)


class DualClockFIFO(wiring.Component):
    """First-in first-out buffer between two clock domains.

    Parameters
    ----------
    width : int in [1, 4096]
        Bits of a word.
    depth : power of two in [4, 65536]
        Words of the RAM; the output buffer holds :data:`OUTPUT_WORDS` more
        (:attr:`capacity`).
    w_domain, r_domain : str
        Clock domains of the write and read sides.

    Ports
    -----
    w_data : In(width), w_en : In(1), w_rdy : Out(1)
        Write side: a word is written on a cycle with ``w_en`` and ``w_rdy``
        (``w_rdy`` low while the RAM is full, as the write side sees it).
    r_data : Out(width), r_rdy : Out(1), r_en : In(1)
        Read side: ``r_data`` is the oldest word, from a register, while
        ``r_rdy`` (a register); ``r_en`` pops it.
    r_level : Out(range(capacity + 1))
        Words in the FIFO as the read side saw them two clocks ago (exact for
        that cycle: RAM words and buffered words sampled together).

    Timing
    ------
    A written word is at ``r_data`` four ``r_domain`` edges after the write
    side's Gray pointer register takes it: two synchroniser stages, the Gray
    decode, then the RAM read. Pops may come every cycle.

    Resets
    ------
    A reset of the write side empties the read side too (synchronised, as in
    ``AsyncFIFO``). A reset of the read side alone drops the buffered words and
    keeps the pointers consistent (the RAM pointer is not reset, it drains).
    """

    def __init__(self, *, width: int, depth: int, w_domain: str, r_domain: str = "sync"):
        self.width = check_int("width", width, *WIDTH_RANGE)
        self.depth = check_power_of_two("depth", depth, *DEPTH_RANGE)
        self._w_domain = check_domain("w_domain", w_domain)
        self._r_domain = check_domain("r_domain", r_domain)
        super().__init__({
            "w_data": In(self.width), "w_en": In(1), "w_rdy": Out(1),
            "r_data": Out(self.width), "r_rdy": Out(1), "r_en": In(1),
            "r_level": Out(range(self.capacity + 1)),
        })

    @property
    def capacity(self) -> int:
        """Words the FIFO holds when full: the RAM and the output buffer."""
        return self.depth + OUTPUT_WORDS

    def elaborate(self, platform):
        m = Module()
        wd, rd = self._w_domain, self._r_domain
        bits = self.depth.bit_length()          # one more than the address

        storage = m.submodules.storage = memory.Memory(
            shape=self.width, depth=self.depth, init=[])

        # ---- write side (as AsyncFIFO) ----
        produce_w_bin = Signal(bits)
        produce_w_gry = Signal(bits)
        consume_w_gry = Signal(bits)
        full = Signal()
        m.d.comb += full.eq((produce_w_gry[-1] != consume_w_gry[-1])
                            & (produce_w_gry[-2] != consume_w_gry[-2])
                            & (produce_w_gry[:-2] == consume_w_gry[:-2]))
        do_write = self.w_en & ~full
        produce_w_nxt = Signal(bits)
        m.d.comb += produce_w_nxt.eq(produce_w_bin + do_write)
        m.d[wd] += [produce_w_bin.eq(produce_w_nxt),
                    produce_w_gry.eq(_gray_encode(produce_w_nxt))]
        w_port = storage.write_port(domain=wd)
        m.d.comb += [w_port.addr.eq(produce_w_bin[:-1]), w_port.data.eq(self.w_data),
                     w_port.en.eq(do_write), self.w_rdy.eq(~full)]

        # ---- read side ----
        produce_r_gry = Signal(bits)
        m.submodules.produce_cdc = FFSynchronizer(produce_w_gry, produce_r_gry, o_domain=rd)
        # the pointers survive a reset of the read side alone (see Resets)
        produce_r_bin = Signal(bits, reset_less=True)
        m.d[rd] += produce_r_bin.eq(_gray_decode(produce_r_gry))
        fetch = Signal(bits, reset_less=True)           # words read out of the RAM
        consume_r_gry = Signal(bits, reset_less=True)
        m.submodules.consume_cdc = FFSynchronizer(consume_r_gry, consume_w_gry, o_domain=wd)

        # words in the output buffer or on their way from the RAM
        occupancy = Signal(range(OUTPUT_WORDS + 1))
        fetching = Signal()
        m.d.comb += fetching.eq((produce_r_bin != fetch) & (occupancy < OUTPUT_WORDS))
        fetch_nxt = Signal(bits)
        m.d.comb += fetch_nxt.eq(fetch + fetching)
        m.d[rd] += [fetch.eq(fetch_nxt), consume_r_gry.eq(_gray_encode(fetch_nxt))]
        # the address is a register: reading every cycle, the word of a fetch
        # arrives on the next one
        r_port = storage.read_port(domain=rd)
        m.d.comb += [r_port.addr.eq(fetch[:-1]), r_port.en.eq(1)]
        arriving = Signal()
        m.d[rd] += arriving.eq(fetching)

        # output buffer: word 0 is the head; `filled` is a thermometer code
        words = [Signal(self.width, name=f"word_{i}") for i in range(OUTPUT_WORDS)]
        filled = [Signal(name=f"filled_{i}") for i in range(OUTPUT_WORDS)]
        pop = Signal()
        m.d.comb += [pop.eq(self.r_en & filled[0]),
                     self.r_data.eq(words[0]), self.r_rdy.eq(filled[0])]
        after_pop = [Signal(name=f"after_pop_{i}") for i in range(OUTPUT_WORDS)]
        for i in range(OUTPUT_WORDS):
            above = filled[i + 1] if i + 1 < OUTPUT_WORDS else 0
            m.d.comb += after_pop[i].eq(Mux(pop, above, filled[i]))
        for i in range(OUTPUT_WORDS):
            lands = arriving & ~after_pop[i] & (after_pop[i - 1] if i else 1)
            m.d[rd] += filled[i].eq(after_pop[i] | lands)
            with m.If(lands):
                m.d[rd] += words[i].eq(r_port.data)
            if i + 1 < OUTPUT_WORDS:
                with m.Elif(pop):
                    m.d[rd] += words[i].eq(words[i + 1])
        m.d[rd] += occupancy.eq(occupancy + fetching - pop)

        # level over two registered steps
        ram_level = Signal(bits)
        occupancy_1 = Signal.like(occupancy)
        m.d[rd] += [ram_level.eq(produce_r_bin - fetch), occupancy_1.eq(occupancy),
                    self.r_level.eq(ram_level + occupancy_1)]

        # a reset of the write side empties the read side (its pointer restarts)
        r_rst = Signal()
        m.submodules.rst_cdc = AsyncFFSynchronizer(
            ResetSignal(wd, allow_reset_less=True), r_rst, o_domain=rd)
        with m.If(r_rst):
            m.d.comb += fetching.eq(0)
            m.d[rd] += [fetch.eq(produce_r_bin), consume_r_gry.eq(_gray_encode(produce_r_bin)),
                        occupancy.eq(0), arriving.eq(0)]
            m.d[rd] += [f.eq(0) for f in filled]
        return m
