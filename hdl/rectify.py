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
from amaranth.hdl import Cat, Module, Mux, Signal, signed
from amaranth.lib import data, memory, stream, wiring
from amaranth.lib.wiring import In, Out

from sim.model.rectify import INTERPOLATIONS, RectifyGrid

from ._util import (NO_RW_COLLISION, bits_for, check_geometry, check_int, delay,
                    register_input, registered_read, replicate, times_constant)
from .raster_position import OVERRUN_ROWS, RasterPosition
from .stage import StageTiming

__all__ = ["Rectifier", "rectify_timing", "ring_rows", "check_rectifier", "rectify_memory_bits",
           "MAX_SHIFT_Y", "CHUNK_WORDS"]

#: Largest vertical reach of the row buffers, rows (the ring stays within the
#: position counters' overrun).
MAX_SHIFT_Y = (OVERRUN_ROWS - 6) // 2

#: Words of a row-buffer bank's memory chunk: one block deep at the widths
#: the blocks offer for 8 to 24-bit words (ECP5 DP16KD 2048 x 9, Cyclone V M10K
#: 2048 x 5), so a full chunk's output needs no multiplexer before its
#: register. A bank's last, shorter chunk is one memory per lane (8 bits):
#: as one memory of 24-bit words yosys built the default rig's 1,024-word
#: chunk of two ECP5 blocks in depth (512 x 36), and put a multiplexer there.
CHUNK_WORDS = 2048


def _partial_products(m, u, v, name: str) -> list:
    """The products of ``u`` (signed or not) by the low and by the high half
    of the unsigned ``v``'s bits, each a sum of shifted copies of ``u``,
    registered (``name``): ``[(register, shift), ...]``, whose shifted sum
    the next cycle is ``u * v``. Not a DSP block: the routing into and out of
    one took a cycle alone (routed on an ECP5: 3.4 + 3.1 + 4.1 ns between
    registers)."""
    half = (len(v) + 1) // 2
    parts = []
    for part, shift, bits in (("lo", 0, v[:half]), ("hi", half, v[half:])):
        if not len(bits):
            continue
        total = None
        for i, bit in enumerate(bits):
            term = Mux(bit, u << i, 0)
            total = term if total is None else total + term
        width = len(u) + len(bits)
        reg = Signal(signed(width + 1) if u.shape().signed else width,
                     name=f"{name}_{part}", reset_less=True)
        m.d.sync += reg.eq(total)
        parts.append((reg, shift))
    return parts


def _shifted_sum(parts):
    """The sum of :func:`_partial_products` terms (for the caller to register)."""
    total = None
    for reg, shift in parts:
        term = reg << shift
        total = term if total is None else total + term
    return total


def _product_in_two_cycles(m, u, v, name: str):
    """``u * v``: :func:`_partial_products` registered, their sum returned."""
    return _shifted_sum(_partial_products(m, u, v, name))


def ring_rows(max_shift_y: int) -> int:
    """Rows of the ring buffer: 2 Vmax + 3 rows in use at once, rounded up to
    even (the banks split rows by parity)."""
    return 2 * max_shift_y + 4


def rectify_timing(width: int, max_shift_x: int, max_shift_y: int) -> StageTiming:
    """Look-ahead (Vmax + 1) * width + Hmax + 2 beats; :attr:`Rectifier.cycles`
    (18: an input register, every memory read has a register stage of its
    own, every product two (shifts and adds, no DSP block), and each
    multiplier its own copy of a shared operand: issue 27's routed margin on
    an ECP5)."""
    return StageTiming(lag=(max_shift_y + 1) * width + max_shift_x + 2,
                       cycles=Rectifier.cycles)


