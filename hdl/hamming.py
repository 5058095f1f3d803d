"""Hamming distances of one census code to many (thesis eq. 2, Fig. 48).

The SHD compares each left code with the ``D`` right codes of its disparities.
Every distance is an XOR and a pipelined adder tree: the XOR counted three bits
at a time (a full adder: a 6-input function of the two codes per output bit,
one ALM LUT level), registered, then summed by a binary adder tree of ripple
adders with a register after every two adder levels. Free-running pipeline: a
result appears ``cycles`` clock cycles after its inputs.

The ``codes`` trees are built bit-sliced: every wire of the tree is a word with
one bit per code. The logic per code is the same full adders as ``codes``
separate trees (fewer LUTs than adder cells on a Cyclone V), but a simulator
evaluates a word of ``codes`` bits per gate instead of a gate per code: the
whole pipeline ran 1.8 times as fast under Verilator (docs/figures/fpga.md
"Simulation speed").
"""
from __future__ import annotations

from amaranth.hdl import Cat, Module, Signal
from amaranth.lib import data, wiring
from amaranth.lib.wiring import In, Out

from ._util import bits_for, check_int

__all__ = ["HammingDistances", "hamming_cycles"]


def _adder_levels(bits: int) -> int:
    groups = (bits + 2) // 3
    levels = 0
    while groups > 1:
        groups = (groups + 1) // 2
        levels += 1
    return levels


def _full_add(*planes):
    """Sum and carry words of up to three one-bit words (``None``: absent)."""
    present = [p for p in planes if p is not None]
    if len(present) == 1:
        return present[0], None
    if len(present) == 2:
        x, y = present
        return x ^ y, x & y
    x, y, z = present
    return x ^ y ^ z, (x & y) | (x & z) | (y & z)


def _ripple_add(x: list, y: list) -> list:
    """Bit-sliced sum of two numbers given as lists of bit words, LSB first."""
    out, carry = [], None
    for i in range(max(len(x), len(y))):
        s, carry = _full_add(x[i] if i < len(x) else None, y[i] if i < len(y) else None, carry)
        out.append(s)
    if carry is not None:
        out.append(carry)
    return out


def hamming_cycles(bits: int, adder_levels_per_stage: int = 2) -> int:
    """Clock cycles of a distance of ``bits``-bit codes: the XOR and 3-bit counts,
    then a register after every ``adder_levels_per_stage`` adder levels."""
    return 1 + -(-_adder_levels(bits) // adder_levels_per_stage)


class HammingDistances(wiring.Component):
    """``distance[k] = popcount(a ^ code_k)`` for ``codes`` codes, ``cycles``
    clock cycles later.

    Parameters
    ----------
    bits : int in [1, 64]
        Code width (census bits).
    codes : int in [1, 256]
        Codes compared with ``a`` (the SHD's ``D``).
    adder_levels_per_stage : int in [1, 4]
        Adder-tree levels between registers.
    a_copies : int in [1, codes]
        Copies of ``a`` the caller drives, each from its own register: copy
        ``i`` meets the codes ``i * ceil(codes / a_copies)`` onwards, so that no
        bit of ``a`` reaches every code's XOR on one net (routed on an ECP5: 8 ns
        for one bit reaching 48 codes).

    Ports
    -----
    a : ``bits``; ``ArrayLayout(bits, a_copies)`` when ``a_copies`` > 1
    b : ``ArrayLayout(codes, bits)``, bit-plane order: ``b[j]`` holds bit ``j``
        of every code (bit ``k`` of ``b[j]`` is bit ``j`` of ``code_k``), as the
        SHD's delay line of right codes keeps them.
    distance : ``ArrayLayout(bits_for(bits), codes)``
    """

    def __init__(self, bits: int, codes: int = 1, adder_levels_per_stage: int = 2,
                 a_copies: int = 1):
        self.bits = check_int("bits", bits, 1, 64)
        self.codes = check_int("codes", codes, 1, 256)
        self.per_stage = check_int("adder_levels_per_stage", adder_levels_per_stage, 1, 4)
        self.a_copies = check_int("a_copies", a_copies, 1, self.codes)
        #: clock cycles from a, b to distance
        self.cycles = hamming_cycles(self.bits, self.per_stage)
        super().__init__({
            "a": In(bits if a_copies == 1 else data.ArrayLayout(bits, a_copies)),
            "b": In(data.ArrayLayout(codes, bits)),
            "distance": Out(data.ArrayLayout(bits_for(bits), codes)),
        })

    def elaborate(self, platform):
        m = Module()
        n = self.codes
        copies = [self.a] if self.a_copies == 1 else list(self.a)
        share = -(-n // self.a_copies)
        # each copy's bit replicated over its codes (a word per copy, not a bit
        # per code: a simulator evaluates a few words)
        x = [Cat(*(self.b[j][lo:lo + share] ^ copy[j].replicate(len(self.b[j][lo:lo + share]))
                   for lo, copy in zip(range(0, n, share), copies)))
             for j in range(self.bits)]

        def register(number, name):
            regs = []
            for i, plane in enumerate(number):
                reg = Signal(n, name=f"{name}_b{i}", reset_less=True)
                m.d.sync += reg.eq(plane)
                regs.append(reg)
            return regs

        # Level 0: each group of three XOR bits counted (2-bit results), registered.
        values = [register([p for p in _full_add(*x[g:g + 3], *[None] * (3 - len(x[g:g + 3])))
                            if p is not None], f"cnt_{g // 3}")
                  for g in range(0, self.bits, 3)]
        level = 0
        while len(values) > 1:
            nxt = [_ripple_add(values[k], values[k + 1]) for k in range(0, len(values) - 1, 2)]
            if len(values) % 2:
                nxt.append(values[-1])
            level += 1
            values = nxt
            if level % self.per_stage == 0 or len(values) == 1:
                values = [register(v, f"sum_l{level}_{k}") for k, v in enumerate(values)]
        planes = values[0]
        width = len(self.distance[0])
        for k in range(n):
            m.d.comb += self.distance[k].eq(Cat(*(p[k] for p in planes))[:width])
        return m
