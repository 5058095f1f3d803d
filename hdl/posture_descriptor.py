"""The hand's shape descriptor, one pass over the posture mask (thesis §10.1,
future work: "the configuration of the hand"), bit for bit
:func:`sim.model.posture.posture_registers` about
:func:`sim.model.posture.next_reference` of the previous two frames.

While the mask streams past, one pixel per clock:

* the moments (area, sums of x, y, x*x, y*y, x*y) and the bounding box;
* per row, the runs that start in it; at the row's end its count goes to the
  band the row lies in (sum, rows, largest);
* per pixel, its ring and sector about the reference's anchor; one counter per
  (ring, sector).

No multiplier sits on the pixel path: the squares and the products by the
sector tangents change by a step per pixel along a row and per row down the
frame, so each is an accumulator loaded at the row's or frame's start (routed,
a DSP block's way in and out cost more than a cycle). The constants they start
from (the anchor's squares and products) come from shift-and-add products
computed once per frame, while the record goes out.

After the frame's last pixel the record leaves as ``POSTURE_WORD_COUNT`` words
on ``o_stream``, one per clock; the polar counters leave as a shift chain,
which zeroes them for the next frame. Then the next frame's reference is
loaded: this frame's own (centroid column, top, width) moved on by its change
since the previous frame's own, so that a moving hand is described about
where it is rather than where it was.
"""
from __future__ import annotations

from amaranth.hdl import Cat, Const, Module, Mux, Signal, signed
from amaranth.lib import data, stream, wiring
from amaranth.lib.wiring import In, Out

from soc.hps_interface import POSTURE_WORD_COUNT, POSTURE_WORDS, posture_word_offsets
from sim.model.posture import (BAND_SPAN, BANDS, RING_EDGES_16THS, RINGS, SECTORS, TAN_Q,
                               TANGENTS)

from sim.model.centroid import TRACK_GATE_RANGE

from ._util import bits_for, check_geometry, check_int, replicate, times_constant
from .divider import UnsignedDivider, divider_cycles
from .raster_position import RasterPosition
from .streams import pixel_signature

__all__ = ["PostureDescriptor", "posture_cycles_after_frame", "WORD_BITS"]

#: Bits of one record word.
WORD_BITS = 32
#: Pixel pipeline: input register, steps, sums, comparisons, one-hot, increments.
PIXEL_STAGES = 7
#: Counters per copy of the shift enable (a copy steers 8 x 19 flip-flops).
SHIFT_GROUP = 8


def posture_cycles_after_frame() -> int:
    """Clock cycles from the beat of a frame's last pixel to the cycle after
    the record's last word: the pixel pipeline, one to start, the words, one
    to load the next reference. The next frame's first beat may come then."""
    return PIXEL_STAGES + 1 + POSTURE_WORD_COUNT + 1