def check_rectifier(width: int, height: int, grid: RectifyGrid, *, lanes: int = 1,
                    interpolation: str = "bilinear", max_shift_x: int | None = None,
                    max_shift_y: int | None = None) -> tuple[int, int, int, int, int]:
    """Check the parameters of a :class:`Rectifier` (``ValueError`` naming the
    first bad one) without building it; returns ``(width, height, lanes,
    max_shift_x, max_shift_y)``, the shifts defaulting to the grid's."""
    if not isinstance(grid, RectifyGrid):
        raise ValueError(f"grid must be a RectifyGrid, got {type(grid).__name__}")
    need_x, need_y = grid.max_shift
    max_shift_y = check_int("max_shift_y", need_y if max_shift_y is None else max_shift_y,
                            need_y, MAX_SHIFT_Y)
    max_shift_x = check_int("max_shift_x", need_x if max_shift_x is None else max_shift_x,
                            need_x, 4096)
    # the ring's writes trail the beat by 2 cycles and its reads by 9: a row
    # must outlast them (width >= Hmax + 10; 2 Hmax + 12 keeps a margin)
    width, height = check_geometry(width, height, min_width=2 * max_shift_x + 12)
    if width % 2:
        raise ValueError(f"width must be even (the banks split columns by parity), "
                         f"got {width}")
    if (grid.width, grid.height) != (width, height):
        raise ValueError(f"grid is for {grid.width}x{grid.height} frames, not "
                         f"{width}x{height}")
    lanes = check_int("lanes", lanes, 1, 4)
    if interpolation not in INTERPOLATIONS:
        raise ValueError(f"interpolation must be one of {', '.join(INTERPOLATIONS)}, "
                         f"got {interpolation!r}")
    if width - grid.dx.shape[1] < 6:
        # a row's map line is written while the row before is output
        raise ValueError(f"grid_step {grid.grid_step} is too fine for width {width}: "
                         f"the grid's {grid.dx.shape[1]} columns need width - 6 beats")
    return width, height, lanes, max_shift_x, max_shift_y


