"""The whole FPGA side as golden model: camera bytes in, per-frame
(x, y, gesture flag) out (thesis chapters 5-7).

A reader sees the pipeline in :func:`process_frame` and :func:`track` as a
list of stages, each a pure function of :mod:`sim.model`::

    per frame (§5.4, §6.1-6.4, §7.1)
        ycbcr422_to_444      left and right camera byte streams
        rectify              optional (§10.1): Y, Cb, Cr left, Y right
        median3x3            Y of each camera
        stereo_match         census, SHD, L2R/R2L, LRCC, disparity median
        skin_mask            Cb/Cr of the left camera (the disparity's reference)
        disparity_band       TL < d < TH
        hand_mask            skin AND band
        opening              W x W structuring element
        centroid             first-order moments / area
        posture_mask         beside them (§10.1): skin AND band, 3x3 opening
        posture_registers    the hand's shape about the previous frame's reference
    per clip (§7.2-7.3)
        moving_average       N samples, 10.8 fixed point
        gesture_spotting     K frames, Tm pixels
    on the HPS (§7.4), for the trajectory file
        orientation_symbols  8 directions
"""
from __future__ import annotations

from dataclasses import asdict, dataclass
from typing import Callable, NamedTuple

import numpy as np

from .centroid import TRACK_GATE_RANGE, Centroid, centroid, counted_pixels
from .gesture_spotting import gesture_spotting
from .median import median3x3
from .morphology import opening, structuring_element
from .moving_average import moving_average
from .orientation import NO_SYMBOL, orientation_symbols
from .posture import (PostureReference, PostureRegisters, next_reference, posture_mask,
                      posture_reference,
                      posture_registers, posture_words)
from .rectify import StereoRectification, rectify_pair
from .segmentation import disparity_band, hand_mask, skin_mask
from .stereo import check_stereo_params, stereo_match
from .validation import check_int
from .ycbcr import ycbcr422_to_444

__all__ = ["check_rectification", "PipelineParams", "DEMO_SPOT_HOLD", "HAND_TRACKING_640",
           "hand_tracking_for", "VIDEO_STAGES", "video_picture", "FrameStages", "Trajectory", "process_frame", "track",
           "step_symbols", "run_clip"]


#: The posture reference before the first frame (no hand).
EMPTY_REFERENCE = PostureReference(0, 0, 0)
#: Still frames that end a gesture in the end-to-end demo (:meth:`PipelineParams.for_frame`).
DEMO_SPOT_HOLD = 24
#: Hand tracking of :meth:`PipelineParams.for_frame` (``hand_tracking=True``) for
#: 640-pixel-wide frames, scaled to the width: the centroid counts the mask within
#: 64 px of the previous centroid and its first 36 rows (sim.model.centroid).
#: Chosen on the hard scene's development seeds 501-502 (docs/figures/scenes.md).
#: The posture descriptor's window (96 px) holds the largest rendered hand with
#: its fingers spread about its palm.
HAND_TRACKING_640 = {"track_gate": 64, "hand_rows": 36, "posture_gate": 96}


