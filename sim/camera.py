"""Pin-level model of an OV5642 camera (thesis §5.2, Fig. 25, Table 9).

The camera sends each frame as YCbCr 4:2:2 bytes, row by row (``Y0 Cb0 Y1 Cr0 ...``,
see :mod:`sim.model.ycbcr`), one byte per PCLK cycle, framed by two signals:

* VSYNC high = vertical blanking between frames (its rising edge ends a frame,
  its falling edge starts the next one);
* HREF high while a line's bytes are on the data bus, low between lines.

A byte is valid when VSYNC is low and HREF is high. :func:`camera_waveform` turns
frames into per-cycle ``vsync`` / ``href`` / ``data`` arrays, the fault injectors
damage a waveform the way a real link can (cut frame, HREF glitch, VSYNC inside a
line, camera silent for a frame period, PCLK stopped), :func:`pack_pins` flattens it for the
C++ Verilator harness, and :func:`capture_words` is the golden model of
:class:`hdl.camera_capture.CameraCapture`: the words it emits from a waveform.

Waveform layout (cycles)::

    start_delay   VSYNC high, HREF low            (idle before the first frame)
    per frame:    vsync_cycles  VSYNC high        (vertical blanking pulse)
                  front_porch   VSYNC low, HREF low
                  H lines of 2W bytes, HREF high, separated by hblank cycles HREF low
                  back_porch    VSYNC low, HREF low
    vsync_cycles  VSYNC high                      (closes the last frame)

Bytes on the bus outside valid cycles are a deterministic junk pattern, so a
receiver that samples them is caught by a bit-exact comparison.
"""
from __future__ import annotations

from dataclasses import dataclass, field, replace

import numpy as np

from .model.validation import check_image, check_int

__all__ = ["CameraTiming", "CameraWaveform", "camera_waveform", "cut_frame", "href_glitch",
           "vsync_in_line", "stop_frame", "stop_clock", "pack_pins", "CLOCK_STOPPED",
           "capture_words", "WORD_DTYPE"]

#: Upper bound of every timing field (cycles).
TIMING_MAX = 1 << 20


@dataclass(frozen=True)
class CameraTiming:
    """Blanking intervals of the camera waveform, in PCLK cycles (thesis Fig. 25).

    Attributes
    ----------
    vsync_cycles : int in [1, 2**20]
        Length of the VSYNC high pulse between frames.
    front_porch : int in [0, 2**20]
        Cycles from VSYNC falling to the first HREF rising edge.
    hblank : int in [1, 2**20]
        HREF-low cycles between two lines of a frame.
    back_porch : int in [0, 2**20]
        Cycles from HREF falling after the last line to VSYNC rising.
    """

    vsync_cycles: int = 16
    front_porch: int = 8
    hblank: int = 8
    back_porch: int = 8

    def __post_init__(self):
        check_int("vsync_cycles", self.vsync_cycles, 1, TIMING_MAX)
        check_int("front_porch", self.front_porch, 0, TIMING_MAX)
        check_int("hblank", self.hblank, 1, TIMING_MAX)
        check_int("back_porch", self.back_porch, 0, TIMING_MAX)

    def frame_cycles(self, width: int, height: int) -> int:
        """PCLK cycles of one frame period (VSYNC pulse included) for ``width``
        pixels (``2*width`` bytes) per line and ``height`` lines."""
        return (self.vsync_cycles + self.front_porch + height * 2 * width
                + (height - 1) * self.hblank + self.back_porch)


@dataclass
class CameraWaveform:
    """Per-PCLK-cycle camera pins and where each frame and line lies in them.

    Attributes
    ----------
    vsync, href : (n,) bool arrays
    data : (n,) uint8 array
    frames : (F, H, 2W) uint8, the frames the waveform was made of
    timing : CameraTiming
    start_delay : int
    vsync_start : (F,) int64, cycle where frame f's VSYNC pulse begins
    line_start : (F, H) int64, cycle of the first byte (Y0) of line l of frame f
    frame_end : (F,) int64, cycle after frame f's back porch (the next VSYNC pulse)
    faults : list of str, the faults injected so far (for messages)
    stopped : (n,) bool array or None
        Cycles in which PCLK does not rise (:func:`stop_clock`): the receiver
        sees nothing of them. None: the clock never stops.
    """

    vsync: np.ndarray
    href: np.ndarray
    data: np.ndarray
    frames: np.ndarray
    timing: CameraTiming
    start_delay: int
    vsync_start: np.ndarray
    line_start: np.ndarray
    frame_end: np.ndarray
    faults: list = field(default_factory=list)
    stopped: np.ndarray | None = None

    def __len__(self) -> int:
        return len(self.vsync)

    @property
    def width(self) -> int:
        """Pixels per line (half the bytes)."""
        return self.frames.shape[2] // 2

    @property
    def height(self) -> int:
        return self.frames.shape[1]

    @property
    def valid(self) -> np.ndarray:
        """Cycles carrying a pixel byte (VSYNC low and HREF high)."""
        return ~self.vsync & self.href

    def cycle(self, frame: int, line: int, byte: int = 0) -> int:
        """Cycle of byte ``byte`` of line ``line`` of frame ``frame``."""
        frame, line, byte = self._check_position(frame, line, byte)
        return int(self.line_start[frame, line]) + byte

    def _check_position(self, frame, line=0, byte=0):
        frame = check_int("frame", frame, 0, len(self.frames) - 1)
        line = check_int("line", line, 0, self.height - 1)
        byte = check_int("byte", byte, 0, 2 * self.width - 1)
        return frame, line, byte

    def _damaged(self, what: str) -> "CameraWaveform":
        return replace(self, vsync=self.vsync.copy(), href=self.href.copy(),
                       data=self.data.copy(), faults=self.faults + [what],
                       stopped=(np.zeros(len(self), bool) if self.stopped is None
                                else self.stopped.copy()))