class PostureDescriptor(wiring.Component):
    """One posture record per frame of the posture mask.

    Parameters
    ----------
    width : int in [8, 4096]
    height : int in [2, 4096]
    gate : int in [0, 4095]
        Half-size of the window about the previous centroid (``i_gate``) the
        mask counts in (:func:`sim.model.centroid.counted_pixels`); 0: the
        whole frame.

    Ports
    -----
    i_stream : payload ``{first, real, pixel: 1}`` (always ready)
        The posture mask as a window stage emits it (non-real beats ignored,
        idle cycles anywhere). A frame's first beat must come at least
        ``cycles_after_frame`` clock cycles after the previous frame's last one
        (the record is then out and the reference loaded).
    o_stream : payload ``{index: 8, word: 32}`` (always ready)
        The frame's record, :data:`soc.hps_interface.POSTURE_WORDS` in order
        (``index`` 0 .. ``POSTURE_WORD_COUNT - 1``), on consecutive cycles, the
        first ``PIXEL_STAGES + 3`` cycles after the beat of the frame's last
        pixel: :func:`sim.model.posture.posture_words` of the frame about the
        reference predicted from the previous two frames (none after reset).
    i_gate : payload ``{x, y, hand}`` (always ready; only with ``gate``)
        The centroid the window is about: a beat between two frames' pixels
        (the pipeline's centroid, while the frame's last pixels are still in
        its opening) sets the next frame's window, two cycles later.

    Attributes
    ----------
    cycles_after_frame : int
        :func:`posture_cycles_after_frame`.
    count_bits : int
        Width of the area and of every polar and band counter.
    """

    def __init__(self, width: int, height: int, *, gate: int = 0):
        self.width, self.height = check_geometry(width, height)
        self.gate = check_int("gate", gate, *TRACK_GATE_RANGE)
        self.cycles_after_frame = posture_cycles_after_frame()
        self.count_bits = bits_for(self.width * self.height)
        # the reference is loaded after the divider and the products: the
        # record must outlast them (it does for every legal geometry)
        self.x_bits = bits_for(self.width - 1)
        self.y_bits = bits_for(self.height - 1)
        self.sum_x_bits = bits_for(self.width * self.height * (self.width - 1))
        assert divider_cycles(self.sum_x_bits) + 2 + 2 * 14 < POSTURE_WORD_COUNT
        members = {
            "i_stream": In(pixel_signature(1, real=True)),
            "o_stream": Out(stream.Signature(data.StructLayout(
                {"index": bits_for(POSTURE_WORD_COUNT - 1), "word": WORD_BITS}),
                always_ready=True)),
        }
        if self.gate:
            members["i_gate"] = In(stream.Signature(data.StructLayout(
                {"x": self.x_bits, "y": self.y_bits, "hand": 1}), always_ready=True))
        super().__init__(members)

    # ---- helpers --------------------------------------------------------------

    def _gate_bounds(self, m):
        """The window's bounds (x_lo, x_hi, y_lo, y_hi): the square of half-size
        ``gate`` about the last centroid on ``i_gate``, clipped to the frame;
        the whole frame after reset or a centroid without hand. The new bounds
        are registered first, then loaded (as :class:`hdl.centroid.Centroid`'s gate)."""
        r, g = self.gate, self.i_gate
        bounds = [Signal(self.x_bits, name="gate_x_lo"),
                  Signal(self.x_bits, name="gate_x_hi", init=self.width - 1),
                  Signal(self.y_bits, name="gate_y_lo"),
                  Signal(self.y_bits, name="gate_y_hi", init=self.height - 1)]
        load = Signal(name="gate_load")
        m.d.sync += load.eq(g.valid)
        following = []
        for axis, c, top, bits in (("x", g.payload.x, self.width - 1, self.x_bits),
                                   ("y", g.payload.y, self.height - 1, self.y_bits)):
            lo, hi = (Signal(bits, name=f"gate_next_{axis}_{end}") for end in ("lo", "hi"))
            m.d.sync += [lo.eq(Mux(g.payload.hand & (c > r), c - r, 0)),
                         hi.eq(Mux(~g.payload.hand | (c + r >= top), top, c + r))]
            following += [lo, hi]
        with m.If(load):
            m.d.sync += [b.eq(f) for b, f in zip(bounds, following)]
        return bounds

    @staticmethod
    def _serial_product(m, start, a, b, bits, name):
        """``a * b`` by shift and add, one bit of ``b`` per cycle: loaded on
        ``start``, held from ``len(b)`` cycles after it."""
        b_bits = len(b)
        multiplicand = Signal(bits, name=f"{name}_a")
        multiplier = Signal(b_bits, name=f"{name}_b")
        product = Signal(bits, name=f"{name}_p")
        with m.If(start):
            m.d.sync += [multiplicand.eq(a), multiplier.eq(b), product.eq(0)]
        with m.Else():
            m.d.sync += [
                product.eq(product + Mux(multiplier[0], multiplicand, 0)),
                multiplicand.eq(multiplicand << 1),
                multiplier.eq(multiplier >> 1),
            ]
        return product

    def elaborate(self, platform):
        m = Module()
        w, h = self.width, self.height
        cb = self.count_bits
        p = self.i_stream.payload
        beat = self.i_stream.valid & p.real
        pos = RasterPosition(w, h, 0, "pix").attach(m, beat, p.first)
        x0, y0 = pos.x[:self.x_bits], pos.y[:self.y_bits]

        # ---- the reference in use (loaded between frames) ------------------------
        anchor_max = (h - 1) + w // 2
        a_bits = bits_for(anchor_max)
        w_bits = bits_for(w)
        tangents = TANGENTS
        ref = {
            "x": Signal(self.x_bits, name="ref_x"),
            "top": Signal(self.y_bits, name="ref_top"),
            "width": Signal(w_bits, name="ref_width"),
            "anchor": Signal(a_bits, name="ref_anchor"),
            "have": Signal(name="ref_have"),
            "x_sq": Signal(bits_for((w - 1) ** 2), name="ref_x_sq"),
            "anchor_sq": Signal(bits_for(anchor_max ** 2), name="ref_anchor_sq"),
            "x_tan": [Signal(bits_for((w - 1) * t), name=f"ref_x_tan{j}")
                      for j, t in enumerate(tangents)],
            "anchor_tan": [Signal(bits_for(anchor_max * t), name=f"ref_anchor_tan{j}")
                           for j, t in enumerate(tangents)],
            # 16 r^2 >= edge * W^2, and band edges 16 up >= 3 W k (k = 1 .. BANDS)
            "ring_edges": [Signal(bits_for(e * w * w), name=f"ref_ring_edge{k}")
                           for k, e in enumerate(RING_EDGES_16THS)],
            "band_edges": [Signal(bits_for(BAND_SPAN[0] * w * k), name=f"ref_band_edge{k}")
                           for k in range(1, BANDS + 1)],
        }

        # ---- s1: the beat's position and offsets ----------------------------------
        dx_shape = signed(max(self.x_bits, a_bits) + 2)
        v1, pix1, first1, rowstart1, row_end1, last1 = (
            Signal(name=n) for n in ("v1", "pix1", "first1", "rowstart1", "row_end1", "last1"))
        x1 = Signal(self.x_bits, name="x1")
        y1 = Signal(self.y_bits, name="y1")
        dx1 = Signal(dx_shape, name="dx1")
        dyu1 = Signal(dx_shape, name="dyu1")
        oddx1 = Signal(signed(dx_shape.width + 2), name="oddx1")      # 2 dx - 1
        oddy1 = Signal(signed(dx_shape.width + 2), name="oddy1")      # 2 dyu + 1
        right1 = Signal(name="right1")                                 # x > ref x
        in_gate1 = Signal(name="in_gate1")
        if self.gate:
            lo_x, hi_x, lo_y, hi_y = self._gate_bounds(m)
            m.d.sync += in_gate1.eq((x0 >= lo_x) & (x0 <= hi_x) & (y0 >= lo_y) & (y0 <= hi_y))
        else:
            m.d.comb += in_gate1.eq(1)
        m.d.sync += [
            v1.eq(beat), pix1.eq(p.pixel), first1.eq(p.first), rowstart1.eq(x0 == 0),
            row_end1.eq(x0 == w - 1), last1.eq((x0 == w - 1) & (y0 == h - 1)),
            x1.eq(x0), y1.eq(y0),
            dx1.eq(x0 - ref["x"]), dyu1.eq(ref["anchor"] - y0),
            oddx1.eq((x0 << 1) - (ref["x"] << 1) - 1),
            oddy1.eq((ref["anchor"] << 1) + 1 - (y0 << 1)),
            right1.eq(x0 > ref["x"]),
        ]

        # ---- s2: squares and tangent products by steps; row runs -----------------
        r_max = (w - 1) ** 2 + anchor_max ** 2
        dx_sq = Signal(bits_for((w - 1) ** 2), name="dx_sq2")
        dy_sq = Signal(bits_for(max((h - 1) ** 2, anchor_max ** 2)), name="dy_sq2")
        ax = [Signal(len(s), name=f"dx_tan{j}_2") for j, s in enumerate(ref["x_tan"])]
        by = [Signal(bits_for(max(anchor_max, h - 1) * t), name=f"dy_tan{j}_2")
              for j, t in enumerate(tangents)]
        xx = Signal(bits_for((w - 1) ** 2), name="xx2")
        yy = Signal(bits_for((h - 1) ** 2), name="yy2")
        xy = Signal(bits_for((w - 1) * (h - 1)), name="xy2")
        counted1 = pix1 & in_gate1
        start2 = Signal(name="start2")                                 # a run starts here
        rowstart2 = Signal(name="rowstart2")
        prev = Signal(name="prev_pixel")
        with m.If(v1):
            m.d.sync += prev.eq(counted1)
        m.d.sync += [start2.eq(counted1 & (rowstart1 | ~prev)), rowstart2.eq(rowstart1)]
        with m.If(v1):
            m.d.sync += [
                dx_sq.eq(Mux(rowstart1, ref["x_sq"], dx_sq + oddx1)),
                xx.eq(Mux(rowstart1, 0, xx + (x1 << 1) - 1)),
                xy.eq(Mux(rowstart1, 0, xy + y1)),
            ]
            m.d.sync += [a.eq(Mux(rowstart1, r, a + Mux(right1, t, -t)))
                         for a, r, t in zip(ax, ref["x_tan"], tangents)]
            with m.If(first1):
                m.d.sync += [dy_sq.eq(ref["anchor_sq"]), yy.eq(0)]
                m.d.sync += [b.eq(r) for b, r in zip(by, ref["anchor_tan"])]
            with m.Elif(rowstart1):
                m.d.sync += [dy_sq.eq(dy_sq - oddy1), yy.eq(yy + (y1 << 1) - 1)]
                m.d.sync += [b.eq(b + Mux(dyu1 < 0, t, -t)) for b, t in zip(by, tangents)]
        v2, pix2, first2, row_end2, last2, origin2 = (
            Signal(name=n) for n in ("v2", "pix2", "first2", "row_end2", "last2", "origin2"))
        x2 = Signal(self.x_bits, name="x2")
        y2 = Signal(self.y_bits, name="y2")
        abs_dx = Signal(dx_shape.width, name="abs_dx2")
        abs_dy = Signal(dx_shape.width, name="abs_dy2")
        swapped = Signal(name="swapped2")     # quadrants 1, 3: u = |dyu|, v = |dx|
        quadrant = Signal(2, name="quadrant2")
        above = Signal(name="above2")         # the row lies at or above the anchor
        band_ge = Signal(BANDS, name="band_ge2")
        q = [(dx1 > 0) & (dyu1 >= 0), (dx1 <= 0) & (dyu1 > 0), (dx1 < 0) & (dyu1 <= 0)]
        m.d.sync += [
            v2.eq(v1), pix2.eq(counted1), first2.eq(first1), row_end2.eq(row_end1),
            last2.eq(last1), x2.eq(x1), y2.eq(y1),
            origin2.eq((dx1 == 0) & (dyu1 == 0)),
            abs_dx.eq(Mux(dx1 < 0, -dx1, dx1)), abs_dy.eq(Mux(dyu1 < 0, -dyu1, dyu1)),
            quadrant.eq(Mux(q[0], 0, Mux(q[1], 1, Mux(q[2], 2, 3)))),
            swapped.eq(~q[0] & (q[1] | ~q[2])),
            above.eq(dyu1 >= 0),
            band_ge.eq(Cat(*[(dyu1 << 4) >= e for e in ref["band_edges"]])),
        ]

        # ---- s3: radius, major and minor; moments; the row's band --------------
        r2 = Signal(bits_for(r_max), name="r_sq3")
        major_tan = [Signal(max(len(a), len(b)), name=f"major_tan{j}_3")
                     for j, (a, b) in enumerate(zip(ax, by))]
        minor = Signal(dx_shape.width, name="minor3")
        low = Signal(name="low3")
        v3, pix3, last3, origin3 = (Signal(name=n) for n in ("v3", "pix3", "last3", "origin3"))
        quadrant3 = Signal(2, name="quadrant3")
        dx_major = abs_dx >= abs_dy
        m.d.sync += [
            r2.eq(dx_sq + dy_sq),
            minor.eq(Mux(dx_major, abs_dy, abs_dx)),
            low.eq(Mux(swapped, abs_dx < abs_dy, abs_dy < abs_dx)),
            v3.eq(v2), pix3.eq(pix2 & ref["have"]), last3.eq(last2), origin3.eq(origin2),
            quadrant3.eq(quadrant),
        ]
        m.d.sync += [mt.eq(Mux(dx_major, a, b)) for mt, a, b in zip(major_tan, ax, by)]

        moments = {name: Signal(bits, name=name) for name, bits in (
            ("area", cb), ("sum_x", self.sum_x_bits),
            ("sum_y", bits_for(w * h * (h - 1))), ("sum_xx", bits_for(w * h * (w - 1) ** 2)),
            ("sum_yy", bits_for(w * h * (h - 1) ** 2)),
            ("sum_xy", bits_for(w * h * (w - 1) * (h - 1))))}
        box = {name: Signal(bits, name=name) for name, bits in (
            ("x_min", self.x_bits), ("x_max", self.x_bits),
            ("y_min", self.y_bits), ("y_max", self.y_bits))}
        seen = Signal(name="seen")
        with m.If(v2):
            for name, term in (("area", 1), ("sum_x", x2), ("sum_y", y2), ("sum_xx", xx),
                               ("sum_yy", yy), ("sum_xy", xy)):
                acc = moments[name]
                m.d.sync += acc.eq(Mux(first2, 0, acc) + Mux(pix2, term, 0))
            with m.If(pix2 & (first2 | ~seen)):
                m.d.sync += [seen.eq(1), box["x_min"].eq(x2), box["x_max"].eq(x2),
                             box["y_min"].eq(y2), box["y_max"].eq(y2)]
            with m.Elif(pix2):
                m.d.sync += box["y_max"].eq(y2)
                with m.If(x2 < box["x_min"]):
                    m.d.sync += box["x_min"].eq(x2)
                with m.If(x2 > box["x_max"]):
                    m.d.sync += box["x_max"].eq(x2)
            with m.Elif(first2):
                m.d.sync += seen.eq(0)

        # the row's runs (s3), then its band (s4): b with 3 W b <= 16 up < 3 W (b + 1)
        row_runs = Signal(bits_for(w), name="row_runs3")
        with m.If(v2):
            m.d.sync += row_runs.eq(Mux(rowstart2, 0, row_runs) + start2)
        above3 = Signal(name="above3")
        band_ge3 = Signal(BANDS, name="band_ge3")
        row_end3, first3 = Signal(name="row_end3"), Signal(name="first3")
        m.d.sync += [above3.eq(above), band_ge3.eq(band_ge), row_end3.eq(row_end2),
                     first3.eq(first2)]
        row_done = Signal(name="row_done4")
        row_total = Signal(bits_for(w), name="row_total4")
        band_hot = Signal(BANDS, name="band_hot4")
        first4 = Signal(name="first4")
        ge = [Const(1)] + [band_ge3[k] for k in range(BANDS)]
        m.d.sync += [
            row_done.eq(v3 & row_end3 & ref["have"]), row_total.eq(row_runs),
            band_hot.eq(Cat(*[above3 & ge[b] & ~ge[b + 1] for b in range(BANDS)])),
            first4.eq(v3 & first3),
        ]
        band_sum = [Signal(cb, name=f"band_sum{b}") for b in range(BANDS)]
        band_rows = [Signal(self.y_bits + 1, name=f"band_rows{b}") for b in range(BANDS)]
        band_max = [Signal(bits_for(w), name=f"band_max{b}") for b in range(BANDS)]
        with m.If(first4):
            m.d.sync += [s.eq(0) for s in band_sum + band_rows + band_max]
        with m.Elif(row_done):
            for b in range(BANDS):
                with m.If(band_hot[b]):
                    m.d.sync += [band_sum[b].eq(band_sum[b] + row_total),
                                 band_rows[b].eq(band_rows[b] + 1)]
                    with m.If(row_total > band_max[b]):
                        m.d.sync += band_max[b].eq(row_total)

        # ---- s4: comparisons ---------------------------------------------------
        ring_ge = Signal(len(RING_EDGES_16THS), name="ring_ge4")
        sector_ge = Signal(len(tangents), name="sector_ge4")
        v4, pix4, last4, origin4, low4 = (
            Signal(name=n) for n in ("v4", "pix4", "last4", "origin4", "low4"))
        quadrant4 = Signal(2, name="quadrant4")
        m.d.sync += [
            ring_ge.eq(Cat(*[(r2 << 4) >= e for e in ref["ring_edges"]])),
            sector_ge.eq(Cat(*[(minor << TAN_Q) >= mt for mt in major_tan])),
            v4.eq(v3), pix4.eq(pix3), last4.eq(last3), origin4.eq(origin3), low4.eq(low),
            quadrant4.eq(quadrant3),
        ]

        # ---- s5: ring and sector, one-hot --------------------------------------
        # count = boundaries below the angle (a thermometer: the tangents rise)
        ring_hot = Signal(RINGS, name="ring_hot5")
        sector_hot = Signal(SECTORS, name="sector_hot5")
        v5, pix5, last5 = (Signal(name=n) for n in ("v5", "pix5", "last5"))
        rg = [Const(1)] + [ring_ge[k] for k in range(RINGS - 1)] + [Const(0)]
        sg = [Const(1)] + [sector_ge[k] for k in range(len(tangents))] + [Const(0)]
        count_hot = [sg[c] & ~sg[c + 1] for c in range(len(tangents) + 1)]
        quarter = SECTORS // 4
        octant_hot = [0] * quarter
        for c, hot in enumerate(count_hot):
            octant_hot[c] = low4 & hot
            octant_hot[quarter - 1 - c] = ~low4 & hot
        sectors = []
        for s in range(SECTORS):
            in_quadrant = (quadrant4 == s // quarter) & octant_hot[s % quarter]
            sectors.append(Mux(origin4, int(s == 0), in_quadrant))
        m.d.sync += [
            ring_hot.eq(Cat(*[rg[r] & ~rg[r + 1] for r in range(RINGS)])),
            sector_hot.eq(Cat(*sectors)),
            v5.eq(v4), pix5.eq(pix4), last5.eq(last4),
        ]

        # ---- s6: the counters' increments; s7: the counters -------------------
        increments = Signal(RINGS * SECTORS, name="increments6")
        last6 = Signal(name="last6")
        m.d.sync += [
            increments.eq(Cat(*[v5 & pix5 & ring_hot[r] & sector_hot[s]
                                for r in range(RINGS) for s in range(SECTORS)])),
            last6.eq(v5 & last5),
        ]
        counters = [Signal(cb, name=f"polar{k}") for k in range(RINGS * SECTORS)]
        done = Signal(name="frame_done")       # the counters hold the frame
        m.d.sync += done.eq(last6)

        # ---- the record: a word per cycle ---------------------------------------
        n_words = POSTURE_WORD_COUNT
        at = posture_word_offsets()
        polar_at = at["polar"]
        index = Signal(range(n_words + 1), name="word_index")
        sending = Signal(name="sending")
        shift_next = Signal(name="shift_next")
        m.d.comb += shift_next.eq(Mux(done, polar_at == 0,
                                      sending & (index + 1 >= polar_at) & (index + 1 < n_words)))
        groups = -(-len(counters) // SHIFT_GROUP)
        shifts = replicate(m, shift_next, groups, "polar_shift")
        for k, counter in enumerate(counters):
            nxt = counters[k + 1] if k + 1 < len(counters) else 0
            with m.If(shifts[k // SHIFT_GROUP]):
                m.d.sync += counter.eq(nxt)
            with m.Elif(increments[k]):
                m.d.sync += counter.eq(counter + 1)

        scalar = {}
        scalar[at["reference"]] = Cat(ref["x"], Const(0, 16 - self.x_bits), ref["top"])
        scalar[at["reference_width"]] = ref["width"]
        scalar[at["area"]] = moments["area"]
        for name in ("sum_x", "sum_y", "sum_xx", "sum_yy", "sum_xy"):
            value = moments[name]
            scalar[at[name]] = value[:WORD_BITS]
            scalar[at[name] + 1] = value[WORD_BITS:] if len(value) > WORD_BITS else Const(0, 1)
        scalar[at["box_x"]] = Cat(Mux(seen, box["x_min"], 0), Const(0, 16 - self.x_bits),
                                  Mux(seen, box["x_max"], 0))
        scalar[at["box_y"]] = Cat(Mux(seen, box["y_min"], 0), Const(0, 16 - self.y_bits),
                                  Mux(seen, box["y_max"], 0))
        for b in range(BANDS):
            scalar[at["band_sum"] + b] = band_sum[b]
            scalar[at["band_rows_max"] + b] = Cat(band_rows[b],
                                                  Const(0, 16 - len(band_rows[b])), band_max[b])
        assert sorted(scalar) == list(range(polar_at))
        # two cycles: a word of each group of 8 scalars, then the group (routed,
        # one multiplexer of all the scalars was 10 logic levels)
        groups_of = [sorted(i for i in scalar if i // 8 == g) for g in range(-(-polar_at // 8))]
        picked = [Signal(WORD_BITS, name=f"scalar_group{g}") for g in range(len(groups_of))]
        for g, members in enumerate(groups_of):
            with m.Switch(index[:3]):
                for i in members:
                    with m.Case(i % 8):
                        m.d.sync += picked[g].eq(scalar[i])
        polar_word = Signal(cb, name="polar_word")
        picked_index = Signal.like(index, name="picked_index")
        picked_valid = Signal(name="picked_valid")
        m.d.sync += [polar_word.eq(counters[0]), picked_index.eq(index),
                     picked_valid.eq(sending)]
        group_word = Signal(WORD_BITS, name="group_word")
        with m.Switch(picked_index[3:]):
            for g in range(len(picked)):
                with m.Case(g):
                    m.d.comb += group_word.eq(picked[g])
        out = self.o_stream
        m.d.sync += [out.valid.eq(picked_valid), out.payload.index.eq(picked_index),
                     out.payload.word.eq(Mux(picked_index < polar_at, group_word, polar_word))]
        finished = Signal(name="record_finished")
        m.d.sync += finished.eq(0)
        with m.If(done):
            m.d.sync += [sending.eq(1), index.eq(0)]
        with m.Elif(sending):
            m.d.sync += index.eq(index + 1)
            with m.If(index == n_words - 1):
                m.d.sync += [sending.eq(0), finished.eq(1)]

        # ---- the next reference: division, products, then loaded ---------------
        div = UnsignedDivider(dividend_bits=self.sum_x_bits, divisor_bits=cb)
        m.submodules.div_x = div
        have_next = Signal(name="next_have")
        top_next = Signal(self.y_bits, name="next_top")
        width_next = Signal(w_bits, name="next_width")
        m.d.comb += [div.start.eq(done), div.dividend.eq(moments["sum_x"]),
                     div.divisor.eq(moments["area"])]
        with m.If(done):
            m.d.sync += [have_next.eq(seen), top_next.eq(Mux(seen, box["y_min"], 0)),
                         width_next.eq(Mux(seen, box["x_max"] - box["x_min"] + 1, 0))]
        # this frame's own reference, and the last frame's: the next one is
        # predicted from both (sim.model.posture.next_reference), one step a cycle
        x_own = Signal(self.x_bits, name="own_x")
        last = {"x": Signal(self.x_bits, name="last_x"), "top": Signal(self.y_bits, name="last_top"),
                "have": Signal(name="last_have")}
        predict = Signal(name="predict")
        top_moved = Signal(signed(self.y_bits + 2), name="top_moved")
        top_pred = Signal(self.y_bits, name="pred_top")
        x_moved = Signal(signed(self.x_bits + 2), name="x_moved")
        x_next = Signal(self.x_bits, name="next_x")
        anchor_next = Signal(a_bits, name="next_anchor")
        moved1, moved2, products_start = (Signal(name=n) for n in (
            "reference_moved1", "reference_moved2", "products_start"))
        m.d.sync += [moved1.eq(div.done), moved2.eq(moved1), products_start.eq(moved2)]
        with m.If(div.done):
            m.d.sync += [x_own.eq(Mux(have_next, div.quotient, 0)),
                         predict.eq(have_next & last["have"]),
                         top_moved.eq((top_next << 1) - last["top"])]
        with m.If(moved1):
            m.d.sync += [
                x_moved.eq((x_own << 1) - last["x"]),
                top_pred.eq(Mux(~predict, top_next,
                                Mux(top_moved < 0, 0,
                                    Mux(top_moved > h - 1, h - 1, top_moved[:self.y_bits])))),
            ]
        with m.If(moved2):
            m.d.sync += [
                x_next.eq(Mux(~predict, x_own,
                              Mux(x_moved < 0, 0,
                                  Mux(x_moved > w - 1, w - 1, x_moved[:self.x_bits])))),
                anchor_next.eq(top_pred + (width_next >> 1)),
            ]
        coord_bits = max(self.x_bits, a_bits, w_bits)
        products = {
            "x_sq": (x_next, x_next), "anchor_sq": (anchor_next, anchor_next),
            "width_sq": (width_next, width_next),
        }
        for j, t in enumerate(tangents):
            products[f"x_tan{j}"] = (x_next, Const(t, bits_for(t)))
            products[f"anchor_tan{j}"] = (anchor_next, Const(t, bits_for(t)))
        made = {name: self._serial_product(m, products_start, a, b, 2 * coord_bits + 12,
                                           f"mul_{name}")
                for name, (a, b) in products.items()}
        w_sq = made["width_sq"]
        with m.If(finished):
            m.d.sync += [
                last["x"].eq(x_own), last["top"].eq(top_next), last["have"].eq(have_next),
                ref["x"].eq(x_next), ref["top"].eq(top_pred), ref["width"].eq(width_next),
                ref["anchor"].eq(anchor_next), ref["have"].eq(have_next),
                ref["x_sq"].eq(made["x_sq"]), ref["anchor_sq"].eq(made["anchor_sq"]),
            ]
            m.d.sync += [r.eq(made[f"x_tan{j}"]) for j, r in enumerate(ref["x_tan"])]
            m.d.sync += [r.eq(made[f"anchor_tan{j}"]) for j, r in enumerate(ref["anchor_tan"])]
            m.d.sync += [r.eq(times_constant(w_sq, e))
                         for r, e in zip(ref["ring_edges"], RING_EDGES_16THS)]
            m.d.sync += [r.eq(times_constant(width_next, BAND_SPAN[0] * k))
                         for k, r in enumerate(ref["band_edges"], start=1)]
        return m