@dataclass(frozen=True)
class PipelineParams:
    """Every parameter of the FPGA pipeline; defaults are the thesis run-time values."""
    census_window: int = 7            #: Wc (§6.2.1)
    hamming_window: int = 29          #: Wh (§6.2.2)
    max_disparity: int = 48           #: D
    lrcc_threshold: int = 8           #: Th (eq. 21)
    no_match_cost: int | None = None  #: left-band cost, None = census bits // 3
    skin_cb: tuple[int, int] = (77, 127)    #: eq. 22
    skin_cr: tuple[int, int] = (133, 173)   #: eq. 22
    band_low: int = 33                #: TL (Fig. 58)
    band_high: int | None = None      #: TH, None = D - 2
    opening_shape: str = "cross"      #: structuring element (Fig. 100)
    opening_size: int = 11            #: W
    average_window: int = 4           #: N (eq. 27)
    frac_bits: int = 8                #: 10.8 fixed point
    spot_window: int = 8              #: K (Fig. 78)
    spot_threshold: int = 30          #: Tm, pixels
    spot_hold: int = 16               #: still frames that end a gesture
    track_gate: int = 0               #: hand tracking (not in the thesis): gate half-size, px
    hand_rows: int = 0                #: hand tracking: rows counted from the hand's top
    posture: bool = True              #: the posture descriptor (§10.1, not in the thesis)
    posture_gate: int = 0             #: its window about the previous centroid, px (0: none)

    #: Frame heights the pipeline accepts (the widths depend on the parameters:
    #: :meth:`width_range`).
    HEIGHT_RANGE = (16, 4096)

    def width_range(self) -> tuple[int, int]:
        """The frame widths these parameters allow, ``(low, high)``; a width must
        also be even (4:2:2 pixel pairs). A row must hold the disparity search D,
        the census window Wc and the Hamming window Wh with a pixel beside them
        and the opening's W + 2 (the window stages' line buffers), and at least 16."""
        low = max(16, self.max_disparity, self.census_window + 2, self.hamming_window + 1,
                  self.opening_size + 2)
        return low + low % 2, 4096

    def validate(self, width: int, height: int) -> None:
        """Raise ``ValueError`` naming the first parameter out of range: the
        parameters first, then the frame size against :meth:`width_range`."""
        check_stereo_params(4096, 4096, self.census_window, self.hamming_window,
                            self.max_disparity, self.lrcc_threshold, self.no_match_cost)
        # The cheap stages validate themselves; run them once on a tiny input and
        # rename the stage's argument in the message to the field of this class.
        probe = np.zeros((1, 1), np.uint8)
        point = np.zeros((1, 2), np.int64), np.ones(1, bool)
        _renamed({"cb_range": "skin_cb", "cr_range": "skin_cr"},
                 skin_mask, probe, probe, self.skin_cb, self.skin_cr)
        _renamed({"low": "band_low", "high": "band_high"},
                 disparity_band, probe, self.band_low, self.band_high, self.max_disparity)
        _renamed({"shape": "opening_shape", "size": "opening_size"},
                 structuring_element, self.opening_shape, self.opening_size)
        centroid(probe, previous=(0, 0, 1), track_gate=self.track_gate,
                 hand_rows=self.hand_rows)
        if not isinstance(self.posture, bool):
            raise ValueError(f"posture must be True or False, got {self.posture!r}")
        check_int("posture_gate", self.posture_gate, *TRACK_GATE_RANGE)
        if self.posture_gate and not self.posture:
            raise ValueError("posture_gate needs posture")
        _renamed({"window": "average_window"},
                 moving_average, *point, self.average_window, self.frac_bits)
        _renamed({"window": "spot_window", "threshold": "spot_threshold", "hold": "spot_hold"},
                 gesture_spotting, *point, self.spot_window, self.spot_threshold,
                 self.spot_hold, self.frac_bits)
        low, high = self.width_range()
        check_int("width", width, low, high)
        if width % 2:
            raise ValueError(f"width must be even, in [{low}, {high}] (4:2:2 pixel pairs), "
                             f"got {width}")
        check_int("height", height, *self.HEIGHT_RANGE)

    def as_dict(self) -> dict:
        return asdict(self)

    @property
    def hand_tracking(self) -> bool:
        """Whether the centroid tracks the hand (:mod:`sim.model.centroid`)."""
        return bool(self.track_gate or self.hand_rows)

    @classmethod
    def for_frame(cls, width: int, *, hand_tracking: bool = False,
                  **overrides) -> "PipelineParams":
        """The parameters of the end-to-end demo for frames ``width`` pixels wide:
        the thesis values, with the spotting threshold Tm (a distance in pixels,
        set for 640-pixel-wide frames) scaled to ``width``, and the spotting hold
        raised to :data:`DEMO_SPOT_HOLD` frames (the rendered out-and-back
        gestures dwell at their turn long enough to split under 16; measured on
        the development seeds, see docs/design/soc.md). ``hand_tracking``: also the
        centroid's hand tracking, :data:`HAND_TRACKING_640` scaled to ``width``."""
        check_int("width", width, 16, 4096)
        values = dict(spot_threshold=max(1, round(cls.spot_threshold * width / 640)),
                      spot_hold=DEMO_SPOT_HOLD)
        if hand_tracking:
            values.update(hand_tracking_for(width))
        values.update(overrides)
        return cls(**values)


