# amaranth: UnusedElaboratable=no
"""The whole FPGA side of the recogniser (thesis chapters 5-7): two camera byte
streams in, one (x, y, gesture flag) record per frame out, bit for bit the golden
model :func:`sim.model.pipeline.process_frame` / :func:`~sim.model.pipeline.track`.

Stages, in dataflow order (each a component of :mod:`hdl`)::

    cam_left / cam_right domains (camera PCLK)
        CameraCapture        x2   §5.2   VSYNC/HREF, Y/C byte pairs
    sync domain (pipeline clock)
        StereoSynchronizer        §5.3   AsyncFIFOs, frame pairing, flush beats
        YCbCr422To444        x2   §5.4   Y, Cb, Cr per pixel
        Rectifier            x2   §10.1  optional: Y, Cb, Cr left, Y right
        Median3x3            x2   §6.1   Y of each camera
        StereoMatcher             §6.2   census, SHD, L2R/R2L, LRCC, disparity median
        HandSegmentation          §6.3   skin (left Cb/Cr, delayed) AND disparity band
        Opening                   §6.4   erosion then dilation, W x W element
        Centroid                  §7.1   moments and dividers, once per frame
        MovingAverage             §7.2   N frames, 10.8 fixed point
        GestureSpotting           §7.3   K frames, Tm pixels, hold

The synchroniser delivers every frame as exactly ``width * height`` pixel beats
followed by ``flush`` beats, the sum of the look-ahead (``lag``) of the window
stages behind it, so every stage is a plain stream stage of the
:mod:`hdl._util` convention and the last pixel of a frame reaches the centroid
before the next frame starts. The camera's vertical blanking must therefore
last at least ``flush`` pipeline clock cycles (or the synchroniser's FIFOs hold
what arrives meanwhile).

A frame the synchroniser has to abort (cut short, HREF glitch, VSYNC in a line,
camera restart) ends early, without flush: the next frame's ``first`` restarts
every stage's raster position, so the aborted frame never reaches the
centroid's last pixel and produces no record. The moving average and the
spotting see the clip without that frame (as if the camera had dropped it).
"""
from __future__ import annotations

from typing import NamedTuple

from amaranth.hdl import Cat, ClockDomain, DomainRenamer, Module, Mux, Signal
from amaranth.lib import data, stream, wiring
from amaranth.lib.wiring import In, Out

from sim.model.morphology import resolve_element
from sim.model.pipeline import VIDEO_STAGES, PipelineParams, check_rectification
from sim.model.rectify import StereoRectification

from ._util import bits_for
from .camera_capture import CameraCapture
from .centroid import Centroid, centroid_cycles_after_frame
from .gesture_spotting import GestureSpotting
from .median3x3 import Median3x3, median_timing
from .moving_average import MovingAverage
from .opening import Opening, opening_timing
from .raster_position import OVERRUN_ROWS
from .rectify import Rectifier, rectify_timing
from .segmentation import HandSegmentation
from .stage import PixelStage, StageTiming
from .stereo_matcher import StereoMatcher, matcher_timing
from .stereo_sync import StereoSynchronizer
from .streams import connect_remapped, pixel_signature
from .ycbcr422 import YCbCr422To444

__all__ = ["GesturePipeline", "VIDEO_STAGES", "record_layout", "PipelineTop", "pipeline_timing",
           "PipelineTiming"]



def record_layout(width: int, height: int, frac_bits: int) -> data.StructLayout:
    """Per-frame output record: smoothed position (``frac_bits`` fixed point),
    gesture flag, raw centroid and area."""
    coord = bits_for(max(width, height) - 1)
    return data.StructLayout({
        "x": coord + frac_bits, "y": coord + frac_bits, "flag": 1,
        "centroid_x": coord, "centroid_y": coord, "area": bits_for(width * height),
    })


class PipelineTiming(NamedTuple):
    """The pipeline's timing figures (:func:`pipeline_timing`)."""
    #: flush beats per frame: the look-ahead of every window stage
    flush: int
    #: clock cycles from a pixel beat to its opened-mask beat (free-running part)
    pixel_cycles: int
    #: clock cycles per frame, cameras never starving the pipeline
    frame_cycles: int
    #: clock cycles from a frame's last pixel leaving the synchroniser to its record
    record_cycles: int


