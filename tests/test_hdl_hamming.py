# amaranth: UnusedElaboratable=no
"""hdl/hamming.py: HammingDistances, bit for bit against the bit count of a XOR b."""
import numpy as np
import pytest

from hdl.hamming import HammingDistances


@pytest.mark.parametrize("bits, codes, a_copies", [(4, 1, 1), (12, 3, 1), (24, 1, 1),
                                                   (46, 7, 1), (60, 2, 1), (24, 10, 3),
                                                   (12, 16, 2)])
def test_hamming_distances_pipeline(bits, codes, a_copies):
    """With ``a_copies`` > 1 each copy gets its own values: code ``k`` must meet
    copy ``k // ceil(codes / a_copies)``."""
    from amaranth.sim import Simulator
    rng = np.random.default_rng(bits * 10 + codes)
    steps = 200
    share = -(-codes // a_copies)
    a = [[int(v) for v in rng.integers(0, 1 << min(bits, 62), a_copies)] for _ in range(steps)]
    a += [[(1 << bits) - 1] * a_copies, [0] * a_copies]
    b = [[int(v) for v in rng.integers(0, 1 << min(bits, 62), codes)] for _ in range(steps)]
    b += [[0] * codes, [(1 << bits) - 1] * codes]
    dut = HammingDistances(bits, codes=codes, a_copies=a_copies)
    width = len(dut.distance[0])
    got = []

    def planes(row):        # bit k of word j: bit j of code k
        return sum(((code >> j) & 1) << (j * codes + k) for k, code in enumerate(row)
                   for j in range(bits))

    async def tb(ctx):
        for t in range(len(a) + dut.cycles):
            if t < len(a):
                ctx.set(dut.a if a_copies == 1 else dut.a.as_value(),
                        sum(v << (i * bits) for i, v in enumerate(a[t])))
                ctx.set(dut.b.as_value(), planes(b[t]))
            await ctx.tick()
            if t + 1 >= dut.cycles:
                out = ctx.get(dut.distance.as_value())
                got.append([(out >> (k * width)) & ((1 << width) - 1) for k in range(codes)])

    sim = Simulator(dut)
    sim.add_clock(1e-8)
    sim.add_testbench(tb)
    sim.run()
    assert got[:len(a)] == [[bin(x[k // share] ^ y).count("1") for k, y in enumerate(row)]
                            for x, row in zip(a, b)]


def test_hamming_a_copies_range():
    with pytest.raises(ValueError, match="a_copies"):
        HammingDistances(8, codes=4, a_copies=5)


@pytest.mark.parametrize("bits, cycles", [(1, 1), (3, 1), (6, 2), (12, 2), (24, 3), (48, 3),
                                          (64, 4)])
def test_hamming_distances_latency(bits, cycles):
    """The adder tree's depth (the SHD's and so the pipeline's timing)."""
    assert HammingDistances(bits, codes=4).cycles == cycles
