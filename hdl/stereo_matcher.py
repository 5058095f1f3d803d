"""The stereo matcher of thesis §6.2 (the Fife & Archibald stream architecture,
Figs. 44-56) plus the 3x3 median of the disparity map: left and right pixel
streams in, disparity stream out, bit for bit the golden model
:func:`sim.model.stereo.stereo_match` (``prefilter_median=False``).

Pipeline::

    left  -> SparseCensus (V1, V2 = Wh rows above) -+
    right -> SparseCensus (V1, V2)                 -+-> SumOfHammingDistances
          -> DisparitySelectors (L2R tree, R2L chain) -> LeftRightCheck (Th)
          -> Median3x3 -> disparity

Frame protocol. The input is a frame of exactly ``width * height`` pixels in
raster order, ``valid`` may drop anywhere (inside rows, between frames). Every
stage advances only on a beat; after the frame's last pixel the matcher
inserts ``flush`` beats of its own (one per clock, ``i_stream.ready`` low
meanwhile) that push the frame's last ``flush`` results out, then accepts the
next frame. A frame therefore occupies at least ``width * height + flush``
clock cycles; each output pixel leaves ``flush`` beats plus ``cycles`` clock
cycles after its input pixel (``latency`` when the input has no gaps).
"""
from __future__ import annotations

from amaranth.hdl import Module, Mux, Signal
from amaranth.lib import data, stream, wiring
from amaranth.lib.wiring import In, Out

from sim.model.census import CENSUS_WINDOW_RANGE, census_bits
from sim.model.matching import HAMMING_WINDOW_RANGE, MAX_DISPARITY_RANGE

from ._util import (HEIGHT_RANGE, PIXEL_BITS_RANGE, WIDTH_RANGE, bits_for, check_int,
                    check_odd_window, replicate)
from .census import SparseCensus, census_memory_bits, census_timing
from .lrcc import LeftRightCheck, disparity_bits, lrcc_timing
from .median3x3 import Median3x3, median_memory_bits, median_timing
from .selectors import DisparitySelectors, selectors_timing
from .shd import (SHD_STAGES, SumOfHammingDistances, shd_cost_bits, shd_memory_bits, shd_stage,
                  shd_timing)
from .stage import StageTiming
from .streams import connect_remapped

__all__ = ["StereoMatcher", "matcher_timing", "matcher_memory_bits", "matcher_stage",
           "MATCHER_STAGES"]

#: The stages of :class:`StereoMatcher` by name, in dataflow order
#: (:func:`matcher_stage`); ``median`` only with ``disparity_median``.
MATCHER_STAGES = ("census_left", "census_right", "shd", "select", "check", "median")


def matcher_timing(width: int, census_window: int, hamming_window: int, max_disparity: int,
                   *, disparity_median: bool = True) -> StageTiming:
    """The census, SHD, selectors, consistency check and disparity median in
    series: their look-aheads add up to the flush beats a frame needs; their
    cycles, plus the input and output registers, to the pipeline depth."""
    stages = [census_timing(width, census_window),
              shd_timing(width, census_bits(census_window), hamming_window),
              selectors_timing(max_disparity), lrcc_timing(max_disparity)]
    if disparity_median:
        stages.append(median_timing(width))
    return StageTiming(lag=sum(s.lag for s in stages), cycles=2 + sum(s.cycles for s in stages))


def matcher_memory_bits(width: int, census_window: int, hamming_window: int,
                        max_disparity: int, *, pixel_bits: int = 8,
                        disparity_median: bool = True) -> dict:
    """The memory of each stage: both censuses' row buffers, the SHD's parts
    (:func:`~hdl.shd.shd_memory_bits`) and the disparity median's row buffers."""
    return {
        "census row buffers": 2 * census_memory_bits(width, census_window=census_window,
                                                     pixel_bits=pixel_bits,
                                                     separation=hamming_window),
        **shd_memory_bits(width, census_bits=census_bits(census_window),
                          hamming_window=hamming_window, max_disparity=max_disparity),
        "median row buffers": (median_memory_bits(width,
                                                  pixel_bits=disparity_bits(max_disparity))
                               if disparity_median else 0),
    }


