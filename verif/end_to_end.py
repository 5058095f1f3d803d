"""End to end, cameras to robot command: a stereo clip through the Verilated
FPGA side (:mod:`verif.system`) and the unmodified board application, checked
against the golden model on the way (the main job, ``stereogest demo``).

What is compared with what:

* the (x, y) pairs the application pops from the hardware FIFO against the
  golden model's smoothed centroids of the flagged frames, word for word;
* the bytes on the UART's TX pin, decoded by an independent 8N1 receiver
  (:func:`verif.system.decode_uart`), against the telegram the application
  sent;
* one whole VGA frame of the debug view, taken after the last camera frame,
  against the golden model's picture of the selected stage for that frame.
"""
from __future__ import annotations

import logging
import time
from dataclasses import dataclass, field

import numpy as np

from sim.model.pipeline import FrameStages, PipelineParams, Trajectory, track, video_picture

from .clocks import Clocks
from .system import SystemBus, VerilatorSystem, decode_uart

__all__ = ["EndToEndResult", "hardware_progress", "frames_to_still", "hold_still", "run_end_to_end",
           "clip_end_to_end"]

log = logging.getLogger(__name__)


@dataclass
class EndToEndResult:
    """What one end-to-end run saw (see the module docstring)."""
    recognised: str | None            #: last recognised gesture (None: nothing)
    telegram: bytes | None            #: the application's telegram for it
    uart_bytes: bytes                 #: bytes decoded from the UART TX pin
    results: list = field(default_factory=list)   #: every GestureResult, as dicts
    popped: list = field(default_factory=list)    #: raw (x, y) words read from the FIFO
    expected: list = field(default_factory=list)  #: the model's smoothed flagged points
    vga: np.ndarray | None = None     #: the captured VGA frame (active area)
    vga_expected: np.ndarray | None = None
    leds: int = 0
    cycles: int = 0
    seconds: float = 0.0
    stats: dict = field(default_factory=dict)
    #: the posture slave's last record as the application reads it, (seq, words)
    posture: tuple | None = None
    #: the model's record of the last frame and the frames played (its seq)
    posture_expected: tuple | None = None

    @property
    def posture_matches_model(self) -> bool | None:
        """The last frame's posture record through the SoC equals the model's
        (None: the model has none)."""
        if self.posture_expected is None:
            return None
        return self.posture == self.posture_expected

    @property
    def fifo_matches_model(self) -> bool:
        return self.popped == self.expected

    @property
    def vga_mismatches(self) -> int:
        if self.vga is None or self.vga_expected is None:
            return -1
        return int(np.count_nonzero(self.vga != self.vga_expected))

    @property
    def telegrams(self) -> bytes:
        """Every telegram the application sent, in order."""
        return b"".join(bytes.fromhex(r["telegram"]) for r in self.results
                        if r.get("sent") and r.get("telegram"))

    @property
    def recognised_all(self) -> list:
        """Every recognised gesture, in order."""
        return [r["class_name"] for r in self.results if r.get("outcome") == "recognised"]

    @property
    def uart_matches_telegram(self) -> bool:
        """The bytes on the UART pin are exactly the telegrams the application sent."""
        return self.uart_bytes == self.telegrams


class _Spotted:
    """A :class:`sw_hps.streaming.SpottedGesture` as the thesis application's
    results read (``recognised``, ``class_name``, ``telegram``, ``to_dict``)."""

    recognised = True

    def __init__(self, spotted):
        self.spotted = spotted
        self.class_name, self.telegram = spotted.class_name, spotted.telegram

    def to_dict(self) -> dict:
        return dict(self.spotted.to_dict(), outcome="recognised",
                    class_name=self.spotted.class_name)


def hardware_progress(frame: int, frames: int, cycles: int, seconds: float) -> str:
    """One progress line of a hardware run: frames done, simulated cycles per
    second of wall time and the time left at that rate."""
    rate = cycles / seconds if seconds > 0 else 0.0
    left = (frames - frame) * seconds / frame if frame > 0 else float("nan")
    eta = f"{left:.0f} s left" if left == left else "time left unknown"
    return (f"  hardware: frame {frame}/{frames}, {cycles:,} cycles, {rate:,.0f} cycles/s, "
            f"{eta}")


def frames_to_still(trajectory: Trajectory, params: PipelineParams, limit: int = 256) -> int:
    """How many repeats of the clip's last frame (the hand held still) end a
    gesture still flagged at the end of the clip: the hardware sees no more
    frames once the cameras stop, so its spotting flag would stay set.
    0 if the flag is already down."""
    if not len(trajectory.flag) or not trajectory.flag[-1]:
        return 0
    cents, areas = trajectory.centroid, trajectory.area
    for extra in range(1, limit + 1):
        longer = track(np.concatenate([cents, np.repeat(cents[-1:], extra, axis=0)]),
                       np.concatenate([areas, np.repeat(areas[-1:], extra)]), params)
        if not longer.flag[-1]:
            return extra
    raise ValueError(f"the spotting flag is still set after {limit} still frames")


