"""Moving-window generator: a ``window`` x ``window`` neighbourhood of every
pixel, optionally a second window ``separation`` rows above it (the dual window
V1/V2 of thesis Fig. 53, which lets the SHD stage recompute the census codes of
the row leaving the aggregation window instead of storing them).

Each window row is a shift register of ``window`` pixels; the rows are chained
through :class:`~hdl.row_buffer.RowBuffer` delay lines: ``width - window`` beats
behind a window row (its register holds the rest of the row), ``width`` beats
behind a row no window uses (between V1 and V2). The window centre lags the
input by ``r`` rows and ``r`` pixels (r = window // 2). Memory:
``(rows behind a window row) * (width - window) + (other rows) * width`` pixels. Border handling: the
generator does not replace pixels outside the frame; it outputs, from x/y
counters, which window rows and columns lie inside the frame, and the consumer
masks those taps.
"""
from __future__ import annotations

from amaranth.hdl import Cat, Module, Signal
from amaranth.lib import data, stream, wiring
from amaranth.lib.wiring import In, Out

from ._util import PIXEL_BITS_RANGE, check_geometry, check_int, check_odd_window, delay, \
    replicate
from .raster_position import RasterPosition
from .row_buffer import RowBuffer
from .stage import StageTiming

__all__ = ["WindowGenerator", "window_timing", "window_memory_bits"]


def window_timing(width: int, window: int) -> StageTiming:
    """A ``window`` x ``window`` generator's look-ahead (its radius in rows and
    columns) and cycles (the row buffer's read, one register)."""
    radius = window // 2
    return StageTiming(lag=radius * width + radius, cycles=RowBuffer.cycles + 1)


def window_memory_bits(width: int, window: int, pixel_bits: int, separation: int = 0) -> int:
    """Bits of the row buffers of a :class:`~hdl.window.WindowGenerator` with
    these parameters (its ``memory_bits``), for the stages built around one:
    a line of ``width - window`` pixels behind each row a window uses, of
    ``width`` behind any other row."""
    used = set(range(window)) | set(range(separation, separation + window))
    rows = window - 1 + separation
    short = sum(1 for k in range(1, rows + 1) if k - 1 in used)
    return (short * (width - window) + (rows - short) * width) * pixel_bits


