"""Sequential restoring divider, one quotient bit per clock (the divider of the
centroid unit, thesis §7.1, Fig. 72).

The centroid needs two divisions per frame (eq. 24), and a frame lasts far
longer than the ``dividend_bits`` clock cycles a bit-serial divider takes, so a
restoring divider -- one trial subtraction of ``divisor_bits + 1`` bits per clock
-- is all the hardware needed: no multiplier, no wide combinational divider.
"""
from __future__ import annotations

from amaranth.hdl import Cat, Module, Mux, Signal
from amaranth.lib import wiring
from amaranth.lib.wiring import In, Out

from ._util import check_int

__all__ = ["UnsignedDivider", "OPERAND_BITS_RANGE", "divider_cycles"]

OPERAND_BITS_RANGE = (1, 64)


def divider_cycles(dividend_bits: int) -> int:
    """The ``start`` cycle, then one cycle per quotient bit."""
    return dividend_bits + 1


class UnsignedDivider(wiring.Component):
    """``quotient, remainder = divmod(dividend, divisor)`` for unsigned integers.

    Thesis §7.1, Fig. 72. Restoring algorithm: the partial remainder is shifted
    left by one bit, taking in the next dividend bit (most significant first); if
    it is at least the divisor, the divisor is subtracted and the quotient bit is
    1. The dividend register doubles as the quotient register (its bits shift out
    at the top as the quotient bits shift in at the bottom).

    Parameters
    ----------
    dividend_bits : int in [1, 64]
        Width of ``dividend`` and ``quotient``; also the number of iterations.
    divisor_bits : int in [1, 64]
        Width of ``divisor`` and ``remainder``.

    Ports
    -----
    start : In(1)
        Operands are sampled in a cycle with ``start`` high. A ``start`` while
        ``busy`` abandons the running division and begins the new one.
    dividend : In(dividend_bits)
    divisor : In(divisor_bits)
    quotient : Out(dividend_bits)
    remainder : Out(divisor_bits)
        Valid from the ``done`` cycle until the next ``start`` (held).
    busy : Out(1)
        High during the ``dividend_bits`` iteration cycles.
    done : Out(1)
        One-cycle pulse, ``cycles`` clock cycles after the ``start`` cycle. A new
        ``start`` may be given in the ``done`` cycle (one division per
        ``cycles`` clocks back to back).

    Attributes
    ----------
    cycles : int
        ``dividend_bits + 1``: the ``start`` cycle loads the operands, then one
        cycle per quotient bit.

    Notes
    -----
    Divisor 0 is defined by what the restoring algorithm gives: every trial
    subtraction succeeds, so ``quotient = 2**dividend_bits - 1`` (all ones) and
    ``remainder = dividend mod 2**divisor_bits``. The centroid never divides by 0
    (an empty mask is detected from ``M00`` and output as (0, 0, 0)).
    """

    def __init__(self, dividend_bits: int, divisor_bits: int):
        self.dividend_bits = check_int("dividend_bits", dividend_bits, *OPERAND_BITS_RANGE)
        self.divisor_bits = check_int("divisor_bits", divisor_bits, *OPERAND_BITS_RANGE)
        self.cycles = divider_cycles(self.dividend_bits)
        super().__init__({
            "start": In(1),
            "dividend": In(self.dividend_bits),
            "divisor": In(self.divisor_bits),
            "quotient": Out(self.dividend_bits),
            "remainder": Out(self.divisor_bits),
            "busy": Out(1),
            "done": Out(1),
        })

    def elaborate(self, platform):
        m = Module()
        n = self.dividend_bits
        shifting = Signal(n, name="dividend_quotient")  # dividend bits out, quotient bits in
        partial = Signal(self.divisor_bits, name="partial_remainder")
        divisor = Signal(self.divisor_bits, name="divisor_r")
        remaining = Signal(range(n + 1))  # iterations still to run

        # One iteration: partial remainder with the next dividend bit appended
        # (divisor_bits + 1 bits: it is at most 2 * divisor - 1) and the trial
        # subtraction; its borrow decides the quotient bit.
        trial = Cat(shifting[n - 1], partial)
        difference = Signal(self.divisor_bits + 2)
        m.d.comb += difference.eq(trial - divisor)
        fits = ~difference[-1]

        m.d.sync += self.done.eq(0)
        with m.If(self.start):
            m.d.sync += [
                shifting.eq(self.dividend), partial.eq(0), divisor.eq(self.divisor),
                remaining.eq(n), self.busy.eq(1),
            ]
        with m.Elif(self.busy):
            m.d.sync += [
                shifting.eq(Cat(fits, shifting[:n - 1])),
                partial.eq(Mux(fits, difference, trial)),
                remaining.eq(remaining - 1),
            ]
            with m.If(remaining == 1):
                m.d.sync += [self.busy.eq(0), self.done.eq(1)]
        m.d.comb += [self.quotient.eq(shifting), self.remainder.eq(partial)]
        return m