def hand_tracking_for(width: int) -> dict:
    """``track_gate``, ``hand_rows`` and ``posture_gate`` of
    :data:`HAND_TRACKING_640` scaled to frames ``width`` pixels wide."""
    check_int("width", width, 16, 4096)
    return {name: max(1, round(value * width / 640)) for name, value in HAND_TRACKING_640.items()}


def _renamed(names: dict[str, str], check: Callable, *args) -> None:
    """Call ``check(*args)``; re-raise its ``ValueError`` with the leading argument
    name replaced by the :class:`PipelineParams` field it came from."""
    try:
        check(*args)
    except ValueError as exc:
        message = str(exc)
        for arg, field in names.items():
            rest = message[len(arg):]
            if message.startswith(arg) and not (rest[:1].isalnum() or rest[:1] == "_"):
                message = field + rest
                break
        raise ValueError(message) from None


class FrameStages(NamedTuple):
    """Every intermediate picture of one frame, (H, W) each, the centroid, and
    the posture descriptor (None without ``params.posture``)."""
    left: np.ndarray        #: Y of the left camera after the median, uint8
    right: np.ndarray       #: Y of the right camera after the median, uint8
    disparity: np.ndarray   #: final disparity map, uint8, 0 = invalid
    skin: np.ndarray        #: bool
    band: np.ndarray        #: bool
    hand: np.ndarray        #: skin AND band, bool
    opened: np.ndarray      #: after the opening, bool
    centroid: Centroid
    #: the posture's mask (3x3 opening of ``hand``, within ``posture_gate``), bool
    posture_mask: np.ndarray | None = None
    #: its descriptor about ``posture_reference`` (predicted from the
    #: previous two frames, :func:`sim.model.posture.next_reference`)
    posture: PostureRegisters | None = None
    posture_reference: PostureReference | None = None
    #: the previous frame's own reference (:func:`sim.model.posture.posture_reference`)
    posture_previous: PostureReference | None = None

    def posture_words(self) -> list | None:
        """The frame's posture record as the hardware sends it (None without)."""
        if self.posture is None:
            return None
        return posture_words(self.posture, self.posture_reference)

    def following(self) -> dict:
        """:func:`process_frame`'s keyword arguments for the next frame: this
        frame's centroid (the hand tracking's gate), the posture reference
        predicted from this frame's and the previous frame's own references,
        and this frame's own reference."""
        if self.posture is None:
            return {"previous": self.centroid}
        height, width = self.hand.shape
        own = posture_reference(self.posture)
        return {"previous": self.centroid, "posture_previous": own,
                "reference": next_reference(own, self.posture_previous or EMPTY_REFERENCE,
                                            width, height)}


def check_rectification(rectification, width: int, height: int) -> None:
    """Refuse a rectification that is not a :class:`StereoRectification` for
    ``width`` x ``height`` frames (None, no rectification, passes)."""
    if rectification is None:
        return
    if not isinstance(rectification, StereoRectification):
        raise ValueError(f"rectification must be a StereoRectification or None, got "
                         f"{type(rectification).__name__}")
    if rectification.size != (width, height):
        raise ValueError("the rectification is for {}x{} frames, not {}x{}".format(
            *rectification.size, width, height))


