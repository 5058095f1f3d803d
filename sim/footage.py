"""Footage as clips: two video files, image sequences or webcams through OpenCV,
converted to the cameras' YCbCr 4:2:2 byte stream (thesis §5.4, Table 11).

A source is one of

* a video file (whatever OpenCV's ``VideoCapture`` reads: AVI, MP4, ...);
* an image sequence: a folder of images, or a glob pattern (``'left_*.png'``),
  in name order;
* a camera index (``0``, ``1``: a USB webcam through ``cv2.VideoCapture``).
  Two cameras are read in lockstep (both ``grab()``, then both ``retrieve()``)
  so that a pair is as close in time as the cameras allow.

Each frame is resized to the clip size (``cv2.INTER_AREA``) and converted from
BGR to YCbCr with the full-range ITU-R BT.601 matrix of JPEG (JFIF), the one of
OpenCV's ``COLOR_BGR2YCrCb`` and of the Cb/Cr skin box the thesis uses:

    Y  =       0.299 R + 0.587 G + 0.114 B
    Cb = 128 + 0.564 (B - Y)
    Cr = 128 + 0.713 (R - Y)

in 14-bit fixed point rounded to nearest (:func:`bgr_to_ycbcr`), all three
planes 0..255; the 4:2:2 stream carries each pixel pair's mean chroma
(:func:`sim.model.ycbcr.ycbcr444_to_422`). The clip has no truth: no hand
positions, no motion span (:class:`sim.clip.Clip`).
"""
from __future__ import annotations

import glob
import math
from pathlib import Path

import numpy as np

from sim.clip import Clip
from sim.model.validation import check_int
from sim.model.ycbcr import ycbcr444_to_422
from sim.render import HEIGHT_RANGE, WIDTH_RANGE

__all__ = ["bgr_to_ycbcr", "frame_to_422", "frame_to_bgr", "FrameSource",
           "StereoSource", "footage_clip",
           "IMAGE_SUFFIXES", "WIDTH_RANGE", "HEIGHT_RANGE", "MAX_FRAMES", "CONVERSION"]

#: Image files an image-sequence folder is read from.
IMAGE_SUFFIXES = (".png", ".jpg", ".jpeg", ".bmp", ".tif", ".tiff", ".ppm", ".pgm", ".webp")
#: Frames one clip may hold (about 3 GB at 1280x720).
MAX_FRAMES = 1800
#: How the frames were converted, as recorded in ``clip.json`` (``source``).
CONVERSION = ("BGR -> YCbCr full-range ITU-R BT.601 (JFIF: Y = 0.299 R + 0.587 G + "
              "0.114 B, Cb = 128 + 0.564 (B - Y), Cr = 128 + 0.713 (R - Y)), 14-bit fixed "
              "point; 4:2:2 chroma = mean of each pixel pair")

# 14-bit fixed-point coefficients of the matrix above.
_SHIFT = 14
_R2Y, _G2Y, _B2Y = 4899, 9617, 1868          # 0.299, 0.587, 0.114 (sum 2**14)
_CR, _CB = 11682, 9241                        # 0.713, 0.564
_HALF = 1 << (_SHIFT - 1)