def _check_frames(frames) -> np.ndarray:
    if isinstance(frames, np.ndarray) and frames.ndim == 3:
        stack = list(frames)
    elif isinstance(frames, np.ndarray) and frames.ndim == 2:
        stack = [frames]
    else:
        stack = list(frames)
    if not stack:
        raise ValueError("frames must hold at least one frame")
    checked = [check_image(f"frames[{k}]", f, dtype_kind="u", max_value=255, min_shape=(1, 4))
               for k, f in enumerate(stack)]
    shape = checked[0].shape
    for k, f in enumerate(checked):
        if f.shape != shape:
            raise ValueError(f"frames must share one shape, frames[0] is {shape} and "
                             f"frames[{k}] is {f.shape}")
    if shape[1] % 4:
        raise ValueError(f"frame row length must be a multiple of 4 bytes (Y Cb Y Cr per "
                         f"pixel pair), got {shape[1]}")
    return np.stack(checked).astype(np.uint8)


def _junk(n: int) -> np.ndarray:
    """Deterministic bytes for the bus outside valid cycles."""
    return ((np.arange(n, dtype=np.int64) * 73 + 41) % 251).astype(np.uint8)


def camera_waveform(frames, timing: CameraTiming = CameraTiming(),
                    start_delay: int = 0) -> CameraWaveform:
    """Camera pins, cycle by cycle, sending ``frames`` (thesis Fig. 25).

    Parameters
    ----------
    frames : (F, H, 2W) array or sequence of (H, 2W) arrays of bytes
        4:2:2 frames as in :func:`sim.model.ycbcr.ycbcr444_to_422`; ``2W`` a
        multiple of 4.
    timing : CameraTiming
    start_delay : int in [0, 2**24]
        Idle cycles (VSYNC high) before the first frame's VSYNC pulse, so the two
        cameras of a stereo pair can start apart.

    Returns
    -------
    CameraWaveform
    """
    frames = _check_frames(frames)
    if not isinstance(timing, CameraTiming):
        raise ValueError(f"timing must be a CameraTiming, got {type(timing).__name__}")
    start_delay = check_int("start_delay", start_delay, 0, 1 << 24)
    count, height, row_bytes = frames.shape
    period = timing.frame_cycles(row_bytes // 2, height)
    n = start_delay + count * period + timing.vsync_cycles
    vsync = np.ones(n, dtype=bool)
    href = np.zeros(n, dtype=bool)
    data = _junk(n)
    vsync_start = np.empty(count, dtype=np.int64)
    line_start = np.empty((count, height), dtype=np.int64)
    frame_end = np.empty(count, dtype=np.int64)
    t = start_delay
    for f in range(count):
        vsync_start[f] = t
        t += timing.vsync_cycles
        body = period - timing.vsync_cycles
        vsync[t:t + body] = False
        t += timing.front_porch
        for line in range(height):
            line_start[f, line] = t
            href[t:t + row_bytes] = True
            data[t:t + row_bytes] = frames[f, line]
            t += row_bytes + (timing.hblank if line < height - 1 else 0)
        t += timing.back_porch
        frame_end[f] = t
    assert t + timing.vsync_cycles == n
    return CameraWaveform(vsync, href, data, frames, timing, start_delay,
                          vsync_start, line_start, frame_end)


# ------------------------------------------------------------------ fault injection


def cut_frame(wave: CameraWaveform, frame: int, line: int) -> CameraWaveform:
    """VSYNC rises at the start of line ``line`` of ``frame``: the rest of the frame is
    lost (VSYNC high, HREF low up to the next frame's VSYNC pulse, which keeps its
    schedule)."""
    frame, line, _ = wave._check_position(frame, line)
    out = wave._damaged(f"cut_frame(frame={frame}, line={line})")
    lo, hi = int(wave.line_start[frame, line]), int(wave.frame_end[frame])
    out.vsync[lo:hi] = True
    out.href[lo:hi] = False
    return out


def href_glitch(wave: CameraWaveform, frame: int, line: int, byte: int) -> CameraWaveform:
    """HREF low for the one cycle of byte ``byte`` of a line (that byte is lost)."""
    c = wave.cycle(frame, line, byte)
    out = wave._damaged(f"href_glitch(frame={frame}, line={line}, byte={byte})")
    out.href[c] = False
    return out


def vsync_in_line(wave: CameraWaveform, frame: int, line: int, byte: int,
                  length: int = 3) -> CameraWaveform:
    """VSYNC high for ``length`` cycles from byte ``byte`` of a line, HREF staying
    high (those bytes are lost; the line then goes on)."""
    c = wave.cycle(frame, line, byte)
    length = check_int("length", length, 1, 2 * wave.width - byte)
    out = wave._damaged(f"vsync_in_line(frame={frame}, line={line}, byte={byte}, "
                        f"length={length})")
    out.vsync[c:c + length] = True
    return out


def stop_frame(wave: CameraWaveform, frame: int) -> CameraWaveform:
    """The camera sends nothing for the whole period of ``frame``: VSYNC stays high and
    HREF low from its VSYNC pulse to the next one."""
    frame, _, _ = wave._check_position(frame)
    out = wave._damaged(f"stop_frame(frame={frame})")
    lo, hi = int(wave.vsync_start[frame]), int(wave.frame_end[frame])
    out.vsync[lo:hi] = True
    out.href[lo:hi] = False
    return out


def stop_clock(wave: CameraWaveform, cycle: int, length: int) -> CameraWaveform:
    """PCLK stops for ``length`` cycles from ``cycle`` (held low; the pins keep
    their schedule, so what the camera sent meanwhile is lost), then runs again."""
    cycle = check_int("cycle", cycle, 0, len(wave) - 1)
    length = check_int("length", length, 1, len(wave) - cycle)
    out = wave._damaged(f"stop_clock(cycle={cycle}, length={length})")
    out.stopped[cycle:cycle + length] = True
    return out


#: Bit of a packed pin sample (:func:`pack_pins`) set when PCLK does not rise.
CLOCK_STOPPED = 1 << 15


def pack_pins(wave: CameraWaveform) -> np.ndarray:
    """Pins of each cycle as one uint16: ``(vsync << 9) | (href << 8) | data``,
    with :data:`CLOCK_STOPPED` in the cycles where PCLK stops."""
    pins = ((wave.vsync.astype(np.uint16) << 9) | (wave.href.astype(np.uint16) << 8)
            | wave.data.astype(np.uint16))
    if wave.stopped is not None:
        pins |= wave.stopped.astype(np.uint16) << 15
    return pins


# ------------------------------------------------------------------ capture model

#: One captured word (see :func:`capture_words`).
WORD_DTYPE = np.dtype([("sof", np.uint8), ("sol", np.uint8), ("luma", np.uint8),
                       ("chroma", np.uint8), ("x", np.int32), ("y", np.int32),
                       ("cycle", np.int64)])


def capture_words(wave: CameraWaveform, width: int, height: int) -> np.ndarray:
    """Golden model of :class:`hdl.camera_capture.CameraCapture`: the words it emits
    from ``wave`` with ``start`` high, ``pause`` low and the output always ready.

    Rules (thesis §5.2, Table 9):

    * a frame starts on the first VSYNC-low cycle after a VSYNC-high cycle whose HREF
      was low (a VSYNC pulse inside a line is not a frame boundary); it ends on any
      VSYNC-high cycle;
    * inside a frame, HREF rising starts a line (byte phase 0, x = 0; the line index
      y counts HREF rising edges from 0); phase 0 is luma, phase 1 chroma; each phase-1
      byte completes the word of pixel x (then x += 1); HREF falling between the two
      bytes of a pair drops the lone luma byte;
    * words with x >= width or y >= height are not emitted (crop);
    * cycles where PCLK stops (``wave.stopped``) do not exist for the receiver.

    Returns
    -------
    (n,) array of :data:`WORD_DTYPE`: ``sof = (x == 0 and y == 0)``, ``sol = (x == 0)``,
    the two bytes, the pixel position and the cycle of the chroma byte.
    """
    width = check_int("width", width, 1)
    height = check_int("height", height, 1)
    words = []
    seen = active = False
    prev_href = False
    phase = x = y = lines = 0
    luma = 0
    stopped = wave.stopped.tolist() if wave.stopped is not None else [False] * len(wave)
    for c, (v, h, d, off) in enumerate(zip(wave.vsync.tolist(), wave.href.tolist(),
                                           wave.data.tolist(), stopped)):
        if off:
            continue
        if v:
            active = False
            seen = not h
        else:
            if seen:
                active, lines = True, 0
            seen = False
        if active and h:
            if not prev_href:  # HREF rising: a new line
                x, y, lines = 0, lines, min(lines + 1, height)
                luma, phase = d, 1
            elif phase == 0:
                luma, phase = d, 1
            else:
                if x < width and y < height:
                    words.append((int(x == 0 and y == 0), int(x == 0), luma, d, x, y, c))
                x, phase = min(x + 1, width), 0
        else:
            phase = 0
        prev_href = h
    return np.array(words, dtype=WORD_DTYPE)
