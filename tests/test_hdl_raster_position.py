"""hdl/raster_position.py: RasterPosition's x, y, registered flags, thermometer
and sliding flags, beat by beat against the raster index they stand for."""
import numpy as np
import pytest
from amaranth.hdl import Module
from amaranth.lib import wiring
from amaranth.lib.wiring import In, Out
from amaranth.sim import Simulator

from hdl.raster_position import OVERRUN_ROWS, RasterPosition

THERMO = 4
SPLIT = 5              # a thermometer in runs of 3 and 2 bits, one first each
ROWS = (1, 4)          # the sliding flags: 1 - i <= y < 4 - i, i in 0..2


class _Probe(wiring.Component):
    """A RasterPosition and its helpers as ports, for one beat per cycle."""

    def __init__(self, width, height, lag):
        self.width, self.height, self.lag = width, height, lag
        super().__init__({"beat": In(1), "first": In(1), "x": Out(16), "y": Out(16),
                          "real": Out(1), "is_first": Out(1), "edge": Out(1),
                          "thermo": Out(THERMO), "split": Out(SPLIT), "rows": Out(3), "cols": Out(3)})

    def elaborate(self, platform):
        m = Module()
        pos = RasterPosition(self.width, self.height, self.lag, "probe").attach(
            m, self.beat, self.first)
        m.d.comb += [self.x.eq(pos.x), self.y.eq(pos.y), self.real.eq(pos.real),
                     self.is_first.eq(pos.is_first),
                     self.edge.eq(pos.registered(lambda x, y: (x == self.width - 1) | (y < 0),
                                                 "edge")),
                     self.thermo.eq(pos.thermometer(THERMO)),
                     self.split.eq(pos.thermometer(SPLIT, "split",
                                                   firsts=[self.first, self.first])),
                     self.rows.eq(pos.sliding_flags(3, *ROWS, "y", "rows")),
                     self.cols.eq(pos.sliding_flags(3, 1, 4, "x", "cols"))]
        return m


def _expected(width, height, lag, index):
    """x and y of raster index ``index`` - ``lag``, y saturating past the frame."""
    k = index - lag
    x, y = k % width, k // width
    y_max = height + OVERRUN_ROWS
    if y > y_max:
        y = y_max
    return x, y


@pytest.mark.parametrize("width, height, lag", [(5, 3, 0), (6, 2, 7), (4, 3, 1), (5, 2, 3)])
def test_position_and_helpers_follow_the_raster(width, height, lag):
    dut = _Probe(width, height, lag)
    rng = np.random.default_rng(width * 10 + lag)
    # two frames; the second starts early, mid-way through the first's overrun,
    # and runs far past its end to reach the saturation
    lengths = [width * height + 3, width * (height + OVERRUN_ROWS + 3) + 2]
    checked = []

    async def testbench(ctx):
        for length in lengths:
            for index in range(length):
                while rng.random() < 0.3:            # idle cycles change nothing
                    ctx.set(dut.beat, 0)
                    await ctx.tick()
                ctx.set(dut.beat, 1)
                ctx.set(dut.first, int(index == 0))
                x, y = _expected(width, height, lag, index)
                ys = ctx.get(dut.y)
                ys = ys - (1 << 16) if ys >= 1 << 15 else ys
                assert (ctx.get(dut.x), ys) == (x, y), index
                assert ctx.get(dut.real) == int(0 <= y < height)
                assert ctx.get(dut.is_first) == int(x == 0 and y == 0)
                assert ctx.get(dut.edge) == int(x == width - 1 or y < 0)
                thermo = sum(1 << i for i in range(THERMO) if x >= i)
                assert ctx.get(dut.thermo) == thermo, (index, x)
                split = sum(1 << i for i in range(SPLIT) if x >= i)
                assert ctx.get(dut.split) == split, (index, x)
                rows = sum(1 << i for i in range(3) if ROWS[0] - i <= y < ROWS[1] - i)
                assert ctx.get(dut.rows) == rows, (index, y)
                cols = sum(1 << i for i in range(3) if 1 - i <= x < 4 - i)
                assert ctx.get(dut.cols) == cols, (index, x)
                checked.append(index)
                await ctx.tick()
            ctx.set(dut.first, 0)

    sim = Simulator(dut)
    sim.add_clock(1e-8)
    sim.add_testbench(testbench)
    sim.run()
    assert len(checked) == sum(lengths)
