"""The raster position of a stage's beats (see the stream convention in :mod:`hdl`)."""
from __future__ import annotations

from amaranth.hdl import Cat, Mux, Signal, signed

from ._util import bits_for

__all__ = ["RasterPosition", "OVERRUN_ROWS"]

#: Rows a position counter runs past the frame before it saturates: more than
#: the flush of any stage (windows of at most 63 rows).
OVERRUN_ROWS = 64


class RasterPosition:
    """Position counter of a stage: the raster position ``lag`` beats behind the
    input beat being consumed.

    ``x`` (0 .. width-1) and ``y`` (signed, may be negative before the frame and
    saturates at ``height + OVERRUN_ROWS`` after it, beyond any window) are
    combinational signals valid in the cycle of a beat. A beat with ``first``
    high is raster index 0 at the input, so its position is index ``-lag``.
    Before the first frame ``y`` is past the frame (not real).
    """

    def __init__(self, width: int, height: int, lag: int, name: str = "pos"):
        self.width, self.height, self.lag = width, height, lag
        self.x0 = (-lag) % width
        self.y0 = (-lag) // width
        lo = min(self.y0, 0)
        self.y_max = height + OVERRUN_ROWS
        ybits = max(bits_for(self.y_max + 1), bits_for(-lo)) + 1
        self.x = Signal(range(width), name=f"{name}_x")
        self.y = Signal(signed(ybits), name=f"{name}_y")
        # Registers of the current position (valid except on a frame's first beat),
        # with x + 1, y + 1 and the row-end / saturation flags kept ready, so the
        # next position is a multiplexer of registers (no adder in front of users).
        self._x = Signal(range(width), name=f"{name}_xr")
        self._x1 = Signal(range(width + 1), name=f"{name}_x1r", init=1)
        self._y = Signal(signed(ybits), name=f"{name}_yr", init=self.y_max)
        self._y1 = Signal(signed(ybits), name=f"{name}_y1r", init=self.y_max + 1)
        self._wrap = Signal(name=f"{name}_wrapr", init=int(width == 1))
        self._sat = Signal(name=f"{name}_satr", init=1)
        self.name = name

    def attach(self, m, beat, first):
        """Add the counter to module ``m``: it advances on ``beat``, and
        ``first`` (valid with the beat) restarts it at the frame's start.
        Returns ``self``, whose ``x``, ``y`` and helpers are then usable."""
        w = self.width
        x0, y0 = self.x0, self.y0
        x1 = Mux(first, x0 + 1, self._x1)
        y1 = Mux(first, y0 + 1, self._y1)
        wrap = Mux(first, int(x0 == w - 1), self._wrap)
        sat = Mux(first, int(y0 >= self.y_max), self._sat)
        m.d.comb += [
            self.x.eq(Mux(first, x0, self._x)),
            self.y.eq(Mux(first, y0, self._y)),
        ]
        self._cur_wrap, self._cur_sat = wrap, sat
        self._nx = Mux(wrap, 0, x1)
        self._ny = Mux(wrap & ~sat, y1, self.y)
        with m.If(beat):
            m.d.sync += [
                self._x.eq(self._nx), self._x1.eq(self._nx + 1),
                self._y.eq(self._ny), self._y1.eq(self._ny + 1),
                self._wrap.eq(self._nx == w - 1), self._sat.eq(self._ny >= self.y_max),
            ]
        self._m, self._beat, self._first = m, beat, first
        return self

    def registered(self, cond, name: str = "flag", shape=1, *, first=None, beat=None,
                   attrs=None):
        """``cond(x, y)`` of the current position from a register: evaluated for
        the next position on each beat (and for the first position at the
        frame start), so only a multiplexer lies between the register and the
        user. ``cond`` must also accept Python ints.

        A flag that steers many registers is built once per group, each with
        ``attrs`` (:data:`hdl._util.KEEP_REGISTER`) and its own copy of the
        frame-start ``first`` (equal to the one given to :meth:`attach`) and
        of the ``beat``, so no single net reaches them all."""
        m = self._m
        reg = Signal(shape, name=f"{self.name}_{name}", attrs=attrs or {})
        first = self._first if first is None else first

        def const(v):
            return int(bool(v)) if shape == 1 else int(v) % (1 << len(reg))

        # cond of the three possible next positions, straight from the registers
        # (the comparators run in parallel; one multiplexer picks the result)
        w = self.width
        x0, y0 = self.x0, self.y0
        nx0 = 0 if x0 == w - 1 else x0 + 1
        ny0 = y0 + 1 if x0 == w - 1 and y0 < self.y_max else y0
        same_row = cond(self._x1, self._y)
        next_row = cond(0, self._y1)
        stay = cond(0, self._y)
        nxt = Mux(self._wrap, Mux(self._sat, stay, next_row), same_row)
        with m.If(self._beat if beat is None else beat):
            m.d.sync += reg.eq(Mux(self._first, const(cond(nx0, ny0)), nxt))
        return Mux(first, const(cond(x0, y0)), reg)

    def thermometer(self, count: int, name: str = "thermo", *, firsts=None):
        """``count`` bits, bit k = (x >= k) for the current position, from a
        shift register (a 1 enters per beat, the row start resets it): one LUT
        level instead of a comparator per k, which synthesis tends to chain.

        ``firsts``: copies of the frame-start flag (the one :meth:`attach` was
        given, registered apart), each steering an equal run of the bits in
        order, so that no one flag net reaches all ``count`` bits' users."""
        m = self._m
        reg = Signal(count, name=f"{self.name}_{name}", init=1)
        start = int(min(self.x0 + 1, count) and (1 << min(self.x0 + 1, count)) - 1)
        if firsts is None:
            current = Mux(self._first, start, reg)
        else:
            run = -(-count // len(firsts))
            current = Cat(*(Mux(first, start >> lo, reg[lo:lo + run]
                                )[:min(run, count - lo)]
                            for lo, first in zip(range(0, count, run), firsts)))
        row_end = self.registered(lambda x, y: x == self.width - 1, f"{name}_end")
        with m.If(self._beat):
            m.d.sync += reg.eq(Mux(row_end, 1, (current << 1) | 1))
        return current

    def sliding_flags(self, count: int, low: int, high: int, axis: str, name: str = "flags"):
        """``count`` bits, bit i = (low - i <= v < high - i) with v the current
        position's x or y (``axis``): the in-frame masks of a window's columns or
        rows. Moving on by one position shifts the bits by one, so a register
        shifts (a new top bit from one registered comparison) instead of 2 *
        ``count`` comparators, which synthesis chains into deep logic."""
        m = self._m

        def bits(v):
            return sum(1 << i for i in range(count) if low - i <= v < high - i)

        top = count - 1
        reg = Signal(count, name=f"{self.name}_{name}")
        at_first = bits(self.x0 if axis == "x" else self.y0)
        current = Mux(self._first, at_first, reg)
        if axis == "x":
            entering = self.registered(
                lambda x, y: (x + 1 >= low - top) & (x + 1 < high - top), f"{name}_in")
            nxt = Mux(self._cur_wrap, bits(0), Cat(current[1:], entering))
        else:
            entering = self.registered(
                lambda x, y: (y + 1 >= low - top) & (y + 1 < high - top), f"{name}_in")
            nxt = Mux(self._cur_wrap & ~self._cur_sat, Cat(current[1:], entering), current)
        with m.If(self._beat):
            m.d.sync += reg.eq(nxt)
        return current

    @property
    def real(self):
        return (self.y >= 0) & (self.y < self.height)

    @property
    def is_first(self):
        return (self.x == 0) & (self.y == 0)
