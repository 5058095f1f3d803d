# amaranth: UnusedElaboratable=no
"""hdl/row_buffer.py: RowBuffer, bit for bit against its input delayed by ``length`` beats,
as a memory and as registers, its output held or valid for one cycle."""
import numpy as np
import pytest

from hdl.row_buffer import MEMORY_MIN_LENGTH, RowBuffer


@pytest.mark.parametrize("length, hold, idle_share", [
    (7, True, 0.4), (7, False, 0.4), (MEMORY_MIN_LENGTH, True, 0.0),
    (MEMORY_MIN_LENGTH, False, 0.3), (2, True, 0.0), (3, False, 0.4)])
def test_row_buffer_delays_by_length_beats_with_gaps(length, hold, idle_share):
    """Two cycles after each beat the lines give what they took ``length``
    beats before, and take the new values (beats back to back or with idle
    cycles); a held output keeps its value until the next beat's."""
    from amaranth.sim import Simulator
    lanes, n = 3, 60
    dut = RowBuffer(length, lanes, 8, hold_output=hold)
    assert dut.uses_memory == (length >= MEMORY_MIN_LENGTH)
    assert dut.memory_bits == length * lanes * 8 * dut.uses_memory
    rng = np.random.default_rng(length)
    values = rng.integers(0, 256, (n, lanes))
    idle = rng.random(4 * n) < idle_share
    seen, held = [], []

    async def tb(ctx):
        k, cycle, beats = 0, 0, []          # beats: the cycle of each beat so far
        while k < n or (beats and cycle <= beats[-1] + RowBuffer.cycles):
            due = [j for j, c in enumerate(beats) if c + RowBuffer.cycles == cycle]
            if due:  # the lines' words are valid: read them, write this beat's values
                (j,) = due
                seen.append([ctx.get(dut.o_data[i]) for i in range(lanes)])
                for i in range(lanes):
                    ctx.set(dut.i_data[i], int(values[j, i]))
            elif hold and len(seen) and beats[-1] + RowBuffer.cycles < cycle:
                held.append(([ctx.get(dut.o_data[i]) for i in range(lanes)], seen[-1]))
            beat = k < n and not idle[cycle]
            ctx.set(dut.beat, int(beat))
            await ctx.tick()
            if beat:
                beats.append(cycle)
            cycle += 1
            k += int(beat)

    sim = Simulator(dut)
    sim.add_clock(1e-8)
    sim.add_testbench(tb)
    sim.run()
    seen = np.array(seen)
    assert len(seen) == n
    assert (seen[length:] == values[:n - length]).all()
    assert all(now == last for now, last in held)
