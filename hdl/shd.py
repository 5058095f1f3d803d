"""Sum of Hamming distances for every disparity (thesis eq. 3, Figs. 48-51).

Stream order: census codes of the left and right image at the row entering
the aggregation window (V1) and at the row leaving it, ``Wh`` rows above (V2,
Fig. 53) -> per disparity d the Hamming distances of the left code at x and
the right code at x - d (a delay line of D right codes per window; a left
pixel with x < d has no right partner and costs ``no_match_cost``) ->
:class:`~hdl.column_sum.ColumnSum` -> :class:`~hdl.window_sum.WindowSum`.

Memory (eq. 20 as built here): the column sums, ``(width * D - D * (D - 1) / 2)
* ceil(log2(Wh * bits + 1))`` bits; the census row buffers are counted by
:class:`~hdl.census.SparseCensus`.
"""
from __future__ import annotations

from amaranth.hdl import Cat, Module, Mux, Signal
from amaranth.lib import data, stream, wiring
from amaranth.lib.wiring import In, Out

from sim.model.matching import MAX_DISPARITY_RANGE

from ._util import check_geometry, check_int, check_odd_window, delay, register_input, \
    replicate
from .column_sum import ColumnSum, column_sum_memory_bits, column_sum_timing
from .hamming import HammingDistances, hamming_cycles
from .raster_position import RasterPosition
from .stage import StageTiming
from .window_sum import WindowSum, window_sum_bits, window_sum_memory_bits, \
    window_sum_timing

__all__ = ["SumOfHammingDistances", "shd_timing", "shd_cost_bits", "shd_memory_bits",
           "shd_stage", "SHD_STAGES"]

#: Disparities whose Hamming distances take the left code from one register
#: (each bank holds its own copies of the left code).
CODES_PER_COPY = 8

#: The parts of :class:`SumOfHammingDistances` by name (:func:`shd_stage`): the
#: column sums, the window sums and one of its two banks of ``max_disparity``
#: Hamming distances (alike).
SHD_STAGES = ("columns", "windows", "hamming")


def shd_timing(width: int, census_bits: int, hamming_window: int) -> StageTiming:
    """The input register, the Hamming banks, then the column sums, then the
    window sums."""
    columns = column_sum_timing(width, hamming_window)
    windows = window_sum_timing(hamming_window)
    return StageTiming(lag=columns.lag + windows.lag,
                       cycles=1 + hamming_cycles(census_bits) + columns.cycles + windows.cycles)


def shd_cost_bits(census_bits: int, hamming_window: int) -> int:
    """Bits of a cost: a window sum of ``Wh`` column sums of ``Wh`` distances
    (the ``sum_bits`` of its :class:`~hdl.window_sum.WindowSum`)."""
    return window_sum_bits(hamming_window, max_term=hamming_window * census_bits)


def shd_memory_bits(width: int, census_bits: int, hamming_window: int,
                    max_disparity: int) -> dict:
    """The ``memory_bits`` of its :class:`~hdl.column_sum.ColumnSum` and of its
    :class:`~hdl.window_sum.WindowSum`."""
    return {"column sums": column_sum_memory_bits(width, hamming_window, max_disparity,
                                                  max_term=census_bits),
            "window-sum ring buffer": window_sum_memory_bits(
                hamming_window, max_disparity, max_term=hamming_window * census_bits)}