def pipeline_timing(width: int, height: int, params: PipelineParams = PipelineParams(),
                    rectification: StereoRectification | None = None) -> PipelineTiming:
    """The timing of :class:`GesturePipeline` from its parameters alone (nothing
    is built): each stage's ``*_timing`` function, the one its component uses.

    Raises ``ValueError`` as :meth:`PipelineParams.validate` does, or when the
    windows look further ahead than the position counters run past a frame.
    """
    params.validate(width, height)
    check_rectification(rectification, width, height)
    p = params
    element = resolve_element(p.opening_shape, p.opening_size)
    rectify = [] if rectification is None else [rectify_timing(width,
                                                               *rectification.max_shift)]
    pixel = [StageTiming(YCbCr422To444.lag, YCbCr422To444.cycles), *rectify,
             median_timing(width),
             matcher_timing(width, p.census_window, p.hamming_window, p.max_disparity),
             StageTiming(HandSegmentation.lag, HandSegmentation.cycles),
             opening_timing(width, element)]
    flush = sum(s.lag for s in pixel)
    if flush > OVERRUN_ROWS * width:
        raise ValueError(f"the windows look {flush} beats ahead, more than "
                         f"{OVERRUN_ROWS} rows of width {width}: use smaller windows")
    centroid_cycles = centroid_cycles_after_frame(width, height, params.hand_tracking)
    # A frame's first pixel reaches the centroid at least ``flush`` beats after
    # the previous frame's last one: the gate must be loaded by then.
    if params.track_gate and flush <= centroid_cycles:
        raise ValueError(f"track_gate needs at least {centroid_cycles + 1} flush beats "
                         f"between frames, the windows give {flush}")
    pixel_cycles = sum(s.cycles for s in pixel)
    record_cycles = (flush + pixel_cycles + centroid_cycles
                     + MovingAverage.cycles + GestureSpotting.cycles + 1)
    return PipelineTiming(flush, pixel_cycles, width * height + flush, record_cycles)