def process_frame(left_bytes, right_bytes, params: PipelineParams = PipelineParams(),
                  *, rectification: StereoRectification | None = None,
                  previous: Centroid | None = None,
                  reference: PostureReference | None = None,
                  posture_previous: PostureReference | None = None,
                  threads: int | None = None) -> FrameStages:
    """Run one stereo frame through every pixel stage (§5.4 - §7.1).

    ``left_bytes`` and ``right_bytes`` are (H, 2W) uint8 YCbCr 4:2:2 byte
    streams (Y0 Cb Y1 Cr ...), as the cameras deliver them. ``rectification``
    (:mod:`sim.model.rectify`) rectifies both cameras after the 4:4:4
    conversion; None (the thesis' pipeline) leaves them as they are.
    ``previous`` is the previous frame's centroid, which the hand tracking's
    gate needs (``params.track_gate``; None: the clip's first frame), and
    ``reference`` the reference the posture descriptor is about and
    ``posture_previous`` the previous frame's own reference (None: none yet);
    :meth:`FrameStages.following` gives the three for the next frame.
    """
    y_left, cb_left, cr_left = ycbcr422_to_444(left_bytes)
    y_right, _, _ = ycbcr422_to_444(right_bytes)
    if y_left.shape != y_right.shape:
        raise ValueError(f"left and right frames differ in size: {y_left.shape} vs {y_right.shape}")
    if rectification is not None:
        check_rectification(rectification, y_left.shape[1], y_left.shape[0])
        (y_left, cb_left, cr_left), (y_right,) = rectify_pair(
            (y_left, cb_left, cr_left), (y_right,), rectification)
    y_left, y_right = median3x3(y_left), median3x3(y_right)
    disparity = stereo_match(y_left, y_right, census_window=params.census_window,
                             hamming_window=params.hamming_window,
                             max_disparity=params.max_disparity,
                             lrcc_threshold=params.lrcc_threshold,
                             no_match_cost=params.no_match_cost,
                             threads=threads).disparity
    skin = skin_mask(cb_left, cr_left, params.skin_cb, params.skin_cr)
    band = disparity_band(disparity, params.band_low, params.band_high, params.max_disparity)
    hand = hand_mask(skin, band)
    opened = opening(hand, params.opening_shape, size=params.opening_size)
    cen = centroid(opened, previous=previous, track_gate=params.track_gate,
                   hand_rows=params.hand_rows)
    if not params.posture:
        return FrameStages(y_left, y_right, disparity, skin, band, hand, opened, cen)
    shape_mask = posture_mask(hand)
    if params.posture_gate:
        shape_mask = counted_pixels(shape_mask, previous=previous,
                                    track_gate=params.posture_gate)
    reference = reference or EMPTY_REFERENCE
    return FrameStages(y_left, y_right, disparity, skin, band, hand, opened, cen, shape_mask,
                       posture_registers(shape_mask, reference), reference, posture_previous)


#: Stages of the pipeline's stage-select video output (thesis Table 22, SW[9:7]).
VIDEO_STAGES = ("right", "left", "disparity", "skin", "band", "opening")


def video_picture(stages: FrameStages, stage: str, disparity_bits: int) -> np.ndarray:
    """The 8-bit picture the pipeline's stage-select video output carries for
    ``stage`` (one of :data:`VIDEO_STAGES`): camera luma as is, the disparity
    shifted up to 8 bits, masks as 0/255."""
    if stage not in VIDEO_STAGES:
        raise ValueError(f"stage must be one of {list(VIDEO_STAGES)}, got {stage!r}")
    check_int("disparity_bits", disparity_bits, 1, 8)
    if stage in ("right", "left"):
        return getattr(stages, stage).astype(np.uint8)
    if stage == "disparity":
        return (stages.disparity.astype(np.uint16) << (8 - disparity_bits)).astype(np.uint8)
    mask = {"skin": stages.skin, "band": stages.band, "opening": stages.opened}[stage]
    return mask.astype(np.uint8) * np.uint8(255)


