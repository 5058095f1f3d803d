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
      beside the opening and the centroid (``params.posture``):
        Opening                   §10.1  the posture's mask, 3x3 square
        PostureDescriptor         §10.1  the hand's shape, one record per frame

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

from ._util import bits_for, replicate
from .camera_capture import CameraCapture
from .centroid import GATE_LOAD_CYCLES, Centroid, centroid_cycles_after_frame
from .gesture_spotting import GestureSpotting
from .lrcc import disparity_bits
from .median3x3 import Median3x3, median_memory_bits, median_timing
from .moving_average import MovingAverage
from .opening import Opening, opening_memory_bits, opening_timing
from .posture_descriptor import PostureDescriptor, posture_cycles_after_frame
from .raster_position import OVERRUN_ROWS
from .rectify import Rectifier, check_rectifier, rectify_memory_bits, rectify_timing
from .segmentation import HandSegmentation, segmentation_memory_bits
from .stage import StageTiming
from .stereo_matcher import StereoMatcher, matcher_memory_bits, matcher_stage, matcher_timing
from .stereo_sync import StereoSynchronizer, check_fifo
from .streams import connect_remapped, pixel_signature
from .posture_descriptor import WORD_BITS
from soc.hps_interface import POSTURE_WORD_COUNT
from .ycbcr422 import YCbCr422To444

__all__ = ["GesturePipeline", "VIDEO_STAGES", "record_layout", "PipelineTop", "pipeline_timing",
           "PipelineTiming", "pixel_stage_timing", "pipeline_memory_bits", "pipeline_stage",
           "PIPELINE_STAGES"]

#: The stages of :class:`GesturePipeline` by name, in dataflow order
#: (:func:`pipeline_stage`); ``rectify_*`` only with a rectification.
PIPELINE_STAGES = ("capture_left", "capture_right", "synchronizer", "to444_left", "to444_right",
                   "rectify_left", "rectify_right", "median_left", "median_right", "matcher",
                   "segmentation", "opening", "centroid", "moving_average", "spotting",
                   "posture_opening", "posture")
#: The posture's mask: a 3x3 square opening (sim.model.posture.OPENING).
POSTURE_OPENING = ("square", 3)


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
    #: flush beats per frame: the look-ahead of every window stage (at least
    #: what the posture descriptor needs to send its record)
    flush: int
    #: clock cycles from a pixel beat to its opened-mask beat (free-running part)
    pixel_cycles: int
    #: clock cycles per frame, cameras never starving the pipeline
    frame_cycles: int
    #: clock cycles from a frame's last pixel leaving the synchroniser to its record
    record_cycles: int


def _check(width: int, height: int, params, rectification) -> None:
    """The checks of the pipeline's parameters, its stages' included."""
    if not isinstance(params, PipelineParams):
        raise ValueError(f"params must be a PipelineParams, got {type(params).__name__}")
    params.validate(width, height)        # the frame size too: one range, the model's
    check_rectification(rectification, width, height)
    if rectification is not None:
        reach_x, reach_y = rectification.max_shift
        for grid, lanes in ((rectification.left, 3), (rectification.right, 1)):
            check_rectifier(width, height, grid, lanes=lanes,
                            interpolation=rectification.interpolation,
                            max_shift_x=reach_x, max_shift_y=reach_y)


def pixel_stage_timing(width: int, height: int, params: PipelineParams = PipelineParams(),
                       rectification: StereoRectification | None = None) -> dict:
    """``lag`` and ``cycles`` of the pixel stages of one camera's path through
    :class:`GesturePipeline` (:class:`hdl.stage.PixelStage`), by stage name in
    dataflow order, from each stage's ``*_timing`` function (nothing is built).

    Raises ``ValueError`` as :class:`GesturePipeline` does for its parameters.
    """
    _check(width, height, params, rectification)
    p = params
    stages = {"to444_left": StageTiming(YCbCr422To444.lag, YCbCr422To444.cycles)}
    if rectification is not None:
        stages["rectify_left"] = rectify_timing(width, *rectification.max_shift)
    stages["median_left"] = median_timing(width)
    stages["matcher"] = matcher_timing(width, p.census_window, p.hamming_window,
                                       p.max_disparity)
    stages["segmentation"] = StageTiming(HandSegmentation.lag, HandSegmentation.cycles)
    stages["opening"] = opening_timing(width, resolve_element(p.opening_shape, p.opening_size))
    return stages