class WindowGenerator(wiring.Component):
    """``window`` x ``window`` taps around each pixel (and ``separation`` rows above).

    Parameters
    ----------
    width, height : frame size (width in [max(8, window + 2), 4096], height in [2, 4096])
    pixel_bits : int in [1, 16]
    window : odd int in [1, 63]
    separation : int in [0, 255 - window]
        0: one window (V1). Otherwise a second window V2 whose centre is
        ``separation`` rows above the centre of V1.

    Ports
    -----
    i_stream : payload ``{first, pixel}``
    o_stream : payload ``{first, real, v1, rows1, cols[, v2, rows2]}`` for the
        raster position ``r * width + r`` beats before the input beat (V1's
        centre). ``v1[i][j]`` is the pixel at (x + j - r, y + i - r);
        ``rows1[i]`` / ``cols[j]`` say whether that row / column is inside the
        frame; ``v2``, ``rows2`` likewise for centre (x, y - separation).
    """

    def __init__(self, width: int, height: int, pixel_bits: int, window: int,
                 separation: int = 0):
        self.window = check_odd_window("window", window, 1, 63)
        self.width, self.height = check_geometry(width, height, min_width=window + 2)
        self.pixel_bits = check_int("pixel_bits", pixel_bits, *PIXEL_BITS_RANGE)
        self.separation = check_int("separation", separation, 0, 255 - window)
        self.radius = window // 2
        self.lag, self.cycles = window_timing(self.width, window)
        self.buffer_rows = window - 1 + separation
        self.used_rows = sorted(set(range(window)) | set(range(separation,
                                                                separation + window)))
        self.memory_bits = window_memory_bits(self.width, window=window,
                                              pixel_bits=self.pixel_bits, separation=separation)
        tap = data.ArrayLayout(data.ArrayLayout(pixel_bits, window), window)
        fields = {"first": 1, "real": 1, "v1": tap, "rows1": window, "cols": window}
        if separation:
            fields.update({"v2": tap, "rows2": window})
        super().__init__({
            "i_stream": In(stream.Signature(data.StructLayout(
                {"first": 1, "pixel": pixel_bits}), always_ready=True)),
            "o_stream": Out(stream.Signature(data.StructLayout(fields), always_ready=True)),
        })

    #: window shift-register bits per copy of the beat that moves them
    SHIFT_BITS_PER_BEAT = 256

    def elaborate(self, platform):
        m = Module()
        w, h, win, r, sep = self.width, self.height, self.window, self.radius, self.separation
        beat = self.i_stream.valid
        first = self.i_stream.payload.first

        # Window position and border masks, computed at the input beat.
        pos = RasterPosition(w, h, self.lag, "centre").attach(m, beat, first)
        # (registered flags: comparisons with constants, done for the next position)
        rows1 = pos.sliding_flags(win, r, h + r, "y", "rows1")
        cols = pos.sliding_flags(win, r, w + r, "x", "cols")
        rows2 = pos.sliding_flags(win, sep + r, h + sep + r, "y", "rows2") if sep else 0

        # Rows k = 1 .. N above the input row reach the window through delay lines:
        # behind a window row (whose shift register already holds `win` pixels of
        # it) a line of width - win beats, behind any other row a line of width.
        pb = self.pixel_bits
        used = self.used_rows
        # One word per window row (tap s at bits s*pb ..): the same registers as
        # a register per tap, but a simulator shifts a row in one operation.
        shift_row = {k: Signal(win * pb, name=f"win_r{k}", reset_less=True) for k in used}
        shift = {k: [shift_row[k][s * pb:(s + 1) * pb] for s in range(win)] for k in used}
        short = [k for k in range(1, self.buffer_rows + 1) if k - 1 in used]
        long_ = [k for k in range(1, self.buffer_rows + 1) if k - 1 not in used]
        # the cycle the row buffers' words are valid, once per group of window
        # rows (a single copy's net spans every shift register of a census window)
        rows_per_copy = max(1, self.SHIFT_BITS_PER_BEAT // (win * pb))
        col_valid = replicate(m, delay(m, beat, RowBuffer.cycles - 1, "beat_late"),
                              -(-len(used) // rows_per_copy), "col_valid")
        column = {0: delay(m, self.i_stream.payload.pixel, RowBuffer.cycles, "col",
                           reset_less=True)}
        lines = []
        for name, rows, length in (("short", short, w - win), ("long", long_, w)):
            if not rows:
                continue
            # read every cycle: the lines are sampled only when their words are valid
            rb = RowBuffer(length=length, lanes=len(rows), pixel_bits=pb, hold_output=False)
            m.submodules[f"rows_{name}"] = rb
            m.d.comb += rb.beat.eq(beat)
            for lane, k in enumerate(rows):
                column[k] = rb.o_data[lane]
            lines.append((rb, rows))
        for rb, rows in lines:
            for lane, k in enumerate(rows):
                # sampled with the lines' words: the row below as it leaves its
                # window register (before this beat's shift) or its delay line
                src = shift[k - 1][win - 1] if k - 1 in used else column[k - 1]
                m.d.comb += rb.i_data[lane].eq(src)
        for n, k in enumerate(used):
            with m.If(col_valid[n // rows_per_copy]):
                m.d.sync += shift_row[k].eq(Cat(column[k], shift_row[k][:-pb]))

        out = self.o_stream.payload
        for i in range(win):
            for j in range(win):
                m.d.comb += out.v1[i][j].eq(shift[win - 1 - i][win - 1 - j])
                if sep:
                    m.d.comb += out.v2[i][j].eq(shift[sep + win - 1 - i][win - 1 - j])
        cyc = self.cycles
        m.d.comb += [
            self.o_stream.valid.eq(delay(m, beat, cyc, "valid")),
            out.first.eq(delay(m, pos.is_first, cyc, "first")),
            out.real.eq(delay(m, pos.real, cyc, "real")),
            out.rows1.eq(delay(m, rows1, cyc, "rows1")),
            out.cols.eq(delay(m, cols, cyc, "cols")),
        ]
        if sep:
            m.d.comb += out.rows2.eq(delay(m, rows2, cyc, "rows2"))
        return m