def matcher_stage(name: str, width: int, height: int, *, census_window: int = 7,
                  hamming_window: int = 29, max_disparity: int = 48, pixel_bits: int = 8,
                  no_match_cost: int | None = None, disparity_median: bool = True):
    """The stage ``name`` of a :class:`StereoMatcher` with these parameters (its
    own), built alone as its :meth:`~StereoMatcher.elaborate` builds it.

    ``name`` is one of :data:`MATCHER_STAGES` (``median`` only with
    ``disparity_median``) or ``shd.`` and a part of the SHD
    (:data:`~hdl.shd.SHD_STAGES`). Nothing else is built.
    """
    bits = census_bits(census_window)
    if no_match_cost is None:
        no_match_cost = bits // 3
    if name in ("census_left", "census_right"):
        return SparseCensus(width, height, census_window=census_window, pixel_bits=pixel_bits,
                            separation=hamming_window)
    shd = dict(census_bits=bits, hamming_window=hamming_window, max_disparity=max_disparity,
               no_match_cost=no_match_cost)
    if name == "shd":
        return SumOfHammingDistances(width, height, **shd)
    if name.startswith("shd.") and name[4:] in SHD_STAGES:
        return shd_stage(name[4:], width, height, **shd)
    if name == "select":
        return DisparitySelectors(width, height, max_disparity=max_disparity,
                                  cost_bits=shd_cost_bits(bits, hamming_window=hamming_window))
    if name == "check":
        return LeftRightCheck(width, height, max_disparity=max_disparity)
    if name == "median" and disparity_median:
        return Median3x3(width, height, pixel_bits=disparity_bits(max_disparity))
    names = [n for n in MATCHER_STAGES if n != "median" or disparity_median]
    raise ValueError(f"stage must be one of {', '.join(names)} or shd.<part> "
                     f"({', '.join(SHD_STAGES)}), got {name!r}")