def shd_stage(name: str, width: int, height: int, *, census_bits: int, hamming_window: int,
              max_disparity: int, no_match_cost: int | None = None):
    """The part ``name`` (:data:`SHD_STAGES`) of a :class:`SumOfHammingDistances`
    with these parameters, built alone, as its :meth:`~SumOfHammingDistances.elaborate`
    builds it."""
    if no_match_cost is None:
        no_match_cost = census_bits // 3
    if name == "columns":
        return ColumnSum(width, height, hamming_window=hamming_window,
                         max_disparity=max_disparity, max_term=census_bits,
                         no_match_cost=no_match_cost)
    if name == "windows":
        return WindowSum(width, height, hamming_window=hamming_window,
                         max_disparity=max_disparity, max_term=hamming_window * census_bits)
    if name == "hamming":
        return HammingDistances(census_bits, codes=max_disparity,
                                a_copies=-(-max_disparity // CODES_PER_COPY))
    raise ValueError(f"stage must be one of {', '.join(SHD_STAGES)}, got {name!r}")


class SumOfHammingDistances(wiring.Component):
    """SHD costs of every disparity for each left pixel.

    Parameters
    ----------
    width, height : frame size (width in [max(8, Wh + 1, D), 4096], height in [2, 4096])
    census_bits : int in [1, 64]
    hamming_window : odd int in [1, 63]
        Wh, side of the aggregation window.
    max_disparity : int in [1, 256]
        D: disparities 0 .. D-1.
    no_match_cost : int in [0, census_bits] or None (= census_bits // 3)

    Ports
    -----
    i_stream : payload ``{first, left, right, left2, right2}``: the census codes
        of position (x, y') and of (x, y' - Wh).
    o_stream : payload ``{first, real, cost}``: ``cost[d]`` = SHD_d at
        (x - r, y' - r), r = Wh // 2; ``lag`` = r * width + r.
    """

    def __init__(self, width: int, height: int, census_bits: int, hamming_window: int,
                 max_disparity: int, no_match_cost: int | None = None):
        self.census_bits = check_int("census_bits", census_bits, 1, 64)
        self.hamming_window = check_odd_window("hamming_window", hamming_window, 1, 63)
        self.max_disparity = check_int("max_disparity", max_disparity, *MAX_DISPARITY_RANGE)
        self.width, self.height = check_geometry(
            width, height, min_width=max(hamming_window + 1, max_disparity))
        if no_match_cost is None:
            no_match_cost = census_bits // 3
        self.no_match_cost = check_int("no_match_cost", no_match_cost, 0, census_bits)
        nd, w, wh = self.max_disparity, self.width, self.hamming_window
        self.lag, self.cycles = shd_timing(w, census_bits, wh)
        self.cost_bits = shd_cost_bits(census_bits, hamming_window=wh)
        self.memory_bits = shd_memory_bits(w, census_bits=census_bits, hamming_window=wh,
                                           max_disparity=nd)
        cb = census_bits
        super().__init__({
            "i_stream": In(stream.Signature(data.StructLayout({
                "first": 1, "left": cb, "right": cb, "left2": cb, "right2": cb}),
                always_ready=True)),
            # the window sums' output
            "o_stream": Out(stream.Signature(data.StructLayout({
                "first": 1, "real": 1, "cost": data.ArrayLayout(self.cost_bits, nd)}),
                always_ready=True)),
        })

    #: names of its parts (:meth:`stage`)
    stage_names = SHD_STAGES

    def stage(self, name: str):
        """The part ``name`` of :data:`SHD_STAGES`, freshly built with the
        parameters it has here (as :meth:`elaborate` builds its parts); only
        that part is built."""
        return shd_stage(name, self.width, self.height, census_bits=self.census_bits,
                         hamming_window=self.hamming_window, max_disparity=self.max_disparity,
                         no_match_cost=self.no_match_cost)

    #: code bits of one window per copy of the beat that steers their delay lines
    BITS_PER_BEAT = 8

    def elaborate(self, platform):
        m = Module()
        nd, cb = self.max_disparity, self.census_bits
        # An input register, and the beat once per BITS_PER_BEAT delay lines of a
        # window (and once for the rest): no single beat net steers all
        # 2 x (D - 1) x bits registers of the right codes' delay lines.
        groups = -(-cb // self.BITS_PER_BEAT)
        p, (beat, *line_beats) = register_input(m, self.i_stream, 1 + 2 * groups, "codes")
        pos = RasterPosition(self.width, self.height, 0, "pix").attach(m, beat, p.first)

        # Delay lines of the right codes in bit-plane order (what HammingDistances
        # takes): bit k of `right{win}_bit{j}` is bit j of the code at raster
        # position x - k - 1. The registers of a line of D codes, held as one
        # word per code bit instead of one per code.
        m.submodules.columns = cols = self.stage("columns")
        m.submodules.windows = wins = self.stage("windows")
        lh = hamming_cycles(cb)
        has_partner = delay(m, pos.thermometer(nd, "partner"), lh, "partner")  # bit d: x >= d
        for win, left, right, field, field_name in (
                (1, p.left, p.right, cols.i_stream.payload.enter, "left"),
                (2, p.left2, p.right2, cols.i_stream.payload.leave, "left2")):
            # one bank of D distances for the entering rows (V1), one for the leaving (V2)
            ham = self.stage("hamming")
            m.submodules[f"ham{win}"] = ham
            for j in range(cb):
                plane = right[j]
                if nd > 1:
                    line = Signal(nd - 1, name=f"right{win}_bit{j}", reset_less=True)
                    with m.If(line_beats[(win - 1) * groups + j // self.BITS_PER_BEAT]):
                        m.d.sync += line.eq(Cat(right[j], line[:-1]))
                    plane = Cat(right[j], line)
                m.d.comb += ham.b[j].eq(plane)
            # the left code registered once per CODES_PER_COPY disparities
            # (from the input, like `p`: no extra cycle)
            if ham.a_copies == 1:
                m.d.comb += ham.a.eq(left)
            else:
                for i, copy in enumerate(replicate(m, getattr(self.i_stream.payload, field_name),
                                                   ham.a_copies, f"left{win}_copy",
                                                   reset_less=True)):
                    m.d.comb += ham.a[i].eq(copy)
            for d in range(nd):
                m.d.comb += field[d].eq(Mux(has_partner[d], ham.distance[d], self.no_match_cost))
        m.d.comb += [
            cols.i_stream.valid.eq(delay(m, beat, lh, "valid")),
            cols.i_stream.payload.first.eq(delay(m, p.first, lh, "first")),
        ]
        m.d.comb += [
            wins.i_stream.valid.eq(cols.o_stream.valid),
            wins.i_stream.payload.first.eq(cols.o_stream.payload.first),
            wins.i_stream.payload.csum.eq(cols.o_stream.payload.csum),
        ]
        wiring.connect(m, wins.o_stream, wiring.flipped(self.o_stream))
        return m