def pipeline_timing(width: int, height: int, params: PipelineParams = PipelineParams(),
                    rectification: StereoRectification | None = None) -> PipelineTiming:
    """The timing of :class:`GesturePipeline` from its parameters alone (nothing
    is built): each stage's ``*_timing`` function, the one its component uses.

    Raises ``ValueError`` as :meth:`PipelineParams.validate` does, or when the
    windows look further ahead than the position counters run past a frame.
    """
    pixel = list(pixel_stage_timing(width, height, params, rectification).values())
    flush = sum(s.lag for s in pixel)
    if flush > OVERRUN_ROWS * width:
        raise ValueError(f"the windows look {flush} beats ahead, more than "
                         f"{OVERRUN_ROWS} rows of width {width}: use smaller windows")
    centroid_cycles = centroid_cycles_after_frame(width, height, params.hand_tracking)
    # A frame's first pixel reaches the centroid at least ``flush`` beats after
    # the previous frame's last one: the gate must be loaded by then.
    gate_cycles = centroid_cycles + GATE_LOAD_CYCLES
    if params.track_gate and flush <= gate_cycles:
        raise ValueError(f"track_gate needs at least {gate_cycles + 1} flush beats "
                         f"between frames, the windows give {flush}")
    if params.posture:
        # the descriptor's record must be out before the next frame's pixels (on
        # small frames the synchroniser gives more flush beats than the windows
        # need), and the centroid its window is about must be in before them
        posture_lag = opening_timing(width, resolve_element(*POSTURE_OPENING)).lag
        flush = max(flush, posture_cycles_after_frame() - 1)
        before = flush - pixel[-1].lag + posture_lag
        if params.posture_gate and before <= gate_cycles + 2:
            raise ValueError(f"posture_gate needs the centroid {gate_cycles + 3} beats before "
                             f"the next frame's posture, the windows give {before}")
    pixel_cycles = sum(s.cycles for s in pixel)
    record_cycles = (flush + pixel_cycles + centroid_cycles
                     + MovingAverage.cycles + GestureSpotting.cycles + 1)
    return PipelineTiming(flush, pixel_cycles, width * height + flush, record_cycles)


def pipeline_memory_bits(width: int, height: int, params: PipelineParams = PipelineParams(),
                         rectification: StereoRectification | None = None) -> dict:
    """The memory of each pixel stage of :class:`GesturePipeline` (its
    ``memory_bits``), from the stages' memory functions (nothing is built)."""
    p = params
    pixel = pixel_stage_timing(width, height, params, rectification)
    bits = {}
    if rectification is not None:
        reach_y = rectification.max_shift[1]
        for side, grid, lanes in (("left", rectification.left, 3),
                                  ("right", rectification.right, 1)):
            for k, v in rectify_memory_bits(width, grid, lanes=lanes,
                                            max_shift_y=reach_y).items():
                bits[f"rectify {side} {k}"] = v
    med, mat = pixel["median_left"], pixel["matcher"]
    element = resolve_element(p.opening_shape, p.opening_size)
    return {
        **bits,
        "median row buffers": 2 * median_memory_bits(width, pixel_bits=8),
        **{f"matcher {k}": v for k, v in matcher_memory_bits(
            width, census_window=p.census_window, hamming_window=p.hamming_window,
            max_disparity=p.max_disparity, pixel_bits=8).items()},
        "skin delay line": segmentation_memory_bits(skin_delay_beats=med.lag + mat.lag),
        "opening row buffers": opening_memory_bits(width, element),
        **({"posture opening row buffers": opening_memory_bits(
            width, resolve_element(*POSTURE_OPENING))} if p.posture else {}),
    }