def _still_postures(last: FrameStages, params: PipelineParams, extra: int) -> list:
    """The posture records of ``extra`` repeats of the frame whose stages are
    ``last``: its mask (windowed about its own centroid) described about the
    previous repeat's reference."""
    from sim.model.centroid import counted_pixels
    from sim.model.posture import posture_mask, posture_registers, posture_words
    mask = posture_mask(last.hand)
    if params.posture_gate:
        mask = counted_pixels(mask, previous=last.centroid, track_gate=params.posture_gate)
    records, stages = [], last
    for _ in range(extra):
        following = stages.following()
        registers = posture_registers(mask, following["reference"])
        stages = stages._replace(posture=registers, posture_reference=following["reference"],
                                 posture_previous=following["posture_previous"])
        records.append(posture_words(registers, following["reference"]))
    return records


def hold_still(left_frames, right_frames, trajectory: Trajectory, params: PipelineParams,
               last: FrameStages | None = None):
    """The clip with its last frame repeated :func:`frames_to_still` times, and
    the golden model's trajectory of it (repeated frames give the same
    centroid, so only the tracking is recomputed; the posture records, given
    the last frame's stages ``last``, too). Returns (left, right, trajectory,
    repeats)."""
    extra = frames_to_still(trajectory, params)
    if not extra:
        return left_frames, right_frames, trajectory, 0
    left = np.concatenate([left_frames, np.repeat(left_frames[-1:], extra, axis=0)])
    right = np.concatenate([right_frames, np.repeat(right_frames[-1:], extra, axis=0)])
    longer = track(np.concatenate([trajectory.centroid,
                                   np.repeat(trajectory.centroid[-1:], extra, axis=0)]),
                   np.concatenate([trajectory.area, np.repeat(trajectory.area[-1:], extra)]),
                   params,
                   None if trajectory.posture is None or last is None or last.posture is None
                   else np.concatenate([trajectory.posture,
                                        _still_postures(last, params, extra)]))
    return left, right, longer, extra