def bgr_to_ycbcr(bgr) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Full-range BT.601 Y, Cb, Cr planes (uint8) of an (H, W, 3) uint8 BGR image."""
    bgr = np.asarray(bgr)
    if bgr.ndim != 3 or bgr.shape[2] != 3 or bgr.dtype != np.uint8:
        raise ValueError(f"a frame must be an (H, W, 3) uint8 BGR image, got shape "
                         f"{bgr.shape} dtype {bgr.dtype}")
    b, g, r = (bgr[:, :, k].astype(np.int32) for k in range(3))
    y = (r * _R2Y + g * _G2Y + b * _B2Y + _HALF) >> _SHIFT
    cr = ((r - y) * _CR + (128 << _SHIFT) + _HALF) >> _SHIFT
    cb = ((b - y) * _CB + (128 << _SHIFT) + _HALF) >> _SHIFT
    return tuple(np.clip(v, 0, 255).astype(np.uint8) for v in (y, cb, cr))


def frame_to_422(bgr, width: int, height: int) -> np.ndarray:
    """One camera frame: ``bgr`` resized to ``width`` x ``height`` and packed as
    the (height, 2*width) YCbCr 4:2:2 byte stream."""
    import cv2
    bgr = np.asarray(bgr)
    if bgr.ndim == 2:                       # a grey image (PGM, a mono camera)
        bgr = np.repeat(bgr[:, :, None], 3, axis=2)
    if bgr.ndim == 3 and bgr.shape[2] == 4:    # BGRA
        bgr = bgr[:, :, :3]
    if bgr.dtype == np.uint16:                 # 16-bit PNG/TIFF
        bgr = (bgr >> 8).astype(np.uint8)
    if bgr.shape[:2] != (height, width):
        bgr = cv2.resize(bgr, (width, height), interpolation=cv2.INTER_AREA)
    return ycbcr444_to_422(*bgr_to_ycbcr(np.ascontiguousarray(bgr)))


def frame_to_bgr(frame) -> np.ndarray:
    """A (H, 2W) 4:2:2 camera frame as an (H, W, 3) BGR image (OpenCV's
    ``COLOR_YCrCb2BGR``, the inverse matrix; chroma repeated per pixel pair):
    to write a clip as video or show it."""
    import cv2
    from sim.model.ycbcr import ycbcr422_to_444
    y, cb, cr = ycbcr422_to_444(frame)
    return cv2.cvtColor(np.dstack([y, cr, cb]), cv2.COLOR_YCrCb2BGR)


class FrameSource:
    """Frames of one source (see the module docstring), read one at a time.

    Parameters
    ----------
    spec : str
        A video file, a folder of images, a glob pattern or a camera index.
    option : str
        The command-line option that named it (for messages).
    """

    def __init__(self, spec: str, option: str = "source"):
        import cv2
        self.spec, self.option = str(spec), option
        self.capture, self.files, self.camera = None, None, False
        self.fps = None
        text = self.spec.strip()
        path = Path(text)
        if text.isdigit():
            self.camera = True
            self.capture = cv2.VideoCapture(int(text))
            if not self.capture.isOpened():
                raise ValueError(f"{option}: camera {text} cannot be opened")
            self.kind = f"camera {text}"
        elif path.is_dir():
            self.files = sorted(p for p in path.iterdir()
                                if p.is_file() and p.suffix.lower() in IMAGE_SUFFIXES)
            if not self.files:
                raise ValueError(f"{option}: folder {text} holds no images "
                                 f"({', '.join(IMAGE_SUFFIXES)})")
            self.kind = f"{len(self.files)} images in {text}"
        elif any(ch in text for ch in "*?["):
            self.files = [Path(p) for p in sorted(glob.glob(text)) if Path(p).is_file()]
            if not self.files:
                raise ValueError(f"{option}: no file matches {text!r}")
            self.kind = f"{len(self.files)} images matching {text}"
        elif path.is_file():
            self.capture = cv2.VideoCapture(text)
            if not self.capture.isOpened():
                self.capture = None
                raise ValueError(f"{option}: {text} is not a video OpenCV can read")
            fps = self.capture.get(cv2.CAP_PROP_FPS)
            self.fps = int(round(fps)) if math.isfinite(fps) and 1 <= fps <= 1000 else None
            self.kind = f"video {text}"
        else:
            raise ValueError(f"{option}: {text!r} is not a video file, an image folder, a "
                             f"glob pattern or a camera index")
        self._next = 0

    def grab(self) -> bool:
        """Advance to the next frame (a camera latches it now); False at the end."""
        if self.files is not None:
            self._next += 1
            return self._next <= len(self.files)
        return bool(self.capture.grab())

    def retrieve(self) -> np.ndarray:
        """The frame :meth:`grab` advanced to, as a BGR (or grey) uint8 image."""
        import cv2
        if self.files is not None:
            path = self.files[self._next - 1]
            image = cv2.imread(str(path), cv2.IMREAD_UNCHANGED)
            if image is None:
                raise ValueError(f"{self.option}: {path} is not an image OpenCV can read")
            return image
        ok, image = self.capture.retrieve()
        if not ok or image is None:
            raise ValueError(f"{self.option}: {self.kind} returned no frame")
        return image

    def close(self) -> None:
        if self.capture is not None:
            self.capture.release()
            self.capture = None


class StereoSource:
    """Frame pairs of two sources as 4:2:2 camera frames (``width`` x
    ``height``), read in lockstep: both frames grabbed, then both decoded.

    Iterating yields ``(left, right)`` (H, 2W) uint8 pairs until either source
    ends or ``frames`` pairs are read (a camera never ends). Close it (or use it
    as a context manager) to release the cameras.
    """

    def __init__(self, left: str, right: str, *, width: int = 640, height: int = 480,
                 frames: int | None = None):
        check_int("--width", width, *WIDTH_RANGE)
        if width % 2:
            raise ValueError(f"--width must be even (4:2:2 pixel pairs), got {width}")
        check_int("--height", height, *HEIGHT_RANGE)
        if frames is not None:
            check_int("--frames", frames, 1, MAX_FRAMES)
        self.width, self.height, self.frames = width, height, frames
        self.sources = []
        try:
            self.sources.append(FrameSource(left, "--left"))
            self.sources.append(FrameSource(right, "--right"))
        except BaseException:
            self.close()
            raise
        #: the left video's own frame rate, if it has one
        self.fps = self.sources[0].fps
        self.camera = any(s.camera for s in self.sources)
        self.read = 0

    def __iter__(self):
        while self.frames is None or self.read < self.frames:
            if not all([s.grab() for s in self.sources]):     # grab both, then decode
                return
            pair = tuple(frame_to_422(s.retrieve(), self.width, self.height)
                         for s in self.sources)
            self.read += 1
            yield pair

    def more(self) -> bool:
        """Whether both sources have another frame (consumes it)."""
        return all([s.grab() for s in self.sources])

    def describe(self) -> dict:
        return {"left": self.sources[0].kind, "right": self.sources[1].kind,
                "conversion": CONVERSION}

    def close(self) -> None:
        for s in self.sources:
            s.close()

    def __enter__(self):
        return self

    def __exit__(self, *exc):
        self.close()


def footage_clip(left: str, right: str, *, width: int = 640, height: int = 480,
                 fps: int | None = None, frames: int | None = None,
                 gesture: str | None = None, progress=None) -> Clip:
    """A clip of two sources' frames, pair by pair, until either ends or
    ``frames`` pairs are read (required for cameras, which never end).

    Parameters
    ----------
    left, right : str
        Sources (see the module docstring), named ``--left`` / ``--right`` in errors.
    width, height : int
        Clip size: width even in :data:`WIDTH_RANGE`, height in :data:`HEIGHT_RANGE`.
    fps : int in [1, 1000], optional
        Frame rate; default the left video's own rate, else 30.
    frames : int in [1, MAX_FRAMES], optional
    gesture : str, optional
        A label for the clip (one of the gesture names).
    progress : callable(int), optional
        Called with the number of pairs read so far.
    """
    from sim.gesture_shapes import GESTURE_NAMES
    if fps is not None:
        check_int("--fps", fps, 1, 1000)
    if gesture is not None and gesture not in GESTURE_NAMES:
        raise ValueError(f"--gesture must be one of {', '.join(GESTURE_NAMES)}, got {gesture!r}")
    with StereoSource(left, right, width=width, height=height,
                      frames=MAX_FRAMES if frames is None else frames) as pairs:
        if frames is None and pairs.camera:
            raise ValueError("--frames is required with a camera (a camera never ends)")
        streams = ([], [])
        for left_frame, right_frame in pairs:
            streams[0].append(left_frame)
            streams[1].append(right_frame)
            if progress is not None:
                progress(len(streams[0]))
        if frames is None and len(streams[0]) == MAX_FRAMES and pairs.more():
            raise ValueError(f"--left/--right: more than {MAX_FRAMES} frames; choose a part "
                             f"with --frames")
        if not streams[0]:
            raise ValueError("--left/--right: no frame pair could be read")
        source = pairs.describe()
        rate = fps or pairs.fps or 30
    return Clip(fps=rate, left=np.stack(streams[0]), right=np.stack(streams[1]),
                gesture=gesture, source=source)