def pipeline_stage(name: str, width: int, height: int, params: PipelineParams = PipelineParams(),
                   *, rectification: StereoRectification | None = None, fifo_depth: int = 2048,
                   sync_threshold: int = 64):
    """The stage ``name`` of a :class:`GesturePipeline` with these parameters (its
    own), built alone as its :meth:`~GesturePipeline.elaborate` builds it.

    ``name`` is one of :data:`PIPELINE_STAGES` (``rectify_*`` only with a
    ``rectification``) or ``matcher.`` and a stage of the matcher
    (:func:`~hdl.stereo_matcher.matcher_stage`: ``matcher.census_left``,
    ``matcher.shd.columns``, ...). Nothing else is built.

    Raises ``ValueError`` as :class:`GesturePipeline` does, or for another name.
    """
    flush = pipeline_timing(width, height, params, rectification).flush    # (checks them)
    p = params
    if name in ("capture_left", "capture_right"):
        return CameraCapture(width, height)
    if name == "synchronizer":
        return StereoSynchronizer(width, height, fifo_depth=fifo_depth,
                                  threshold=min(sync_threshold, width * height), flush=flush)
    if name in ("to444_left", "to444_right"):
        return YCbCr422To444(width, height)
    if name in ("rectify_left", "rectify_right") and rectification is not None:
        # both with the larger reach of the two, so that they keep step
        reach_x, reach_y = rectification.max_shift
        grid, lanes = ((rectification.left, 3) if name == "rectify_left"
                       else (rectification.right, 1))
        return Rectifier(width, height, grid, lanes=lanes,
                         interpolation=rectification.interpolation,
                         max_shift_x=reach_x, max_shift_y=reach_y)
    if name in ("median_left", "median_right"):
        return Median3x3(width, height, pixel_bits=8)
    matcher = dict(census_window=p.census_window, hamming_window=p.hamming_window,
                   max_disparity=p.max_disparity, pixel_bits=8, no_match_cost=p.no_match_cost)
    if name == "matcher":
        return StereoMatcher(width, height, **matcher, external_flush=True)
    if name.startswith("matcher."):
        return matcher_stage(name[len("matcher."):], width, height, **matcher)
    if name == "segmentation":
        # the skin bits wait for the disparities of their pixels
        med = median_timing(width)
        mat = matcher_timing(width, p.census_window, p.hamming_window, p.max_disparity)
        return HandSegmentation(
            width, height, max_disparity=p.max_disparity, skin_cb=p.skin_cb, skin_cr=p.skin_cr,
            band_low=p.band_low, band_high=p.band_high,
            skin_delay_beats=med.lag + mat.lag, skin_delay_cycles=med.cycles + mat.cycles)
    if name == "opening":
        return Opening(width, height, element=p.opening_shape, size=p.opening_size)
    if name == "centroid":
        return Centroid(width, height, track_gate=p.track_gate, hand_rows=p.hand_rows)
    if name == "posture_opening" and p.posture:
        return Opening(width, height, element=POSTURE_OPENING[0], size=POSTURE_OPENING[1])
    if name == "posture" and p.posture:
        return PostureDescriptor(width, height, gate=p.posture_gate)
    coord = bits_for(max(width, height) - 1)
    if name == "moving_average":
        return MovingAverage(coord_bits=coord, window=p.average_window, frac_bits=p.frac_bits)
    if name == "spotting":
        return GestureSpotting(point_bits=coord + p.frac_bits, window=p.spot_window,
                               threshold=p.spot_threshold, hold=p.spot_hold,
                               frac_bits=p.frac_bits)
    names = [n for n in PIPELINE_STAGES
             if (rectification is not None or not n.startswith("rectify_"))
             and (p.posture or not n.startswith("posture"))]
    raise ValueError(f"stage must be one of {', '.join(names)} or matcher.<stage>, "
                     f"got {name!r}")


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
    o_posture : the posture descriptor's record, a word a beat
        (:class:`~hdl.posture_descriptor.PostureDescriptor`; never valid
        without ``params.posture``), always ready.
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
        #: :func:`pipeline_timing` of this pipeline, field by field (it checks
        #: the parameters, its stages' included)
        self.flush, self.pixel_cycles, self.frame_cycles, self.record_cycles = \
            pipeline_timing(width, height, params, rectification)
        check_fifo(fifo_depth, min(sync_threshold, width * height), width * height)
        self.width, self.height, self.params = width, height, params
        self.rectification = rectification
        self.fifo_depth, self.sync_threshold = fifo_depth, sync_threshold
        p = params
        #: names of its stages (:meth:`stage`), in dataflow order
        self.stage_names = tuple(name for name in PIPELINE_STAGES
                                 if (rectification is not None or not name.startswith("rectify_"))
                                 and (p.posture or not name.startswith("posture")))
        #: names of the pixel stages of one camera's path, in order
        #: (:class:`hdl.stage.PixelStage`, :func:`pixel_stage_timing`)
        self.pixel_stage_names = tuple(pixel_stage_timing(width, height, params, rectification))
        self.memory_bits = pipeline_memory_bits(width, height, params, rectification)
        # the camera's side of the link drives the pins
        pins = wiring.Signature({"vsync": Out(1), "href": Out(1), "data": Out(8)})
        self.disparity_bits = disparity_bits(p.max_disparity)
        super().__init__({
            "left": In(pins), "right": In(pins),
            "start": In(1, init=1), "pause": In(1),
            "o_stream": Out(stream.Signature(record_layout(width, height, p.frac_bits),
                                             always_ready=True)),
            "video_select": In(3),
            "o_video": Out(pixel_signature(8)),
            "o_posture": Out(stream.Signature(data.StructLayout(
                {"index": bits_for(POSTURE_WORD_COUNT - 1), "word": WORD_BITS}),
                always_ready=True)),
            "frames": Out(16), "faults": Out(16),
            "threshold": In(bits_for(p.max_disparity), init=p.lrcc_threshold),
        })

    def stage(self, name: str):
        """The stage ``name`` (of :attr:`stage_names`, or ``matcher.`` and a stage
        of the matcher), freshly built with the parameters it has here, as
        :meth:`elaborate` builds its stages; only that stage is built (the
        place-and-route check elaborates one alone)."""
        return pipeline_stage(name, self.width, self.height, self.params,
                              rectification=self.rectification, fifo_depth=self.fifo_depth,
                              sync_threshold=self.sync_threshold)

    def elaborate(self, platform):
        m = Module()
        # --- capture (camera clock domains) and synchroniser -------------------------
        m.submodules.synchronizer = sync = self.stage("synchronizer")
        for side, domain, into in (("left", "cam_left", sync.i_left),
                                   ("right", "cam_right", sync.i_right)):
            cap = self.stage(f"capture_{side}")
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
        to444 = [self.stage("to444_left"), self.stage("to444_right")]
        median = [self.stage("median_left"), self.stage("median_right")]
        colour = []          # per camera: the stream of Y (Cb, Cr) the median sees
        for k, side in enumerate(("left", "right")):
            m.submodules[f"to444_{side}"] = to444[k]
            m.submodules[f"median_{side}"] = median[k]
            word = getattr(frame.payload, side)
            connect_remapped(m, frame, to444[k].i_stream, luma=word.luma, chroma=word.chroma)
            ycc = to444[k].o_stream
            if self.rectification is not None:
                rect = self.stage(f"rectify_{side}")
                m.submodules[f"rectify_{side}"] = rect
                lanes = [ycc.payload.y, ycc.payload.cb, ycc.payload.cr][:rect.lanes]
                connect_remapped(m, ycc, rect.i_stream, pixel=Cat(*lanes))
                pixel = rect.o_stream.payload.pixel
                colour.append((rect.o_stream, *(pixel[lane] for lane in range(rect.lanes))))
            else:
                colour.append((ycc, ycc.payload.y, ycc.payload.cb, ycc.payload.cr))
            connect_remapped(m, colour[k][0], median[k].i_stream, pixel=colour[k][1])
        m.submodules.matcher = mat = self.stage("matcher")
        m.d.comb += mat.threshold.eq(self.threshold)
        connect_remapped(m, median[0].o_stream, mat.i_stream,
                         left=median[0].o_stream.payload.pixel,
                         right=median[1].o_stream.payload.pixel)
        m.submodules.segmentation = seg = self.stage("segmentation")
        chroma, _, cb, cr = colour[0]
        connect_remapped(m, chroma, seg.i_chroma, cb=cb, cr=cr)
        wiring.connect(m, mat.o_stream, seg.i_disparity)
        m.submodules.opening = opening = self.stage("opening")
        connect_remapped(m, seg.o_stream, opening.i_stream, pixel=seg.o_stream.payload.hand)
        m.submodules.centroid = cen = self.stage("centroid")
        wiring.connect(m, opening.o_stream, cen.i_stream)

        # --- the posture, beside the opening and the centroid --------------------------
        if self.params.posture:
            m.submodules.posture_opening = shape = self.stage("posture_opening")
            connect_remapped(m, seg.o_stream, shape.i_stream, pixel=seg.o_stream.payload.hand)
            m.submodules.posture = desc = self.stage("posture")
            wiring.connect(m, shape.o_stream, desc.i_stream)
            if self.params.posture_gate:
                connect_remapped(m, cen.o_stream, desc.i_gate)
            wiring.connect(m, desc.o_stream, wiring.flipped(self.o_posture))

        # --- per-frame features -------------------------------------------------------
        m.submodules.moving_average = avg = self.stage("moving_average")
        m.submodules.spotting = spot = self.stage("spotting")
        c = cen.o_stream.payload
        connect_remapped(m, cen.o_stream, avg.i_stream, valid=c.hand)   # a hand was seen
        connect_remapped(m, avg.o_stream, spot.i_stream)
        # The raw centroid waits for the averaging and spotting stages; it loads
        # from its own copy of the centroid's valid, a cycle late (the centroid
        # holds its output until the next frame's), so that valid drives only
        # registers next to it (its net to every raw bit was the routed limit).
        raw = Signal.like(c)
        (raw_load,) = replicate(m, cen.o_stream.valid, 1, "raw_load")
        with m.If(raw_load):
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
    pipeline's own ports flattened.

    ``fold_posture``: instead of ``o_posture``, ``posture_parity`` (Out(4)),
    the registered parities of its registered bits, a quarter each (the
    place-and-route check, :mod:`hdl.place_route`: its package has 190 pins;
    every bit of the record still reaches a pin).
    """

    #: Pins ``fold_posture`` leaves of ``o_posture``.
    PARITY_PINS = 4

    def __init__(self, pipeline: GesturePipeline, *, fold_posture: bool = False):
        self.pipeline = pipeline
        self.fold_posture = bool(fold_posture)
        members = dict(pipeline.signature.members)
        if self.fold_posture:
            del members["o_posture"]
            members["posture_parity"] = Out(self.PARITY_PINS)
        super().__init__({
            "cam_left_clk": In(1), "cam_left_rst": In(1),
            "cam_right_clk": In(1), "cam_right_rst": In(1),
            **members,
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
            theirs = getattr(p, name)
            if name == "o_posture" and self.fold_posture:
                bits = Signal(len(Cat(theirs.valid, theirs.payload.as_value())),
                              name="posture_bits")
                m.d.sync += bits.eq(Cat(theirs.valid, theirs.payload.as_value()))
                quarter = -(-len(bits) // self.PARITY_PINS)
                m.d.sync += self.posture_parity.eq(Cat(*[
                    bits[k * quarter:(k + 1) * quarter].xor()
                    for k in range(self.PARITY_PINS)]))
                continue
            ours = getattr(self, name)
            if member.is_signature:
                wiring.connect(m, wiring.flipped(ours), theirs)
            elif member.flow == In:
                m.d.comb += theirs.eq(ours)
            else:
                m.d.comb += ours.eq(theirs)
        return m
