# amaranth: UnusedElaboratable=no
"""hdl/dual_clock_fifo.py: the camera FIFOs' dual-clock FIFO, against Python's
deque (order, no loss, no duplicate), with random writes and pops on unrelated
clocks, its level, its capacity, one pop per clock, and a write-side reset."""
import random
from collections import deque

import pytest
from amaranth.hdl import ClockDomain, Elaboratable, Module, Signal
from amaranth.sim import Simulator

from hdl.dual_clock_fifo import OUTPUT_WORDS, DualClockFIFO

R_NS, W_NS = 10, 13


class _Top(Elaboratable):
    def __init__(self, depth):
        self.fifo = DualClockFIFO(width=12, depth=depth, w_domain="wr")
        self.wr_rst = Signal()

    def elaborate(self, platform):
        m = Module()
        m.domains.sync = ClockDomain("sync")
        m.domains.wr = wr = ClockDomain("wr")
        m.d.comb += wr.rst.eq(self.wr_rst)
        m.submodules.fifo = self.fifo
        return m


async def _write(ctx, fifo, words):
    """Write ``words``, one per write clock (the FIFO must have room)."""
    for word in words:
        ctx.set(fifo.w_en, 1)
        ctx.set(fifo.w_data, word)
        await ctx.tick("wr")
    ctx.set(fifo.w_en, 0)


def _sim(depth, w_ns=W_NS, r_ns=R_NS):
    top = _Top(depth)
    sim = Simulator(top)
    sim.add_clock(r_ns * 1e-9, domain="sync")
    sim.add_clock(w_ns * 1e-9, domain="wr", phase=3e-9)
    return top, top.fifo, sim


@pytest.mark.parametrize("w_ns, r_ns, w_rate, r_rate", [
    (13, 10, 0.9, 0.6),      # writer faster in words: the FIFO fills and stalls
    (13, 10, 0.5, 0.95),     # reader faster: it runs empty
    (7, 10, 0.7, 0.9),       # write clock faster than the read clock
])
def test_random_traffic_keeps_order(w_ns, r_ns, w_rate, r_rate):
    top, fifo, sim = _sim(16, w_ns, r_ns)
    rng = random.Random(w_ns * 100 + int(w_rate * 10))
    sent, got = [], []
    count = 600

    async def writer_exact(ctx):
        word = 0
        while word < count:
            en = rng.random() < w_rate
            ctx.set(fifo.w_en, en)
            ctx.set(fifo.w_data, word)
            rdy = ctx.get(fifo.w_rdy)
            await ctx.tick("wr")
            if en and rdy:
                sent.append(word)
                word += 1
        ctx.set(fifo.w_en, 0)

    async def reader(ctx):
        level_max = 0
        while len(got) < count:
            en = rng.random() < r_rate
            ctx.set(fifo.r_en, en)
            rdy, data = ctx.get(fifo.r_rdy), ctx.get(fifo.r_data)
            level_max = max(level_max, ctx.get(fifo.r_level))
            await ctx.tick()
            if en and rdy:
                got.append(data)
        assert level_max <= fifo.capacity

    sim.add_testbench(writer_exact)
    sim.add_testbench(reader)
    sim.run_until(count * 40 * max(w_ns, r_ns) * 1e-9)
    assert got == sent == list(range(count))


def test_capacity_level_and_one_pop_per_clock():
    depth = 16
    top, fifo, sim = _sim(depth)
    log = {}

    async def bench(ctx):
        # write until refused: the RAM plus the output buffer
        written = 0
        for _ in range(200):
            ctx.set(fifo.w_en, 1)
            ctx.set(fifo.w_data, written)
            rdy = ctx.get(fifo.w_rdy)
            await ctx.tick("wr")
            written += rdy
        ctx.set(fifo.w_en, 0)
        await ctx.tick().repeat(10)
        log["written"] = written
        log["level_full"] = ctx.get(fifo.r_level)
        # pop every clock: one word per clock, in order, nothing skipped
        popped = []
        ctx.set(fifo.r_en, 1)
        for _ in range(written + 5):
            rdy, data = ctx.get(fifo.r_rdy), ctx.get(fifo.r_data)
            await ctx.tick()
            if rdy:
                popped.append(data)
        ctx.set(fifo.r_en, 0)
        log["popped"] = popped
        await ctx.tick().repeat(4)
        log["level_empty"] = ctx.get(fifo.r_level)

    sim.add_testbench(bench)
    sim.run()
    assert log["written"] == depth + OUTPUT_WORDS == fifo.capacity
    assert log["level_full"] == fifo.capacity
    # one pop per clock from the first: the head never runs dry while words wait
    assert log["popped"] == list(range(fifo.capacity))
    assert log["level_empty"] == 0


def test_level_trails_by_two_clocks():
    top, fifo, sim = _sim(16)
    seen = []

    async def bench(ctx):
        await ctx.tick().repeat(3)
        await _write(ctx, fifo, range(5))
        await ctx.tick().repeat(12)
        # level is exact once the writes are visible; popping lowers it 2 clocks later
        seen.append(ctx.get(fifo.r_level))
        ctx.set(fifo.r_en, 1)
        await ctx.tick()
        ctx.set(fifo.r_en, 0)
        seen.append(ctx.get(fifo.r_level))
        await ctx.tick()
        seen.append(ctx.get(fifo.r_level))
        await ctx.tick()
        seen.append(ctx.get(fifo.r_level))

    sim.add_testbench(bench)
    sim.run()
    assert seen == [5, 5, 5, 4]


def test_write_side_reset_empties_the_read_side():
    top, fifo, sim = _sim(16)
    log = {}

    async def bench(ctx):
        await _write(ctx, fifo, range(10))
        await ctx.tick().repeat(10)
        log["before"] = ctx.get(fifo.r_level)
        ctx.set(top.wr_rst, 1)
        await ctx.delay(3 * W_NS * 1e-9)
        ctx.set(top.wr_rst, 0)
        await ctx.tick().repeat(10)
        log["after"] = (ctx.get(fifo.r_rdy), ctx.get(fifo.r_level))
        await _write(ctx, fifo, (100, 101, 102))
        await ctx.tick().repeat(10)
        got = []
        ctx.set(fifo.r_en, 1)
        for _ in range(6):
            rdy, data = ctx.get(fifo.r_rdy), ctx.get(fifo.r_data)
            await ctx.tick()
            if rdy:
                got.append(data)
        log["got"] = got

    sim.add_testbench(bench)
    sim.run()
    assert log["before"] == 10
    assert log["after"] == (0, 0)
    assert log["got"] == [100, 101, 102]


@pytest.mark.parametrize("kwargs, name", [
    (dict(width=8, depth=12, w_domain="a"), "depth must be a power of two"),
    (dict(width=8, depth=2, w_domain="a"), "depth"),
    (dict(width=0, depth=16, w_domain="a"), "width"),
    (dict(width=8, depth=16, w_domain=""), "w_domain"),
    (dict(width=8, depth=16, w_domain="a", r_domain=None), "r_domain"),
])
def test_bad_parameters_raise_naming_them(kwargs, name):
    with pytest.raises(ValueError, match=name):
        DualClockFIFO(**kwargs)