class GesturePipeline(wiring.Component):
    """Camera pins to per-frame gesture records (thesis chapters 5-7).

    Parameters
    ----------
    width, height : int
        Frame size in pixels (thesis 640 x 480); width even.
    params : sim.model.pipeline.PipelineParams
        Every algorithm parameter, the golden model's own object (thesis
        run-time values by default); validated for this frame size.
    rectification : sim.model.rectify.StereoRectification or None
        Both cameras' compressed maps: a :class:`~hdl.rectify.Rectifier` per
        camera after the 4:4:4 conversion (both with the larger reach of the
        two, so that they keep step). None: no rectification (the thesis).
    fifo_depth : power of two in [16, 65536]
        Words of each synchroniser FIFO (absorbs the cameras' phase difference).
    sync_threshold : int
        Words both FIFOs must hold before a frame starts (thesis N, Table 10).

    Ports
    -----
    left, right : camera pins ``{vsync, href, data}`` in the ``cam_left`` /
        ``cam_right`` clock domains (the cameras' PCLK; GPIO_1 / GPIO_0).
    start, pause : In, capture control (asynchronous; see CameraCapture).
    o_stream : one record per frame (:func:`record_layout`), always ready.
    video_select : In(3), index into :data:`VIDEO_STAGES`.
    o_video : ``{first, pixel}``, the selected stage's pixels (8-bit; masks
        as 0/255, disparity shifted to 8 bits), only real pixels.
    frames, faults : Out(16), frames completed and aborted by the synchroniser.
    threshold : In, LRCC threshold Th (reset value ``params.lrcc_threshold``).
    """

    def __init__(self, width: int = 640, height: int = 480,
                 params: PipelineParams = PipelineParams(), *,
                 rectification: StereoRectification | None = None, fifo_depth: int = 2048,
                 sync_threshold: int = 64):
        if not isinstance(params, PipelineParams):
            raise ValueError(f"params must be a PipelineParams, got {type(params).__name__}")
        params.validate(width, height)        # the frame size too: one range, the model's
        check_rectification(rectification, width, height)
        self.width, self.height, self.params = width, height, params
        self.rectification = rectification
        p = params
        self._capture = [CameraCapture(width, height) for _ in range(2)]
        self._to444 = [YCbCr422To444(width, height) for _ in range(2)]
        if rectification is None:
            self._rectify = []
        else:
            reach_x, reach_y = rectification.max_shift
            self._rectify = [
                Rectifier(width, height, grid, lanes=lanes,
                          interpolation=rectification.interpolation,
                          max_shift_x=reach_x, max_shift_y=reach_y)
                for grid, lanes in ((rectification.left, 3), (rectification.right, 1))]
        self._median = [Median3x3(width, height, pixel_bits=8) for _ in range(2)]
        self._matcher = StereoMatcher(width, height, census_window=p.census_window,
                                      hamming_window=p.hamming_window,
                                      max_disparity=p.max_disparity, pixel_bits=8,
                                      no_match_cost=p.no_match_cost, external_flush=True)
        med, mat = self._median[0], self._matcher
        self._segment = HandSegmentation(
            width, height, max_disparity=p.max_disparity, skin_cb=p.skin_cb, skin_cr=p.skin_cr,
            band_low=p.band_low, band_high=p.band_high,
            skin_delay_beats=med.lag + mat.lag, skin_delay_cycles=med.cycles + mat.cycles)
        self._opening = Opening(width, height, element=p.opening_shape, size=p.opening_size)
        self._centroid = Centroid(width, height, track_gate=p.track_gate,
                                  hand_rows=p.hand_rows)
        coord = bits_for(max(width, height) - 1)
        self._average = MovingAverage(coord_bits=coord, window=p.average_window,
                                      frac_bits=p.frac_bits)
        self._spotting = GestureSpotting(point_bits=coord + p.frac_bits, window=p.spot_window,
                                         threshold=p.spot_threshold, hold=p.spot_hold,
                                         frac_bits=p.frac_bits)
        #: the pixel stages in order (:class:`hdl.stage.PixelStage`)
        self.pixel_stages: list[PixelStage] = [self._to444[0], *self._rectify[:1], med, mat,
                                               self._segment, self._opening]
        #: :func:`pipeline_timing` of this pipeline, field by field
        self.flush, self.pixel_cycles, self.frame_cycles, self.record_cycles = \
            pipeline_timing(width, height, params, rectification)
        self._sync = StereoSynchronizer(width, height, fifo_depth=fifo_depth,
                                        threshold=min(sync_threshold, width * height),
                                        flush=self.flush)
        self.memory_bits = {
            **{f"rectify {side} {k}": v for side, r in zip(("left", "right"), self._rectify)
               for k, v in r.memory_bits.items()},
            "median row buffers": 2 * med.memory_bits,
            **{f"matcher {k}": v for k, v in mat.memory_bits.items()},
            "skin delay line": self._segment.memory_bits,
            "opening row buffers": self._opening.memory_bits,
        }
        # the camera's side of the link drives the pins
        pins = wiring.Signature({"vsync": Out(1), "href": Out(1), "data": Out(8)})
        self.disparity_bits = mat.disparity_bits
        super().__init__({
            "left": In(pins), "right": In(pins),
            "start": In(1, init=1), "pause": In(1),
            "o_stream": Out(stream.Signature(record_layout(width, height, p.frac_bits),
                                             always_ready=True)),
            "video_select": In(3),
            "o_video": Out(pixel_signature(8)),
            "frames": Out(16), "faults": Out(16),
            "threshold": In(bits_for(p.max_disparity), init=p.lrcc_threshold),
        })

    @property
    def stages(self) -> dict:
        """The stage components by name, in dataflow order: the ones
        :meth:`elaborate` wires (a caller may elaborate one alone instead, as the
        place-and-route check does)."""
        return {"capture_left": self._capture[0], "capture_right": self._capture[1],
                "synchronizer": self._sync,
                "to444_left": self._to444[0], "to444_right": self._to444[1],
                **{f"rectify_{side}": r for side, r in zip(("left", "right"), self._rectify)},
                "median_left": self._median[0], "median_right": self._median[1],
                "matcher": self._matcher, "segmentation": self._segment,
                "opening": self._opening, "centroid": self._centroid,
                "moving_average": self._average, "spotting": self._spotting}

    def elaborate(self, platform):
        m = Module()
        # --- capture (camera clock domains) and synchroniser -------------------------
        sync = self._sync
        m.submodules.synchronizer = sync
        for side, cap, domain, into in (("left", self._capture[0], "cam_left", sync.i_left),
                                        ("right", self._capture[1], "cam_right", sync.i_right)):
            m.submodules[f"capture_{side}"] = DomainRenamer(domain)(cap)
            pins = getattr(self, side)
            m.d.comb += [cap.vsync.eq(pins.vsync), cap.href.eq(pins.href),
                         cap.data.eq(pins.data), cap.start.eq(self.start),
                         cap.pause.eq(self.pause)]
            # (the FIFO write side lives in the camera domain, as the capture does)
            wiring.connect(m, cap.o_stream, into)
        m.d.comb += [self.frames.eq(sync.frames), self.faults.eq(sync.faults)]
        frame = sync.o_stream

        # --- pixel stages (sync domain), one beat per synchroniser beat ----------------
        to444, median = self._to444, self._median
        colour = []          # per camera: the stream of Y (Cb, Cr) the median sees
        for k, side in enumerate(("left", "right")):
            m.submodules[f"to444_{side}"] = to444[k]
            m.submodules[f"median_{side}"] = median[k]
            word = getattr(frame.payload, side)
            connect_remapped(m, frame, to444[k].i_stream, luma=word.luma, chroma=word.chroma)
            ycc = to444[k].o_stream
            if self._rectify:
                rect = self._rectify[k]
                m.submodules[f"rectify_{side}"] = rect
                lanes = [ycc.payload.y, ycc.payload.cb, ycc.payload.cr][:rect.lanes]
                connect_remapped(m, ycc, rect.i_stream, pixel=Cat(*lanes))
                pixel = rect.o_stream.payload.pixel
                colour.append((rect.o_stream, *(pixel[lane] for lane in range(rect.lanes))))
            else:
                colour.append((ycc, ycc.payload.y, ycc.payload.cb, ycc.payload.cr))
            connect_remapped(m, colour[k][0], median[k].i_stream, pixel=colour[k][1])
        m.submodules.matcher = mat = self._matcher
        m.d.comb += mat.threshold.eq(self.threshold)
        connect_remapped(m, median[0].o_stream, mat.i_stream,
                         left=median[0].o_stream.payload.pixel,
                         right=median[1].o_stream.payload.pixel)
        m.submodules.segmentation = seg = self._segment
        chroma, _, cb, cr = colour[0]
        connect_remapped(m, chroma, seg.i_chroma, cb=cb, cr=cr)
        wiring.connect(m, mat.o_stream, seg.i_disparity)
        m.submodules.opening = opening = self._opening
        connect_remapped(m, seg.o_stream, opening.i_stream, pixel=seg.o_stream.payload.hand)
        m.submodules.centroid = cen = self._centroid
        wiring.connect(m, opening.o_stream, cen.i_stream)

        # --- per-frame features -------------------------------------------------------
        m.submodules.moving_average = avg = self._average
        m.submodules.spotting = spot = self._spotting
        c = cen.o_stream.payload
        connect_remapped(m, cen.o_stream, avg.i_stream, valid=c.area != 0)   # a hand was seen
        connect_remapped(m, avg.o_stream, spot.i_stream)
        # The raw centroid waits for the averaging and spotting stages.
        raw = Signal.like(c)
        with m.If(cen.o_stream.valid):
            m.d.sync += raw.eq(c)
        rec = self.o_stream.payload
        m.d.sync += [
            self.o_stream.valid.eq(spot.o_stream.valid),
            rec.x.eq(spot.o_stream.payload.x), rec.y.eq(spot.o_stream.payload.y),
            rec.flag.eq(spot.o_stream.payload.flag),
            rec.centroid_x.eq(raw.x), rec.centroid_y.eq(raw.y), rec.area.eq(raw.area),
        ]

        # --- stage-select video (thesis Table 22) ---------------------------------------
        shift = 8 - self.disparity_bits
        sources = {
            "right": (median[1].o_stream, median[1].o_stream.payload.pixel),
            "left": (median[0].o_stream, median[0].o_stream.payload.pixel),
            "disparity": (mat.o_stream, mat.o_stream.payload.disparity << shift),
            "skin": (seg.o_stream, Mux(seg.o_stream.payload.skin, 255, 0)),
            "band": (seg.o_stream, Mux(seg.o_stream.payload.band, 255, 0)),
            "opening": (opening.o_stream, Mux(opening.o_stream.payload.pixel, 255, 0)),
        }
        video = self.o_video
        with m.Switch(self.video_select):
            for index, name in enumerate(VIDEO_STAGES):
                src, pixel = sources[name]
                with m.Case(index):
                    m.d.sync += [video.valid.eq(src.valid & src.payload.real),
                                 video.payload.first.eq(src.payload.first),
                                 video.payload.pixel.eq(pixel)]
            with m.Default():
                m.d.sync += video.valid.eq(0)
        return m


