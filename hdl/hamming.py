"""Hamming distance of two census codes: XOR and a pipelined adder tree
(thesis eq. 2, Fig. 48).

The XOR of the codes is counted three bits at a time (a 6-input function of the
two codes per output bit, one ALM LUT level), registered, then summed by a
binary adder tree with a register after every two adder levels. Free-running
pipeline: a result appears ``cycles`` clock cycles after its inputs.
"""
from __future__ import annotations

from amaranth.hdl import Module, Signal
from amaranth.lib import wiring
from amaranth.lib.wiring import In, Out

from ._util import check_int

__all__ = ["HammingDistance"]


def _adder_levels(bits: int) -> int:
    groups = (bits + 2) // 3
    levels = 0
    while groups > 1:
        groups = (groups + 1) // 2
        levels += 1
    return levels


class HammingDistance(wiring.Component):
    """``distance = popcount(a ^ b)``, ``cycles`` clock cycles later.

    Parameters
    ----------
    bits : int in [1, 64]
        Code width (census bits).
    adder_levels_per_stage : int in [1, 4]
        Adder-tree levels between registers.
    """

    def __init__(self, bits: int, adder_levels_per_stage: int = 2):
        self.bits = check_int("bits", bits, 1, 64)
        self.per_stage = check_int("adder_levels_per_stage", adder_levels_per_stage, 1, 4)
        levels = _adder_levels(self.bits)
        #: clock cycles from a, b to distance
        self.cycles = 1 + -(-levels // self.per_stage)
        super().__init__({
            "a": In(bits),
            "b": In(bits),
            "distance": Out(range(bits + 1)),
        })

    def elaborate(self, platform):
        m = Module()
        x = self.a ^ self.b
        # Level 0: count groups of three bits (2-bit results), registered.
        values = []
        for g in range(0, self.bits, 3):
            part = x[g:g + 3]
            count = Signal(range(len(part) + 1), name=f"cnt_{g // 3}")
            m.d.sync += count.eq(sum(part[i] for i in range(len(part))))
            values.append(count)
        level = 0
        stage_regs = 0
        while len(values) > 1:
            nxt = []
            for k in range(0, len(values) - 1, 2):
                nxt.append(values[k] + values[k + 1])
            if len(values) % 2:
                nxt.append(values[-1])
            level += 1
            values = nxt
            if level % self.per_stage == 0 or len(values) == 1:
                regs = []
                for k, v in enumerate(values):
                    r = Signal(v.shape(), name=f"sum_l{level}_{k}")
                    m.d.sync += r.eq(v)
                    regs.append(r)
                values = regs
                stage_regs += 1
        m.d.comb += self.distance.eq(values[0])
        assert 1 + stage_regs == self.cycles, (stage_regs, self.cycles)
        return m
