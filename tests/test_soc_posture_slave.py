# amaranth: UnusedElaboratable=no
"""soc/posture_slave.py: PostureSlave against its software model
sw_hps.simulated.SimulatedPostureSlave, read for read, with records arriving
while the bus reads (Amaranth's simulator)."""
import numpy as np
from amaranth.sim import Simulator

from soc.hps_interface import (POSTURE_DATA, POSTURE_INDEX, POSTURE_LAYOUT, POSTURE_STATUS,
                               POSTURE_WORD_COUNT, posture_layout_word)
from soc.posture_slave import PostureSlave
from sw_hps.simulated import SimulatedPostureSlave


def test_slave_equals_its_software_model():
    rng = np.random.default_rng(4)
    dut, model = PostureSlave(), SimulatedPostureSlave()
    records = [rng.integers(0, 1 << 32, POSTURE_WORD_COUNT, dtype=np.uint64).tolist()
               for _ in range(5)]
    # the bus: Index writes and Data / Status / Layout reads, mixed with the records' words
    ops = []
    for k in range(3000):
        r = rng.random()
        if r < 0.03:
            ops.append(("write", POSTURE_INDEX, int(rng.integers(0, 256))))
        elif r < 0.6:
            ops.append(("read", POSTURE_DATA, 0))
        elif r < 0.65:
            ops.append(("read", int(rng.choice([POSTURE_STATUS, POSTURE_INDEX, POSTURE_LAYOUT,
                                                 0x10 - 4])), 0))
        else:
            ops.append(None)
    starts = [100, 500, 1100, 1291, 2300]   # records a word a cycle from these cycles
    beats = {}
    for start, record in zip(starts, records):
        for i, word in enumerate(record):
            beats[start + i] = (i, word)
    got, want = [], []

    async def tb(ctx):
        bus = dut.bus
        for cycle, op in enumerate(ops):
            ctx.set(bus.read, 0)
            ctx.set(bus.write, 0)
            beat = beats.get(cycle)
            ctx.set(dut.i_stream.valid, int(beat is not None))
            if beat is not None:
                ctx.set(dut.i_stream.payload.index, beat[0])
                ctx.set(dut.i_stream.payload.word, beat[1])
            if op is not None:
                kind, offset, value = op
                ctx.set(bus.address, offset // 4)
                if kind == "write":
                    ctx.set(bus.write, 1)
                    ctx.set(bus.writedata, value)
                    model.write32(offset, value)
                else:
                    ctx.set(bus.read, 1)
                    want.append(model.read32(offset))
            # the model's record completes at the end of the beat's cycle
            if beat is not None and beat[0] == POSTURE_WORD_COUNT - 1:
                model.push_record(records[starts.index(cycle - POSTURE_WORD_COUNT + 1)])
            await ctx.tick()
            if op is not None and op[0] == "read":     # read latency 1
                got.append(ctx.get(bus.readdata))

    sim = Simulator(dut)
    sim.add_clock(1e-8)
    sim.add_testbench(tb)
    sim.run()
    assert len(got) == len(want) > 1500
    assert got == want
    assert model.records == 5 and posture_layout_word() in want
    assert any(w == records[0][5] for w in want)   # a whole record was read back