def run_end_to_end(left_frames, right_frames, models, trajectory: Trajectory,
                   last_stages: FrameStages | None, params: PipelineParams = PipelineParams(),
                   *, stage: str = "opening", clocks: Clocks = Clocks(),
                   poll_interval: float = 0.005, progress=None, exe=None,
                   rectification=None, vga_scale: int | None = None,
                   spotting: str = "thesis", posture_model=None) -> EndToEndResult:
    """Play a clip into the Verilated core and run the board application on it.

    Parameters
    ----------
    left_frames, right_frames : (F, H, 2W) uint8
        The camera frames (already held still at the end, see :func:`frames_to_still`).
    models : sw_hps.hmm.GestureModels
    trajectory : Trajectory
        The golden model's trajectory of the same frames.
    last_stages : FrameStages or None
        The golden model's stages of the last frame (for the VGA check).
    stage : str
        The VGA stage (SW[9:7]), one of ``hdl.gesture_pipeline.VIDEO_STAGES``.
    progress : callable, optional
        ``progress(text)`` for progress lines.
    exe : path, optional
        A prebuilt harness (:func:`verif.system.build_system`).
    rectification : sim.model.rectify.StereoRectification, optional
        The core rectifies with these maps (as the golden model did).
    vga_scale : int in [1, 2], optional
        Resolution of the core's VGA frame buffer (None:
        :data:`soc.frame_buffer.VGA_SCALE`); the model's picture is shown alike.
    spotting : "thesis" or "continuous"
        The application's spotting (``python -m sw_hps --spotting``):
        continuous runs :class:`sw_hps.streaming.StreamingApp` on the FIFO's
        streaming mode (every frame's record popped, compared word for word
        with :func:`sw_hps.simulated.streaming_words`), and names what is
        pending when the cameras have stopped and the FIFO is empty.
    posture_model : sw_hps.posture.PostureModel, optional
        The application then reads the posture slave as the board does
        (``--posture-model``) and its results name each gesture's posture.
    """
    from hdl.gesture_pipeline import VIDEO_STAGES, pipeline_timing
    from hdl.lrcc import disparity_bits
    from sim.model.vga import vga_frame
    from sw_hps.app import GestureApp, State
    from sw_hps.fifo import CTRL_FIFO_DATA, CTRL_NO_GESTURE, FifoPeripheral
    from sw_hps.robot import UartLink

    from soc.core import FRAME_BUFFER_BITS, UART_BASE, VGA_SCALE
    from soc.vga_timing import VGA_640x480_60

    if stage not in VIDEO_STAGES:
        raise ValueError(f"stage must be one of {list(VIDEO_STAGES)}, got {stage!r}")
    vga_scale = VGA_SCALE if vga_scale is None else vga_scale
    frames = len(left_frames)
    height, width = np.shape(left_frames)[1], np.shape(left_frames)[2] // 2
    timing = pipeline_timing(width, height, params, rectification)
    drain = timing.record_cycles + 8 * width
    if spotting not in ("thesis", "continuous"):
        raise ValueError(f"spotting must be 'thesis' or 'continuous', got {spotting!r}")
    if spotting == "continuous":
        from sw_hps.simulated import streaming_words
        expected = streaming_words(trajectory)
    else:
        expected = [(int(x), int(y)) for (x, y), f in zip(trajectory.smoothed, trajectory.flag)
                    if f]
    start = time.perf_counter()
    with VerilatorSystem(left_frames, right_frames, params, clocks=clocks,
                         stage=VIDEO_STAGES.index(stage),
                         log=progress, exe=exe, rectification=rectification,
                         vga_scale=vga_scale) as system:
        bus = SystemBus(system)
        # The app's timeouts run on the hardware's simulated time (a simulated frame
        # takes far longer than 33 ms of wall time), its frame is the clip's.
        tracker = None
        if posture_model is not None:
            from sw_hps.posture import PostureReader, PostureTracker
            tracker = PostureTracker(PostureReader(bus), posture_model)
        if spotting == "continuous":
            from sw_hps.streaming import StreamingApp
            app = StreamingApp(models, FifoPeripheral(bus), UartLink(bus, UART_BASE),
                               sleep=bus.sleep, poll_interval=poll_interval, frame_width=width,
                               posture=tracker)
        else:
            app = GestureApp(models, FifoPeripheral(bus), UartLink(bus, UART_BASE),
                             sleep=bus.sleep, poll_interval=poll_interval,
                             clock=lambda: system.cycles / clocks.sync_hz,
                             frame_width=width, frame_height=height, posture=tracker)
        done_at = [None]
        shown = [0]
        started = time.perf_counter()     # after the build: the rate is the simulation's

        def finished() -> bool:
            frame = system.cycles // timing.frame_cycles
            if progress is not None and frame >= shown[0] + 5 and not system.cameras_done:
                shown[0] = frame
                progress(hardware_progress(min(frame, frames), frames, system.cycles,
                                           time.perf_counter() - started))
            if not system.cameras_done:
                return False
            if done_at[0] is None:
                done_at[0] = system.cycles
            if spotting == "continuous":
                return (system.cycles - done_at[0] >= drain
                        and not bus.last_control & CTRL_FIFO_DATA)
            idle = (bus.last_control & CTRL_NO_GESTURE) and not (bus.last_control & CTRL_FIFO_DATA)
            return (system.cycles - done_at[0] >= drain and app.state is State.WAIT
                    and bool(idle))

        results = app.run(max_iterations=200 * frames + 10_000, until=finished)
        from sw_hps.posture import PostureReader
        posture = PostureReader(bus).read()       # the last frame's, as the board reads it
        if spotting == "continuous":            # the cameras stopped: name what is pending
            results = [_Spotted(r) for r in results + app.end_of_stream()]
            system.advance(0.002)               # the last telegram leaves the UART
        edges = system.uart_edges()
        vga = system.vga_frame()
        stats = system.close()
    seconds = time.perf_counter() - start
    recognised = [r for r in results if r.recognised]
    last = recognised[-1] if recognised else None
    vga_expected = None
    if last_stages is not None:
        mode = VGA_640x480_60
        picture = video_picture(last_stages, stage, disparity_bits(params.max_disparity))
        raster = vga_frame(picture, mode, pixel_bits=FRAME_BUFFER_BITS, scale=vga_scale)
        active = raster[..., 5].astype(bool)
        vga_expected = raster[..., 0][active].reshape(mode.v_active, mode.h_active)
    return EndToEndResult(
        recognised=last.class_name if last else None,
        telegram=last.telegram if last else None,
        uart_bytes=decode_uart(edges, 115200),
        results=[r.to_dict() for r in results], popped=bus.popped, expected=expected,
        vga=vga, vga_expected=vga_expected, leds=int(stats.get("leds", 0)),
        cycles=int(stats.get("cycles", 0)), seconds=seconds, stats=stats,
        posture=None if posture is None else (posture[0], [int(w) for w in posture[1]]),
        posture_expected=None if trajectory.posture is None else
        (frames & 0xFFFF, [int(w) for w in trajectory.posture[-1]]))



def clip_end_to_end(clip, models, params: PipelineParams, *, stage: str = "opening",
                    keep=(), threads=None, model_progress=None, progress=None, exe=None,
                    rectification=None, vga_scale: int | None = None,
                    spotting: str = "thesis", posture_model=None):
    """A rendered clip end to end: the golden model over every frame (keeping the
    stages of the frames in ``keep`` and of the last one), the hold-still
    extension, then :func:`run_end_to_end` (with ``spotting`` and
    ``posture_model``). Returns (model
    trajectory of the clip as played, kept stages, repeats of the last frame,
    EndToEndResult)."""
    from sim.model.pipeline import run_clip
    chosen = set(keep) | {clip.frames - 1}
    trajectory, kept = run_clip(clip.left, clip.right, params, keep=chosen.__contains__,
                                progress=model_progress, threads=threads,
                                rectification=rectification)
    left, right, played, extra = hold_still(clip.left, clip.right, trajectory, params,
                                            kept[clip.frames - 1])
    result = run_end_to_end(left, right, models, played, kept[clip.frames - 1], params,
                            stage=stage, progress=progress, exe=exe,
                            rectification=rectification, vga_scale=vga_scale,
                            spotting=spotting, posture_model=posture_model)
    return played, kept, extra, result
