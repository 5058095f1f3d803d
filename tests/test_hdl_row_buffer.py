# amaranth: UnusedElaboratable=no
"""hdl/row_buffer.py: RowBuffer, bit for bit against its input delayed by ``length`` beats."""
import numpy as np

from hdl.row_buffer import RowBuffer


def test_row_buffer_delays_by_length_beats_with_gaps():
    from amaranth.sim import Simulator
    length, lanes, n = 7, 3, 60
    dut = RowBuffer(length, lanes, 8)
    rng = np.random.default_rng(0)
    values = rng.integers(0, 256, (n, lanes))
    idle = rng.random(4 * n) < 0.4
    seen = []

    async def tb(ctx):
        k, cycle, pending = 0, 0, False
        while k < n or pending:
            if pending:  # the cycle after a beat: read the lines, write the new values
                seen.append([ctx.get(dut.o_data[i]) for i in range(lanes)])
                for i in range(lanes):
                    ctx.set(dut.i_data[i], int(values[k - 1, i]))
            beat = k < n and not idle[cycle]
            ctx.set(dut.beat, int(beat))
            await ctx.tick()
            cycle += 1
            pending = beat
            k += int(beat)

    sim = Simulator(dut)
    sim.add_clock(1e-8)
    sim.add_testbench(tb)
    sim.run()
    seen = np.array(seen)
    assert (seen[length:] == values[:n - length]).all()
