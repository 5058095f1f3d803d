"""Stream rectification (thesis §10.1, future work): each output pixel is read
from the camera image at the position a compressed map gives, bit for bit
:func:`sim.model.rectify.rectify` (whose docstring has the arithmetic).

One pixel per clock, three parts:

* **Map.** The grid (``G``, a ROM) is interpolated vertically once per row: while
  the output is in row y - 1, beat k reads grid column k of grid rows gy and
  gy + 1 and writes ``V(k)`` for row y into a line memory (two of them, even and
  odd k, double-buffered by row parity), so each output pixel reads ``V(gx)``
  and ``V(gx + 1)`` in one cycle and blends them horizontally.
* **Row buffers.** The input is written into a ring of ``rows`` = 2 Vmax + 4
  image rows (Vmax = ``max_shift_y``), split into four banks by the parity of
  the row and of the column: the four source pixels of a bilinear blend, at
  (ix, iy), (ix + 1, iy), (ix, iy + 1), (ix + 1, iy + 1), always lie in four
  different banks, one read port each.
* **Blend.** The four pixels (0 outside the image), weighted by the position's
  fraction, rounded; ``nearest`` rounds the position first and blends with zero
  fractions, which is the nearest pixel.

The output at raster position (x, y) needs source rows up to y + Vmax + 1 and
columns up to x + Hmax + 1 (Hmax = ``max_shift_x``): ``lag`` = (Vmax + 1) *
width + Hmax + 2 beats.
"""
from __future__ import annotations

import numpy as np
from amaranth.hdl import Cat, Const, Module, Mux, Signal, signed
from amaranth.lib import data, memory, stream, wiring
from amaranth.lib.wiring import In, Out

from sim.model.rectify import INTERPOLATIONS, RectifyGrid

from ._util import bits_for, check_geometry, check_int, delay
from .raster_position import OVERRUN_ROWS, RasterPosition
from .stage import StageTiming

__all__ = ["Rectifier", "rectify_timing", "ring_rows", "MAX_SHIFT_Y"]

#: Largest vertical reach of the row buffers, rows (the ring stays within the
#: position counters' overrun).
MAX_SHIFT_Y = (OVERRUN_ROWS - 6) // 2


def ring_rows(max_shift_y: int) -> int:
    """Rows of the ring buffer: 2 Vmax + 3 rows in use at once, rounded up to
    even (the banks split rows by parity)."""
    return 2 * max_shift_y + 4


def rectify_timing(width: int, max_shift_x: int, max_shift_y: int) -> StageTiming:
    """Look-ahead (Vmax + 1) * width + Hmax + 2 beats; :attr:`Rectifier.cycles`."""
    return StageTiming(lag=(max_shift_y + 1) * width + max_shift_x + 2,
                       cycles=Rectifier.cycles)


