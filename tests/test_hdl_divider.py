# amaranth: UnusedElaboratable=no
"""hdl/divider.py: UnsignedDivider, bit for bit against Python's divmod (thesis §7.1)."""
import numpy as np
import pytest
from amaranth.sim import Simulator

from hdl.divider import UnsignedDivider


def _divide(dut, ops):
    """Run ``ops`` = [(dividend, divisor, idle cycles before the start)], each start
    as soon as the previous done (in the done cycle itself when idle is 0); check
    busy/done timing to the cycle and return [(quotient, remainder)]."""
    results = []

    async def tb(ctx):
        for dividend, divisor, idle in ops:
            for _ in range(idle):
                assert not ctx.get(dut.busy)
                await ctx.tick()
                assert not ctx.get(dut.done)
            ctx.set(dut.start, 1)
            ctx.set(dut.dividend, dividend)
            ctx.set(dut.divisor, divisor)
            await ctx.tick()
            ctx.set(dut.start, 0)
            for _ in range(dut.cycles - 1):
                assert ctx.get(dut.busy) and not ctx.get(dut.done)
                await ctx.tick()
            assert ctx.get(dut.done) and not ctx.get(dut.busy)
            results.append((ctx.get(dut.quotient), ctx.get(dut.remainder)))
        await ctx.tick()
        assert not ctx.get(dut.done)  # a one-cycle pulse
        assert results[-1] == (ctx.get(dut.quotient), ctx.get(dut.remainder))  # held

    sim = Simulator(dut)
    sim.add_clock(1e-8)
    sim.add_testbench(tb)
    sim.run()
    return results


def _expected_division(dividend, divisor, dividend_bits, divisor_bits):
    if divisor == 0:  # documented: all-ones quotient, low dividend bits as remainder
        return (1 << dividend_bits) - 1, dividend % (1 << divisor_bits)
    return divmod(dividend, divisor)


@pytest.mark.parametrize("dividend_bits, divisor_bits", [(1, 1), (4, 3), (3, 5), (6, 2)])
def test_divider_exhaustive_back_to_back(dividend_bits, divisor_bits):
    dut = UnsignedDivider(dividend_bits, divisor_bits)
    assert dut.cycles == dividend_bits + 1
    ops = [(a, b, 0) for a in range(1 << dividend_bits) for b in range(1 << divisor_bits)]
    got = _divide(dut, ops)
    assert got == [_expected_division(a, b, dividend_bits, divisor_bits) for a, b, _ in ops]


@pytest.mark.parametrize("dividend_bits, divisor_bits", [(36, 19), (27, 19), (64, 64)])
def test_divider_random_wide(dividend_bits, divisor_bits):
    rng = np.random.default_rng(dividend_bits)
    top_a, top_b = (1 << dividend_bits) - 1, (1 << divisor_bits) - 1
    ops = [(top_a, 1, 0), (top_a, top_b, 2), (0, top_b, 0), (top_b, top_b, 0), (5, 0, 1)]
    for _ in range(60):
        # divisors of every size, so quotients of every size
        size = int(rng.integers(1, divisor_bits + 1))
        b = max(1, int.from_bytes(rng.bytes(8), "little") % (1 << size))
        a = int.from_bytes(rng.bytes(8), "little") % (top_a + 1)
        ops.append((a, b, int(rng.integers(0, 3))))
    got = _divide(UnsignedDivider(dividend_bits, divisor_bits), ops)
    assert got == [_expected_division(a, b, dividend_bits, divisor_bits) for a, b, _ in ops]


def test_divider_start_while_busy_restarts():
    dut = UnsignedDivider(12, 6)
    seen = []

    async def tb(ctx):
        ctx.set(dut.start, 1)
        ctx.set(dut.dividend, 4000)
        ctx.set(dut.divisor, 7)
        await ctx.tick()
        ctx.set(dut.start, 0)
        await ctx.tick().repeat(4)
        ctx.set(dut.start, 1)
        ctx.set(dut.dividend, 3001)
        ctx.set(dut.divisor, 60)
        await ctx.tick()
        ctx.set(dut.start, 0)
        for cycle in range(1, 3 * dut.cycles):
            if ctx.get(dut.done):
                seen.append((cycle, ctx.get(dut.quotient), ctx.get(dut.remainder)))
            await ctx.tick()

    sim = Simulator(dut)
    sim.add_clock(1e-8)
    sim.add_testbench(tb)
    sim.run()
    assert seen == [(dut.cycles, 3001 // 60, 3001 % 60)]


@pytest.mark.parametrize("make, name", [
    (lambda: UnsignedDivider(0, 4), r"dividend_bits must be in \[1, 64\]"),
    (lambda: UnsignedDivider(8, 65), r"divisor_bits must be in \[1, 64\]"),
    (lambda: UnsignedDivider(8.0, 4), "dividend_bits must be an integer"),
])
def test_bad_parameters_raise_value_error_naming_them(make, name):
    with pytest.raises(ValueError, match=name):
        make()