class PipelineTop(wiring.Component):
    """:class:`GesturePipeline` with its three clock domains declared, for the
    simulators and Verilog export: ports ``clk``/``rst`` (pipeline),
    ``cam_left_clk``/``cam_left_rst``, ``cam_right_clk``/``cam_right_rst`` and the
    pipeline's own ports flattened."""

    def __init__(self, pipeline: GesturePipeline):
        self.pipeline = pipeline
        super().__init__({
            "cam_left_clk": In(1), "cam_left_rst": In(1),
            "cam_right_clk": In(1), "cam_right_rst": In(1),
            **pipeline.signature.members,
        })

    def elaborate(self, platform):
        m = Module()
        for name in ("cam_left", "cam_right"):
            cd = ClockDomain(name, local=True)
            m.domains += cd
            m.d.comb += [cd.clk.eq(getattr(self, f"{name}_clk")),
                         cd.rst.eq(getattr(self, f"{name}_rst"))]
        m.submodules.pipeline = p = self.pipeline
        for name, member in p.signature.members.items():
            ours, theirs = getattr(self, name), getattr(p, name)
            if member.is_signature:
                wiring.connect(m, wiring.flipped(ours), theirs)
            elif member.flow == In:
                m.d.comb += theirs.eq(ours)
            else:
                m.d.comb += ours.eq(theirs)
        return m