def _map_bits(grid: RectifyGrid) -> tuple[int, int, int]:
    """Signed bits of a grid value, bits of a line value and address bits of a
    line memory's half (even or odd grid columns)."""
    limit = int(max(np.abs(grid.dx).max(), np.abs(grid.dy).max(), 1))
    grid_bits = bits_for(limit) + 1
    step_bits = grid.grid_step.bit_length() - 1
    line_bits = grid_bits + step_bits + 1
    line_col_bits = max(1, ((grid.dx.shape[1] + 1) // 2 - 1).bit_length())
    return grid_bits, line_bits, line_col_bits


def rectify_memory_bits(width: int, grid: RectifyGrid, *, lanes: int = 1,
                        max_shift_y: int) -> dict:
    """The ``memory_bits`` of a :class:`Rectifier` with these (checked) parameters:
    the ring of image rows, the map grid ROM and the two line memories."""
    grid_bits, line_bits, line_col_bits = _map_bits(grid)
    grid_rows, grid_cols = grid.dx.shape
    return {
        "row buffers": ring_rows(max_shift_y) * width * 8 * lanes,
        "map grid": grid_rows * grid_cols * 2 * grid_bits,
        "map line": 2 * (2 << line_col_bits) * 2 * line_bits,
    }


class Rectifier(wiring.Component):
    """Rectifies a pixel stream of ``lanes`` 8-bit channels with one map.

    Parameters
    ----------
    width, height : frame size (width even, in [max(8, 2 Hmax + 12), 4096])
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

    cycles = 20

    def __init__(self, width: int, height: int, grid: RectifyGrid, *, lanes: int = 1,
                 interpolation: str = "bilinear", max_shift_x: int | None = None,
                 max_shift_y: int | None = None):
        self.width, self.height, self.lanes, self.max_shift_x, self.max_shift_y = \
            check_rectifier(width, height, grid, lanes=lanes, interpolation=interpolation,
                            max_shift_x=max_shift_x, max_shift_y=max_shift_y)
        self.grid, self.interpolation = grid, interpolation
        self.lag = rectify_timing(self.width, self.max_shift_x, self.max_shift_y).lag
        self.rows = ring_rows(self.max_shift_y)
        self.grid_rows, self.grid_cols = grid.dx.shape
        #: signed bits of a grid value, bits of a line value, address bits of a
        #: line memory's half (even or odd grid columns)
        self.grid_bits, self.line_bits, self.line_col_bits = _map_bits(grid)
        self.memory_bits = rectify_memory_bits(self.width, grid, lanes=self.lanes,
                                               max_shift_y=self.max_shift_y)
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
        # the input registered, its beat once for each position counter and
        # once for the rest: every path starts at a register of this stage
        p, (beat, beat_in, beat_out, beat_ahead) = register_input(
            m, self.i_stream, 4, "input")

        def reg(value, name, cycles=1):
            return delay(m, value, cycles, name)

        pos_in = RasterPosition(w, h, 0, "in").attach(m, beat_in, p.first)
        out = RasterPosition(w, h, self.lag, "out").attach(m, beat_out, p.first)
        ahead = RasterPosition(w, h, self.lag - w, "next").attach(m, beat_ahead, p.first)

        # --- ring buffer: four banks by (row parity, column parity) ---------------------
        # written three cycles after the beat (the address is a product and a sum),
        # every write port fed from registers
        slot_bits = bits_for(rows - 1)
        slot_in = Signal(slot_bits)                   # input row mod rows
        slot_in_cur = Mux(p.first, 0, slot_in)
        with m.If(beat & (pos_in.x == w - 1)):
            m.d.sync += slot_in.eq(Mux(slot_in_cur == rows - 1, 0, slot_in_cur + 1))
        with m.Elif(beat):
            m.d.sync += slot_in.eq(slot_in_cur)
        depth = rows // 2 * half_w
        w_half_1 = reg(slot_in_cur >> 1, "wslot")
        w_bank_1 = reg(Cat(pos_in.x[0], slot_in_cur[0]), "wbank")
        w_col_2 = reg(pos_in.x >> 1, "wcol", 2)
        w_row_2 = Signal(range(depth + 1), name="wrow")
        m.d.sync += w_row_2.eq(times_constant(w_half_1, half_w))
        w_bank_2 = reg(w_bank_1, "wbank2")
        w_en_2 = reg(beat, "wen", 2)
        w_data_2 = reg(p.pixel.as_value(), "wdata", 2)
        depth_bits = (depth - 1).bit_length()
        # each bank in chunks of at most CHUNK_WORDS, one block deep, whose
        # outputs are registered before they are multiplexed (a block's output
        # is slow, and a bank of several blocks in depth put that multiplexer
        # in the same cycle: the limit of the routed rectified pipeline)
        chunk_bits = min(depth_bits, CHUNK_WORDS.bit_length() - 1)
        chunks = -(-depth >> chunk_bits)
        w_addr_2 = (w_row_2 + w_col_2)[:depth_bits]
        w_addr_3 = reg(w_addr_2[:chunk_bits], "waddr3")
        w_data_3 = reg(w_data_2, "wdata3")
        read_addr = [Signal(depth_bits, name=f"raddr_{b}") for b in range(4)]
        banks = []
        for b in range(4):
            chunk_data = []
            for c in range(chunks):
                size = min(depth - (c << chunk_bits), 1 << chunk_bits)
                name = f"bank_{b}_{c}" if chunks > 1 else f"bank_{b}"
                split = size < CHUNK_WORDS and self.lanes > 1
                lane_bits = 8 if split else 8 * self.lanes
                lane_data = []
                for lane in range(self.lanes if split else 1):
                    # (the output reads rows written at least a beat and a dozen
                    # cycles before; the write goes to the newest row)
                    chunk = memory.Memory(shape=lane_bits, depth=size, init=[],
                                          attrs=NO_RW_COLLISION)
                    m.submodules[f"{name}_lane{lane}" if split else name] = chunk
                    wr = chunk.write_port()
                    m.d.comb += [wr.addr.eq(w_addr_3),
                                 wr.data.eq(w_data_3[lane * lane_bits:(lane + 1) * lane_bits]),
                                 wr.en.eq(reg(w_en_2 & (w_bank_2 == b)
                                              & (w_addr_2[chunk_bits:] == c),
                                              f"wen3_{name}_{lane}"))]
                    lane_data.append(registered_read(m, chunk, read_addr[b][:chunk_bits],
                                                     f"{name}_word{lane}"))
                chunk_data.append(Cat(*lane_data))
            banks.append(chunk_data)

        # --- map: vertical interpolation one row ahead ----------------------------------
        words = [(int(dy) & ((1 << gb) - 1)) << gb | (int(dx) & ((1 << gb) - 1))
                 for dx, dy in zip(grid.dx.ravel(), grid.dy.ravel())]
        rom = memory.Memory(shape=2 * gb, depth=len(words), init=words)
        m.submodules.grid = rom
        top, bottom = rom.read_port(), rom.read_port()
        cols = self.grid_cols
        in_grid = beat & (ahead.y >= 0) & (ahead.y < h) & (ahead.x < cols)
        # the grid row's first word (a product), then both addresses (sums), each
        # registered: a sum in front of a memory block's address is slow
        base_1 = Signal(range(self.grid_rows * cols + 1), name="vbase")
        m.d.sync += base_1.eq(times_constant((ahead.y >> s)[:bits_for(self.grid_rows)], cols))
        k_1, fy_1 = reg(ahead.x[:bits_for(cols)], "vk"), reg(ahead.y[:s], "vfy")
        parity_1, ok_1 = reg(ahead.y[0], "vrow"), reg(in_grid, "vok")
        top_addr, bottom_addr = (Signal(range(len(words)), name=n)
                                 for n in ("vtop_addr", "vbottom_addr"))
        m.d.sync += [top_addr.eq(Mux(ok_1, base_1 + k_1, 0)),
                     bottom_addr.eq(Mux(ok_1, base_1 + k_1 + cols, 0))]
        k_2, fy_2, parity_2, ok_2 = (reg(v, n) for v, n in ((k_1, "vk2"), (fy_1, "vfy2"),
                                                             (parity_1, "vrow2"), (ok_1, "vok2")))
        m.d.comb += [top.addr.eq(top_addr), bottom.addr.eq(bottom_addr)]
        # the grid words registered first: the ROM spans several blocks, whose
        # outputs are multiplexed
        top_4, bottom_4 = reg(top.data, "vtop"), reg(bottom.data, "vbottom")
        fy_3 = reg(fy_2, "vfy3")
        # the weights registered as they are, next to the multipliers
        fy_4, nfy_4 = reg(fy_3, "vfy4"), reg(step - fy_3, "vnfy4")
        line_shape = data.StructLayout({"dx": signed(lb), "dy": signed(lb)})
        # (each product's two partial products, then the four summed at once)
        products = []
        for lo in (0, gb):
            g0 = top_4[lo:lo + gb].as_signed()
            g1 = bottom_4[lo:lo + gb].as_signed()
            products.append(_partial_products(m, g0, nfy_4, f"vtop_{lo}")
                            + _partial_products(m, g1, fy_4, f"vbot_{lo}"))
        v_new = Signal(line_shape)
        m.d.sync += [v_new.dx.eq(_shifted_sum(products[0])),
                     v_new.dy.eq(_shifted_sum(products[1]))]
        k_6, parity_6, ok_6 = reg(k_2, "vk6", 4), reg(parity_2, "vrow6", 4), reg(ok_2, "vok6", 4)
        lines = []
        col_bits = self.line_col_bits
        for odd in (0, 1):
            # (written a row ahead: the other half, by the row's parity, is read)
            line = memory.Memory(shape=line_shape, depth=2 << col_bits, init=[],
                                 attrs=NO_RW_COLLISION)
            m.submodules[f"line_{'odd' if odd else 'even'}"] = line
            wr = line.write_port()
            # (from registers: the address, the word, the enable a cycle later)
            m.d.comb += [wr.addr.eq(reg(Cat(k_6[1:1 + col_bits], parity_6), f"laddr_{odd}")),
                         wr.data.eq(reg(v_new.as_value(), f"lword_{odd}")),
                         wr.en.eq(reg(ok_6 & (k_6[0] == odd), f"len_{odd}"))]
            line_addr = Signal(col_bits + 1, name=f"line_addr_{odd}")
            lines.append((line_addr, registered_read(m, line, line_addr, f"line_word_{odd}")))

        # --- per output pixel, one register stage after another (20 in all) -----------
        x_1, y_1 = reg(out.x, "x1"), reg(out.y, "y1")
        gx_1 = x_1 >> s
        for (line_addr, _), addr in ((lines[0], (gx_1 + 1) >> 1), (lines[1], gx_1 >> 1)):
            m.d.comb += line_addr.eq(Cat(addr[:col_bits], reg(out.y[0], "row1")))
        # V(gx), V(gx + 1) out of the line memories (the even one holds V(gx) when
        # gx is even, V(gx + 1) when odd), each times its weight: the weights swap,
        # not the words, so the memories feed the multipliers directly
        # (registered once more: a memory block's output is slow to reach a multiplier)
        x_w, y_w = reg(x_1, "x2", 2), reg(y_1, "y2", 2)
        fx_1 = x_1[:s]
        swap_1 = gx_1[0]
        w_even, w_odd = Signal(s + 1, name="w_even"), Signal(s + 1, name="w_odd")
        m.d.sync += [w_even.eq(Mux(swap_1, fx_1, step - fx_1)),
                     w_odd.eq(Mux(swap_1, step - fx_1, fx_1))]
        # one copy of each weight per multiplier (kept apart in synthesis)
        w_even = dict(zip(("dx", "dy"), replicate(m, w_even, 2, "w_even3", reset_less=True)))
        w_odd = dict(zip(("dx", "dy"), replicate(m, w_odd, 2, "w_odd3", reset_less=True)))
        even = data.View(line_shape, reg(lines[0][1].as_value(), "even3"))
        odd = data.View(line_shape, reg(lines[1][1].as_value(), "odd3"))
        sum_bits = lb + s + 1
        blend = {}
        for axis in ("dx", "dy"):
            parts = (_partial_products(m, getattr(even, axis), w_even[axis], f"h0_{axis}")
                     + _partial_products(m, getattr(odd, axis), w_odd[axis], f"h1_{axis}"))
            total = Signal(signed(sum_bits + 1), name=f"h_{axis}")
            m.d.sync += total.eq(_shifted_sum(parts))
            blend[axis] = total
        # the source position, rounded (and, for nearest, to whole pixels) in one add:
        # ((base << F + 2s) + half + [2^(F-1) << 2s] + sum) >> 2s
        coord_bits = max(bits_for(w), bits_for(h + OVERRUN_ROWS)) + f + 2
        round_const = (1 << (2 * s - 1)) + ((1 << (f - 1 + 2 * s))
                                            if self.interpolation == "nearest" else 0)
        src = {}
        for axis, base in (("dx", reg(x_w, "x4", 2)), ("dy", reg(y_w, "y4", 2))):
            wide = Signal(signed(coord_bits + 2 * s), name=f"src_{axis}_wide")
            m.d.comb += wide.eq(blend[axis] + (base.as_signed() if axis == "dy" else base)
                                * (1 << (f + 2 * s)) + round_const)
            value = Signal(signed(coord_bits), name=f"src_{axis}")
            shifted = wide >> (2 * s)
            if self.interpolation == "nearest":
                shifted = (shifted >> f) << f
            m.d.sync += value.eq(shifted)
            src[axis] = value
        y_src = reg(y_w, "y5", 3)
        slot_out = Signal(slot_bits)
        first_slot = out.y0 % rows            # the row of the frame's first output beat
        with m.If(beat):
            with m.If(p.first):
                m.d.sync += slot_out.eq((first_slot + (out.x0 == w - 1)) % rows)
            with m.Elif(out.x == w - 1):
                m.d.sync += slot_out.eq(Mux(slot_out == rows - 1, 0, slot_out + 1))
        slot_r = reg(Mux(p.first, first_slot, slot_out), "slot7", 7)
        # whole and fraction parts, the row offset, the neighbours
        sx, sy = src["dx"], src["dy"]
        ix, iy = sx >> f, sy >> f
        sbits = len(ix)
        ix_r, iy_r = reg(ix, "ix6"), reg(iy, "iy6")
        ix1_r = Signal(signed(sbits + 1), name="ix1_r")
        iy1_r = Signal(signed(sbits + 1), name="iy1_r")
        dyi_r = Signal(signed(sbits + 1), name="dyi_r")
        m.d.sync += [ix1_r.eq(ix + 1), iy1_r.eq(iy + 1), dyi_r.eq(iy - y_src)]
        ax_r, ay_r = reg(sx[:f], "ax6"), reg(sy[:f], "ay6")
        # the top row's slot (three sums, one chosen); each bank's row,
        # column and whether it lies inside the frame
        wrapped = slot_r + dyi_r
        slot_top = Signal(slot_bits, name="slot_top7")
        m.d.sync += slot_top.eq(Mux(wrapped < 0, wrapped + rows,
                                      Mux(wrapped >= rows, wrapped - rows, wrapped)))
        col_half, inside, same_row = [], [], []
        for b in range(4):
            px, py = b & 1, b >> 1
            col = Mux(ix_r[0] == px, ix_r, ix1_r)
            row = Mux(iy_r[0] == py, iy_r, iy1_r)
            ok = Signal(name=f"inside7_{b}")
            m.d.sync += ok.eq((col >= 0) & (col < w) & (row >= 0) & (row < h))
            half = Signal(range(half_w), name=f"col7_{b}")
            m.d.sync += half.eq(col[1:])
            same = Signal(name=f"same7_{b}")
            m.d.sync += same.eq(iy_r[0] == py)
            col_half.append(half)
            inside.append(ok)
            same_row.append(same)
        # each bank's slot and its read address
        slot_bottom = Mux(slot_top == rows - 1, 0, slot_top + 1)
        chunk_of = []
        for b in range(4):
            slot_bank = Signal(slot_bits, name=f"slot8_{b}")
            m.d.sync += slot_bank.eq(Mux(inside[b], Mux(same_row[b], slot_top, slot_bottom),
                                      0))
            # the whole address in a register, so that only routing lies between
            # it and the blocks (routed, the row base's register, the adder
            # and the way to the blocks cost 9.5 ns on a placement)
            col_bank = reg(Mux(inside[b], col_half[b], 0), f"col8_{b}")
            addr = Signal(depth_bits, name=f"raddr9_{b}")
            m.d.sync += addr.eq((times_constant(slot_bank >> 1, half_w) + col_bank)[:depth_bits])
            m.d.comb += read_addr[b].eq(addr)
            chunk_of.append(reg(addr[chunk_bits:], f"chunk12_{b}", 3))
        # each chunk's word registered twice: the first register's only sink
        # is the second, so it sits by its block (a block's output is late,
        # 4.3 ns after the clock, and routed across the chip to a register
        # pulled towards the chunk choice it cost 9.8 ns); the chunk's word of
        # each bank registered (gathering the chunks' words and choosing the
        # tap in one cycle was routed at 9.5 ns); then each bank's word to its
        # tap (00, 10, 01, 11: x, y offsets), 0 outside; the weights
        words = []
        for b, chunk_data in enumerate(banks):
            chunk_words = [reg(reg(word, f"word11_{b}_{c}"), f"word12_{b}_{c}")
                           for c, word in enumerate(chunk_data)]
            word = Signal(8 * self.lanes, name=f"word12_{b}")
            with m.Switch(chunk_of[b]):
                for c, chunk_word in enumerate(chunk_words):
                    with m.Case(c):
                        m.d.comb += word.eq(chunk_word)
            words.append(reg(word, f"word13_{b}"))
        inside_late = [reg(ok, f"inside13_{b}", 6) for b, ok in enumerate(inside)]
        ix_odd, iy_odd = reg(ix_r[0], "ixodd", 7), reg(iy_r[0], "iyodd", 7)
        one = 1 << f
        # the fractions and their complements registered
        ax_8, ay_8 = reg(ax_r, "ax8", 4), reg(ay_r, "ay8", 4)
        ax_9, ay_9 = reg(ax_8, "ax9"), reg(ay_8, "ay9")
        nax_9, nay_9 = reg(one - ax_8, "nax9"), reg(one - ay_8, "nay9")
        taps = []
        for dx_, dy_ in ((0, 0), (1, 0), (0, 1), (1, 1)):
            word = Signal(8 * self.lanes, name=f"tap_{dx_}{dy_}")
            with m.Switch(Cat(ix_odd ^ dx_, iy_odd ^ dy_)):
                for b in range(4):
                    with m.Case(b):
                        m.d.sync += word.eq(Mux(inside_late[b], words[b], 0))
            taps.append(word)
        weights = []
        for k, (u, v) in enumerate(((nax_9, nay_9), (ax_9, nay_9), (nax_9, ay_9), (ax_9, ay_9))):
            weight = Signal(2 * f + 1, name=f"weight_{k}")
            m.d.sync += weight.eq(_product_in_two_cycles(m, u, v, f"weight10_{k}"))
            # then one copy per lane's multiplier (kept apart in synthesis)
            weights.append(replicate(m, weight, self.lanes, f"weight12_{k}", reset_less=True))
        # products; two sums; the rounded total
        outs = []
        for lane in range(self.lanes):
            prods = []
            for k, (weight, tap) in enumerate(zip(weights, taps)):
                prod = Signal(8 + 2 * f + 1, name=f"prod14_{lane}_{k}", reset_less=True)
                m.d.sync += prod.eq(_product_in_two_cycles(
                    m, weight[lane], tap[8 * lane:8 * lane + 8], f"prod13_{lane}_{k}"))
                prods.append(prod)
            pair_a = Signal(8 + 2 * f + 2, name=f"pair_a_{lane}")
            pair_b = Signal(8 + 2 * f + 2, name=f"pair_b_{lane}")
            m.d.sync += [pair_a.eq(prods[0] + prods[1]), pair_b.eq(prods[2] + prods[3])]
            total = Signal(8 + 2 * f + 2, name=f"total_{lane}")
            m.d.sync += total.eq(pair_a + pair_b + (1 << (2 * f - 1)))
            outs.append(total[2 * f:2 * f + 8])
        o = self.o_stream.payload
        m.d.comb += [
            self.o_stream.valid.eq(delay(m, beat, self.cycles - 1, "valid")),
            o.first.eq(delay(m, out.is_first, self.cycles - 1, "first")),
            o.real.eq(delay(m, out.real, self.cycles - 1, "real")),
            o.pixel.eq(Cat(*outs)),
        ]
        return m