class Trajectory(NamedTuple):
    """Per-frame features of a clip (F frames)."""
    centroid: np.ndarray   #: (F, 2) int64 raw centroid (x, y); (0, 0) when no hand
    area: np.ndarray       #: (F,) int64 hand pixels after the opening
    smoothed: np.ndarray   #: (F, 2) int64 moving average, ``frac_bits`` fixed point
    flag: np.ndarray       #: (F,) bool, gesture in progress
    symbol: np.ndarray     #: (F,) int8 orientation symbol, NO_SYMBOL where none
    #: (F, POSTURE_WORD_COUNT) int64: each frame's posture record (None without)
    posture: np.ndarray | None = None


def step_symbols(smoothed, flag) -> np.ndarray:
    """Orientation symbol of each frame's step from the previous frame (Fig. 82).

    Frame n gets the symbol of ``smoothed[n-1] -> smoothed[n]`` when frames
    n-1 and n are both flagged (the HPS only receives flagged points), and
    ``NO_SYMBOL`` otherwise or when the position did not change.
    """
    smoothed = np.asarray(smoothed)
    flag = np.asarray(flag, dtype=bool)
    symbols = np.full(len(flag), NO_SYMBOL, dtype=np.int8)
    if len(flag) > 1:
        steps = orientation_symbols(smoothed)
        both = flag[1:] & flag[:-1]
        symbols[1:][both] = steps[both]
    return symbols


def track(centroids, areas, params: PipelineParams = PipelineParams(),
          posture=None) -> Trajectory:
    """Moving average, spotting and symbols for a clip's per-frame centroids
    (§7.2-7.4), with the frames' posture records (``posture``, kept as given)."""
    centroids = np.asarray(centroids, dtype=np.int64).reshape(-1, 2)
    areas = np.asarray(areas, dtype=np.int64).reshape(-1)
    if len(areas) != len(centroids):
        raise ValueError(f"centroids ({len(centroids)}) and areas ({len(areas)}) differ in length")
    valid = areas > 0
    smoothed = moving_average(centroids, valid, params.average_window, params.frac_bits)
    primed = np.logical_or.accumulate(valid) if len(valid) else valid
    flag = gesture_spotting(smoothed, primed, params.spot_window, params.spot_threshold,
                            params.spot_hold, params.frac_bits)
    return Trajectory(centroids, areas, smoothed, flag, step_symbols(smoothed, flag),
                      None if posture is None else np.asarray(posture, np.int64))


def run_clip(left_frames, right_frames, params: PipelineParams = PipelineParams(), *,
             keep: Callable[[int], bool] = lambda n: False,
             progress: Callable[[int, int], None] | None = None,
             threads: int | None = None,
             rectification: StereoRectification | None = None,
             ) -> tuple[Trajectory, dict[int, FrameStages]]:
    """Process every frame of a clip (rectified with ``rectification`` if
    given); return the trajectory and the stages of the frames for which
    ``keep(n)`` is true."""
    frames = len(left_frames)
    if len(right_frames) != frames:
        raise ValueError(f"left has {frames} frames but right has {len(right_frames)}")
    if frames == 0:
        raise ValueError("left_frames must hold at least one frame")
    height, width2 = np.shape(left_frames[0])[-2:]
    params.validate(width2 // 2, height)
    check_rectification(rectification, width2 // 2, height)
    cents = np.zeros((frames, 2), np.int64)
    areas = np.zeros(frames, np.int64)
    kept: dict[int, FrameStages] = {}
    following = {}
    records = []
    for n in range(frames):
        stages = process_frame(left_frames[n], right_frames[n], params,
                               rectification=rectification, threads=threads, **following)
        following = stages.following()
        if stages.posture is not None:
            records.append(stages.posture_words())
        cents[n] = stages.centroid.x, stages.centroid.y
        areas[n] = stages.centroid.area
        if keep(n):
            kept[n] = stages
        if progress is not None:
            progress(n + 1, frames)
    return track(cents, areas, params, records if params.posture else None), kept