class Rectifier(wiring.Component):
    """Rectifies a pixel stream of ``lanes`` 8-bit channels with one map.

    Parameters
    ----------
    width, height : frame size (width even, in [max(8, 2 Hmax + 8), 4096])
    grid : sim.model.rectify.RectifyGrid
        The camera's compressed map, for this frame size.
    lanes : int in [1, 4]
        Channels that share the map (3 for Y, Cb, Cr of the left camera).
    interpolation : "bilinear" or "nearest"
    max_shift_x, max_shift_y : int, default the grid's ``max_shift``
        Hmax and Vmax: the reach of the row buffers, at least the grid's
        (Vmax in [0, :data:`MAX_SHIFT_Y`]); a stereo pair uses one value for both
        cameras so that both have the same ``lag``.

    Ports
    -----
    i_stream : payload ``{first, pixel: lanes x 8}``
    o_stream : payload ``{first, real, pixel: lanes x 8}``, ``lag`` and ``cycles``
        from :func:`rectify_timing`.

    Attributes
    ----------
    rows : int
        Image rows of the ring buffer (:func:`ring_rows`).
    memory_bits : dict
        ``row buffers`` (rows * width * lanes * 8), ``map grid`` and ``map line``.
    """

    cycles = 8

    def __init__(self, width: int, height: int, grid: RectifyGrid, *, lanes: int = 1,
                 interpolation: str = "bilinear", max_shift_x: int | None = None,
                 max_shift_y: int | None = None):
        if not isinstance(grid, RectifyGrid):
            raise ValueError(f"grid must be a RectifyGrid, got {type(grid).__name__}")
        need_x, need_y = grid.max_shift
        self.max_shift_y = check_int("max_shift_y", need_y if max_shift_y is None
                                     else max_shift_y, need_y, MAX_SHIFT_Y)
        self.max_shift_x = check_int("max_shift_x", need_x if max_shift_x is None
                                     else max_shift_x, need_x, 4096)
        self.width, self.height = check_geometry(width, height,
                                                 min_width=2 * self.max_shift_x + 8)
        if self.width % 2:
            raise ValueError(f"width must be even (the banks split columns by parity), "
                             f"got {self.width}")
        if (grid.width, grid.height) != (self.width, self.height):
            raise ValueError(f"grid is for {grid.width}x{grid.height} frames, not "
                             f"{self.width}x{self.height}")
        self.lanes = check_int("lanes", lanes, 1, 4)
        if interpolation not in INTERPOLATIONS:
            raise ValueError(f"interpolation must be one of {', '.join(INTERPOLATIONS)}, "
                             f"got {interpolation!r}")
        self.grid, self.interpolation = grid, interpolation
        self.lag = rectify_timing(self.width, self.max_shift_x, self.max_shift_y).lag
        self.rows = ring_rows(self.max_shift_y)
        self.grid_rows, self.grid_cols = grid.dx.shape
        limit = int(max(np.abs(grid.dx).max(), np.abs(grid.dy).max(), 1))
        #: signed bits of a grid value
        self.grid_bits = bits_for(limit) + 1
        step_bits = grid.grid_step.bit_length() - 1
        self.line_bits = self.grid_bits + step_bits + 1
        #: address bits of a line memory's half (even or odd grid columns)
        self.line_col_bits = max(1, ((self.grid_cols + 1) // 2 - 1).bit_length())
        pixel_bits = 8 * self.lanes
        self.memory_bits = {
            "row buffers": self.rows * self.width * pixel_bits,
            "map grid": self.grid_rows * self.grid_cols * 2 * self.grid_bits,
            "map line": 2 * (2 << self.line_col_bits) * 2 * self.line_bits,
        }
        layout_in = data.StructLayout({"first": 1, "pixel": data.ArrayLayout(8, self.lanes)})
        layout_out = data.StructLayout({"first": 1, "real": 1,
                                        "pixel": data.ArrayLayout(8, self.lanes)})
        super().__init__({
            "i_stream": In(stream.Signature(layout_in, always_ready=True)),
            "o_stream": Out(stream.Signature(layout_out, always_ready=True)),
        })

    def elaborate(self, platform):
        m = Module()
        w, h, grid = self.width, self.height, self.grid
        step = grid.grid_step
        s = step.bit_length() - 1
        f = grid.frac_bits
        gb, lb = self.grid_bits, self.line_bits
        rows, half_w = self.rows, w // 2
        beat = self.i_stream.valid
        p = self.i_stream.payload

        pos_in = RasterPosition(w, h, 0, "in").attach(m, beat, p.first)
        out = RasterPosition(w, h, self.lag, "out").attach(m, beat, p.first)
        ahead = RasterPosition(w, h, self.lag - w, "next").attach(m, beat, p.first)

        # --- ring buffer: four banks by (row parity, column parity) ---------------------
        slot_bits = bits_for(rows - 1)
        slot_in = Signal(slot_bits)                   # input row mod rows
        slot_in_cur = Mux(p.first, 0, slot_in)
        with m.If(beat & (pos_in.x == w - 1)):
            m.d.sync += slot_in.eq(Mux(slot_in_cur == rows - 1, 0, slot_in_cur + 1))
        with m.Elif(beat):
            m.d.sync += slot_in.eq(slot_in_cur)
        depth = rows // 2 * half_w
        banks = []
        for b in range(4):
            bank = memory.Memory(shape=8 * self.lanes, depth=depth, init=[])
            m.submodules[f"bank_{b}"] = bank
            wr = bank.write_port()
            m.d.comb += [
                wr.addr.eq((slot_in_cur >> 1) * half_w + (pos_in.x >> 1)),
                wr.data.eq(p.pixel.as_value()),
                wr.en.eq(beat & (Cat(pos_in.x[0], slot_in_cur[0]) == b)),
            ]
            banks.append(bank.read_port(transparent_for=()))

        # --- map: grid ROM, vertical interpolation one row ahead ------------------------
        words = [(int(dy) & ((1 << gb) - 1)) << gb | (int(dx) & ((1 << gb) - 1))
                 for dx, dy in zip(grid.dx.ravel(), grid.dy.ravel())]
        rom = memory.Memory(shape=2 * gb, depth=len(words), init=words)
        m.submodules.grid = rom
        top, bottom = rom.read_port(domain="sync"), rom.read_port(domain="sync")
        gy_next = (ahead.y >> s)[:bits_for(self.grid_rows)]
        fy_next = ahead.y[:s] if s else Const(0, 1)
        k = ahead.x
        in_rows = (ahead.y >= 0) & (ahead.y < h)
        base = Signal(range(self.grid_rows * self.grid_cols + 1))
        m.d.comb += base.eq(gy_next * self.grid_cols + k)
        in_grid = in_rows & (k < self.grid_cols)
        m.d.comb += [top.addr.eq(Mux(in_grid, base, 0)),
                     bottom.addr.eq(Mux(in_grid, base + self.grid_cols, 0))]
        write_v = delay(m, beat & in_grid, 1, "vwrite")
        k_1 = delay(m, k, 1, "vk")
        fy_1 = delay(m, fy_next, 1, "vfy")
        parity_1 = delay(m, ahead.y[0], 1, "vrow")
        line_shape = data.StructLayout({"dx": signed(lb), "dy": signed(lb)})
        v_new = Signal(line_shape)
        for axis, lo in (("dx", 0), ("dy", gb)):
            g0 = top.data[lo:lo + gb].as_signed()
            g1 = bottom.data[lo:lo + gb].as_signed()
            m.d.sync += getattr(v_new, axis).eq((step - fy_1) * g0 + fy_1 * g1)
        write_v2 = delay(m, write_v, 1, "vwrite2")
        k_2 = delay(m, k_1, 1, "vk2")
        parity_2 = delay(m, parity_1, 1, "vrow2")
        lines = []
        col_bits = self.line_col_bits
        for odd in (0, 1):
            line = memory.Memory(shape=line_shape, depth=2 << col_bits, init=[])
            m.submodules[f"line_{'odd' if odd else 'even'}"] = line
            wr = line.write_port()
            m.d.comb += [wr.addr.eq(Cat(k_2[1:1 + col_bits], parity_2)),
                         wr.data.eq(v_new), wr.en.eq(write_v2 & (k_2[0] == odd))]
            lines.append(line.read_port(transparent_for=()))

        # --- per output pixel --------------------------------------------------------
        # c0 (the beat): the pair V(gx), V(gx + 1) is read
        gx = out.x >> s
        even_addr = (gx + 1) >> 1
        odd_addr = gx >> 1
        row_bit = out.y[0]
        for line, addr in ((lines[0], even_addr), (lines[1], odd_addr)):
            m.d.comb += line.addr.eq(Cat(addr[:col_bits], row_bit))
        x_1 = delay(m, out.x, 1, "x")
        y_1 = delay(m, out.y, 1, "y")
        # c1: blend V(gx), V(gx + 1) horizontally
        gx_odd_1 = (x_1 >> s)[0]
        fx_1 = x_1[:s] if s else Const(0, 1)
        v0 = Mux(gx_odd_1, lines[1].data, lines[0].data)
        v1 = Mux(gx_odd_1, lines[0].data, lines[1].data)
        v0, v1 = data.View(line_shape, v0), data.View(line_shape, v1)
        sum_bits = lb + s + 1
        sums = {}
        for axis in ("dx", "dy"):
            acc = Signal(signed(sum_bits), name=f"blend_{axis}")
            m.d.sync += acc.eq((step - fx_1) * getattr(v0, axis) + fx_1 * getattr(v1, axis))
            sums[axis] = acc
        x_2, y_2 = delay(m, x_1, 1, "x2"), delay(m, y_1, 1, "y2")
        # c2: source position sx, sy (F fraction bits); nearest rounds it here
        coord_bits = max(bits_for(w), bits_for(h + OVERRUN_ROWS)) + f + 2
        src = {}
        for axis, base_pos in (("dx", x_2), ("dy", y_2)):
            disp = (sums[axis] + (1 << (2 * s - 1) if s else 0)) >> (2 * s)
            pos = Signal(signed(coord_bits), name=f"src_{axis}")
            value = (base_pos << f) + disp
            if self.interpolation == "nearest":
                value = ((value + (1 << (f - 1))) >> f) << f
            m.d.sync += pos.eq(value)
            src[axis] = pos
        y_3 = delay(m, y_2, 1, "y3")
        # c3: the four taps' banks, rows, columns and addresses
        sx, sy = src["dx"], src["dy"]
        ix, iy = sx >> f, sy >> f
        ax, ay = sx[:f], sy[:f]
        # the output row's ring slot, counted along (y mod rows, y may be negative)
        slot_out = Signal(slot_bits)
        first_slot = (self.lag and (-(self.lag // w) - (1 if self.lag % w else 0))) % rows
        with m.If(beat):
            with m.If(p.first):
                m.d.sync += slot_out.eq(first_slot if out.x0 != w - 1
                                        else (first_slot + 1) % rows)
            with m.Elif(out.x == w - 1):
                m.d.sync += slot_out.eq(Mux(slot_out == rows - 1, 0, slot_out + 1))
        slot_cur = Mux(p.first, first_slot, slot_out)
        slot_3 = delay(m, slot_cur, 3, "slot")
        dyi = Signal(signed(coord_bits), name="row_offset")
        m.d.comb += dyi.eq(iy - y_3)
        slot_top = Signal(slot_bits + 2)
        wrapped = slot_3 + dyi
        m.d.comb += slot_top.eq(Mux(wrapped < 0, wrapped + rows,
                                    Mux(wrapped >= rows, wrapped - rows, wrapped)))
        slot_bottom = Mux(slot_top == rows - 1, 0, slot_top + 1)
        col_addr_bits = bits_for(half_w)
        addr_regs, inside_regs = [], []
        for b in range(4):
            px, py = b & 1, b >> 1
            col = Mux(ix[0] == px, ix, ix + 1)
            row = Mux(iy[0] == py, iy, iy + 1)
            slot = Mux(iy[0] == py, slot_top, slot_bottom)
            inside = (col >= 0) & (col < w) & (row >= 0) & (row < h)
            addr = Signal(range(depth), name=f"addr_{b}")
            m.d.sync += addr.eq(Mux(inside, (slot[:slot_bits] >> 1) * half_w
                                    + col[1:col_addr_bits + 1], 0))
            ok = Signal(name=f"inside_{b}")
            m.d.sync += ok.eq(inside)
            addr_regs.append(addr)
            inside_regs.append(ok)
        ix_odd_4 = delay(m, ix[0], 1, "ixodd")
        iy_odd_4 = delay(m, iy[0], 1, "iyodd")
        ax_4, ay_4 = delay(m, ax, 1, "ax"), delay(m, ay, 1, "ay")
        # c4: the banks read
        for bank, addr in zip(banks, addr_regs):
            m.d.comb += bank.addr.eq(addr)
        inside_5 = [delay(m, ok, 1, f"ok5_{b}") for b, ok in enumerate(inside_regs)]
        ix_odd_5, iy_odd_5 = delay(m, ix_odd_4, 1, "ixodd5"), delay(m, iy_odd_4, 1, "iyodd5")
        ax_5, ay_5 = delay(m, ax_4, 1, "ax5"), delay(m, ay_4, 1, "ay5")
        # c5: each bank's word to its tap (00, 10, 01, 11 = x, y offsets), 0 outside
        one = 1 << f
        tap_regs = []
        for dx_, dy_ in ((0, 0), (1, 0), (0, 1), (1, 1)):
            bx = ix_odd_5 ^ dx_
            by = iy_odd_5 ^ dy_
            choice = Cat(bx, by)
            word = Signal(8 * self.lanes, name=f"tap_{dx_}{dy_}")
            with m.Switch(choice):
                for b in range(4):
                    with m.Case(b):
                        m.d.sync += word.eq(Mux(inside_5[b], banks[b].data, 0))
            tap_regs.append(word)
        wx = Signal(f + 1, name="wx")
        wy = Signal(f + 1, name="wy")
        ax_6, ay_6 = delay(m, ax_5, 1, "ax6"), delay(m, ay_5, 1, "ay6")
        m.d.comb += [wx.eq(ax_6), wy.eq(ay_6)]
        # c6: the weighted sum per lane; c7: rounded
        weights = [(one - wx) * (one - wy), wx * (one - wy), (one - wx) * wy, wx * wy]
        outs = []
        for lane in range(self.lanes):
            total = Signal(8 + 2 * f + 2, name=f"blend_{lane}")
            m.d.sync += total.eq(sum(wt * tap[8 * lane:8 * lane + 8]
                                     for wt, tap in zip(weights, tap_regs))
                                 + (1 << (2 * f - 1)))
            pixel = Signal(8, name=f"pixel_{lane}")
            m.d.sync += pixel.eq(total >> (2 * f))
            outs.append(pixel)
        o = self.o_stream.payload
        m.d.comb += [
            self.o_stream.valid.eq(delay(m, beat, self.cycles, "valid")),
            o.first.eq(delay(m, out.is_first, self.cycles, "first")),
            o.real.eq(delay(m, out.real, self.cycles, "real")),
            o.pixel.eq(Cat(*outs)),
        ]
        return m