class StereoMatcher(wiring.Component):
    """Disparity stream of a rectified stereo pair.

    Parameters
    ----------
    width : int in [max(8, Wc + 2, Wh + 1, D), 4096]
    height : int in [2, 4096]
    census_window : odd int in [3, 11]
        Wc, the sparse census window.
    hamming_window : odd int in [1, 63]
        Wh, the SHD aggregation window.
    max_disparity : int in [1, 256]
        D, disparities 0 .. D-1.
    pixel_bits : int in [1, 16]
    no_match_cost : int in [0, Wc*Wc // 2] or None (= a third of the census bits)
    disparity_median : bool
        3x3 median of the checked map (the golden model's default).
    external_flush : bool
        False (default): a self-contained matcher that counts the pixels of a
        frame and inserts its own flush (ports below). True: a plain stage of
        the :mod:`hdl._util` convention for a larger pipeline whose frame source
        supplies the flush beats: ``i_stream`` always ready with ``first`` in
        the payload, ``o_stream`` one beat per input beat with ``first`` and
        ``real``, ``lag = flush`` raster positions, ``cycles`` clock cycles.

    Ports
    -----
    i_stream : payload ``{left, right}``, with ``ready`` (low during the flush);
        ``{first, left, right}``, always ready, with ``external_flush``
    o_stream : payload ``{disparity}`` (``{first, real, disparity}`` with
        ``external_flush``), no back-pressure (always ready)
    threshold : In, Th of eq. 21, sampled continuously (change it between frames)
    """

    def __init__(self, width: int, height: int, census_window: int = 7,
                 hamming_window: int = 29, max_disparity: int = 48, pixel_bits: int = 8,
                 no_match_cost: int | None = None, disparity_median: bool = True,
                 external_flush: bool = False):
        wc = check_odd_window("census_window", census_window, *CENSUS_WINDOW_RANGE)
        wh = check_odd_window("hamming_window", hamming_window, *HAMMING_WINDOW_RANGE)
        nd = check_int("max_disparity", max_disparity, *MAX_DISPARITY_RANGE)
        lo = max(WIDTH_RANGE[0], wc + 2, wh + 1, nd)
        self.width = check_int("width", width, lo, WIDTH_RANGE[1])
        self.height = check_int("height", height, *HEIGHT_RANGE)
        self.pixel_bits = check_int("pixel_bits", pixel_bits, *PIXEL_BITS_RANGE)
        self.census_bits = census_bits(wc)
        if no_match_cost is None:
            no_match_cost = self.census_bits // 3
        self.no_match_cost = check_int("no_match_cost", no_match_cost, 0, self.census_bits)
        self.census_window, self.hamming_window, self.max_disparity = wc, wh, nd
        self.disparity_median = bool(disparity_median)
        self.external_flush = bool(external_flush)
        w, h = self.width, self.height
        #: names of its stages (:meth:`stage`), in dataflow order
        self.stage_names = tuple(name for name in MATCHER_STAGES
                                 if name != "median" or self.disparity_median)
        timing = matcher_timing(w, wc, wh, nd, disparity_median=self.disparity_median)
        #: flush beats per frame: the total look-ahead of the windows
        self.flush = self.lag = timing.lag
        #: free-running pipeline depth in clock cycles
        self.cycles = timing.cycles
        #: clock cycles from a pixel in to its disparity out, input without gaps
        self.latency = self.flush + self.cycles
        #: clock cycles per frame, input without gaps (back-to-back frames)
        self.frame_cycles = w * h + self.flush
        self.disparity_bits = disparity_bits(nd)
        self.memory_bits = matcher_memory_bits(w, census_window=wc, hamming_window=wh,
                                               max_disparity=nd, pixel_bits=self.pixel_bits,
                                               disparity_median=self.disparity_median)
        marks_in = {"first": 1} if self.external_flush else {}
        marks_out = {"first": 1, "real": 1} if self.external_flush else {}
        super().__init__({
            "i_stream": In(stream.Signature(data.StructLayout(
                {**marks_in, "left": pixel_bits, "right": pixel_bits}),
                always_ready=self.external_flush)),
            "o_stream": Out(stream.Signature(data.StructLayout(
                {**marks_out, "disparity": self.disparity_bits}), always_ready=True)),
            "threshold": In(bits_for(nd)),
        })

    def elaborate(self, platform):
        m = Module()
        # the input register's beat, once per census: each copy steers the
        # beat-gated registers of one census (a single copy ran at 96.8 MHz
        # routed, its net spanning both censuses)
        beat_next = Signal()
        beats = replicate(m, beat_next, 2, "beat")
        first = Signal()
        left = Signal(self.pixel_bits)
        right = Signal(self.pixel_bits)
        if self.external_flush:
            m.d.comb += beat_next.eq(self.i_stream.valid)
            m.d.sync += [first.eq(self.i_stream.valid & self.i_stream.payload.first),
                         left.eq(self.i_stream.payload.left),
                         right.eq(self.i_stream.payload.right)]
        else:
            self._count_and_flush(m, beat_next, first, left, right)
        self._stages(m, beats, first, left, right)
        return m

    def stage(self, name: str):
        """The stage ``name`` (of :attr:`stage_names`, or ``shd.`` and a part of
        the SHD), freshly built with the parameters it has here, as
        :meth:`elaborate` builds its stages; only that stage is built."""
        return matcher_stage(name, self.width, self.height, census_window=self.census_window,
                             hamming_window=self.hamming_window,
                             max_disparity=self.max_disparity, pixel_bits=self.pixel_bits,
                             no_match_cost=self.no_match_cost,
                             disparity_median=self.disparity_median)

    def _count_and_flush(self, m, beat_next, first, left, right):
        """Self-contained mode: count the frame's pixels, then run ``flush`` beats."""
        w, h = self.width, self.height
        # Input side: pixel counter, flush counter; the flags the handshake needs are
        # registers (no counter comparison between them and the beat).
        count = Signal(range(w * h + 1))
        at_start = Signal(init=1)            # count == 0
        at_last = Signal(init=int(w * h == 1))  # count == w * h - 1
        flush_left = Signal(range(self.flush + 1))
        flushing = Signal()                  # flush_left != 0
        m.d.comb += self.i_stream.ready.eq(~flushing)
        take = self.i_stream.valid & ~flushing
        with m.If(take):
            with m.If(at_last):
                m.d.sync += [count.eq(0), at_start.eq(1), at_last.eq(int(w * h == 1)),
                             flush_left.eq(self.flush), flushing.eq(self.flush != 0)]
            with m.Else():
                m.d.sync += [count.eq(count + 1), at_start.eq(0),
                             at_last.eq(count == w * h - 2)]
        with m.If(flushing):
            m.d.sync += [flush_left.eq(flush_left - 1), flushing.eq(flush_left != 1)]
        # One register stage in front of the census windows.
        m.d.comb += beat_next.eq(take | flushing)
        m.d.sync += [first.eq(take & at_start),
                     left.eq(Mux(take, self.i_stream.payload.left, 0)),
                     right.eq(Mux(take, self.i_stream.payload.right, 0))]

    def _stages(self, m, beats, first, left, right):

        cl, cr = self.stage("census_left"), self.stage("census_right")
        m.submodules.census_left = cl
        m.submodules.census_right = cr
        for c, px, beat in ((cl, left, beats[0]), (cr, right, beats[1])):
            m.d.comb += [c.i_stream.valid.eq(beat), c.i_stream.payload.first.eq(first),
                         c.i_stream.payload.pixel.eq(px)]
        m.submodules.shd = shd = self.stage("shd")
        connect_remapped(m, cl.o_stream, shd.i_stream,
                         left=cl.o_stream.payload.code, right=cr.o_stream.payload.code,
                         left2=cl.o_stream.payload.code2, right2=cr.o_stream.payload.code2)
        m.submodules.select = sel = self.stage("select")
        connect_remapped(m, shd.o_stream, sel.i_stream)
        m.submodules.check = chk = self.stage("check")
        m.d.comb += chk.threshold.eq(self.threshold)
        connect_remapped(m, sel.o_stream, chk.i_stream)
        last, value = chk.o_stream, chk.o_stream.payload.disparity
        if self.disparity_median:
            m.submodules.median = med = self.stage("median")
            connect_remapped(m, chk.o_stream, med.i_stream, pixel=chk.o_stream.payload.disparity)
            last, value = med.o_stream, med.o_stream.payload.pixel
        # An output register: the stage behind (segmentation) sits far from the
        # matcher's last stage on the die (routed: 10 ns of wire on that path).
        if self.external_flush:
            m.d.sync += [
                self.o_stream.valid.eq(last.valid),
                self.o_stream.payload.first.eq(last.payload.first),
                self.o_stream.payload.real.eq(last.payload.real),
                self.o_stream.payload.disparity.eq(value),
            ]
        else:
            m.d.sync += [
                self.o_stream.valid.eq(last.valid & last.payload.real),
                self.o_stream.payload.disparity.eq(value),
            ]
