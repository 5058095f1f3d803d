"""Synthetic stereo scene renderer: a person performing one of the seven gestures.

The scene imitates the set-up of the thesis (Guerrero-Balaguera 2016): two
parallel cameras looking at a person whose hand, held in front of the chest,
draws a gesture (Fig. 16) with an amplitude of about 200 px at 640x480
(Fig. 77). It is a stack of fronto-parallel layers, each with one integer
disparity, rendered separately for the two cameras and composed back to front
(larger disparity = nearer = drawn later)::

    layer        disparity (px)  colour                      why
    background   4..10 (seeded)  textured, mostly non-skin   far wall
    hair         = face          dark, non-skin              top of the head
    face (+neck) 24              skin, textured ellipse      skin but OUTSIDE the band 33 < d < 46
    torso        28              non-skin clothing, textured the hand's backdrop
    hand         40              skin, textured palm+fingers skin AND inside the band

A left-image point ``x`` of a layer with disparity ``d`` appears at ``x - d`` in
the right image (the matcher's convention). Every layer is textured at several
scales, because the census matcher needs texture; the hand's texture is fixed
to the hand, so it moves rigidly and both cameras see the same pattern.

The cameras differ by independent Gaussian noise (sigma 2 on Y, 1 on chroma,
added, rounded, to the 4:2:2 byte stream) and a small illumination difference
(right camera ``Y' = 0.96 Y + 3``). The hand is kept entirely inside both views
(its left edge at least ``hand_disparity + 4`` px from the image's left edge);
when the seeded amplitude does not fit (e.g. ``back`` at 640x480) the rest
position moves, and the amplitude shrinks only if that is not enough.

Geometry scales with ``min(width / 640, height / 480)``; disparities do not,
because the segmentation thresholds are in pixels.

Randomness: the scene (person, clothes, textures, background disparity) depends
on ``seed`` only, so one seed is one "person and room" for all seven gestures;
the timing, amplitude (+-15 %), aspect, time warp and rest position depend on
``(seed, gesture)``; the sensor noise on ``(seed, gesture, frame)``.
"""
from __future__ import annotations

import functools
import math
from dataclasses import dataclass
from statistics import NormalDist
from typing import NamedTuple

import numpy as np

from sim.clip import MAX_DISPARITY, Clip, round_truth
from sim.difficulties import Difficulties, camera_gains
from sim.distractors import (COMMAND_SHARE, DISTRACTOR_KINDS, check_kind, distractor_hands,
                             distractor_motion)
from sim.gesture_shapes import GESTURE_NAMES, gesture_id, gesture_path, random_time_warp
from sim.hand_postures import (COMMAND_POSTURE, DEFAULT_POSTURE, FINGERS, HAND_SHAPES,
                               ROLL_RANGE, resolve_hand, resolve_posture)
from sim.model.validation import check_int
from sim.model.ycbcr import ycbcr444_to_422

__all__ = [
    "REFERENCE_WIDTH", "REFERENCE_HEIGHT", "LAYER_LABELS", "NOISE_SIGMA_Y",
    "NOISE_SIGMA_C", "RIGHT_Y_GAIN", "RIGHT_Y_OFFSET", "StereoScene", "render_clip",
    "render_sequence", "SEQUENCE_LEAD", "SEQUENCE_TAIL", "DistractorScene", "render_scene",
    "WIDTH_RANGE", "HEIGHT_RANGE", "MAX_SEGMENT_FRAMES",
]

REFERENCE_WIDTH, REFERENCE_HEIGHT = 640, 480
#: Layer id of each pixel in :meth:`StereoScene.label_map`.
LAYER_LABELS = {"background": 0, "torso": 1, "hair": 2, "face": 3, "hand": 4, "forearm": 5,
                "clutter": 6, "intruder": 7}
NOISE_SIGMA_Y = 2.0
NOISE_SIGMA_C = 1.0
RIGHT_Y_GAIN = 0.96
RIGHT_Y_OFFSET = 3.0

_AMPLITUDE_PX = 200.0          # at the reference size (thesis Fig. 77)
_AMPLITUDE_SPREAD = 0.15
_EDGE_MARGIN_PX = 4            # hand kept this far inside the image (and the right view)
#: Most frames a clip's rest or motion segment may be given (render_clip's n_*).
MAX_SEGMENT_FRAMES = 10000
#: Frame sizes the renderer draws (both even: 4:2:2 pixel pairs); footage
#: (sim.footage) and the commands that render use the same.
WIDTH_RANGE = (96, 4096)
HEIGHT_RANGE = (64, 4096)
_PRE_REST_S = (0.5, 1.0)       # 15-30 frames at 30 fps
_MOTION_S = (40 / 30, 80 / 30)  # 40-80 frames at 30 fps
_TIME_WARP_STRENGTH = 0.1
_ASPECT_RANGE = (0.9, 1.1)

# Independent random streams (SeedSequence entropy words).
_STREAM_LAYOUT, _STREAM_BACKGROUND, _STREAM_TORSO, _STREAM_FACE, _STREAM_HAND = range(1, 6)
_STREAM_MOTION, _STREAM_NOISE, _STREAM_EXPOSURE, _STREAM_FOREARM = 6, 7, 8, 9
_STREAM_CLUTTER, _STREAM_INTRUDER, _STREAM_SEQUENCE = 10, 11, 12
_STREAM_DISTRACTOR = 13
_STREAM_POSTURE, _STREAM_ROLL, _STREAM_HANDS = 14, 15, 16
#: Most a hand's roll changes from one frame to the next, and from the clip's.
_ROLL_STEP, _ROLL_WOBBLE = 1, 3
#: ``gesture_id`` of a distractor scene's random streams: this plus its index
#: (apart from the gestures' 0..6).
_DISTRACTOR_ID = 1000
#: First noise/exposure id of a held posture (:class:`HoldScene`): apart from the distractors.
_HOLD_ID = 70000
#: The intruder ball (reference px radius), its disparity below the hand's.
_INTRUDER_RADIUS, _INTRUDER_BELOW_HAND = 26.0, 2
#: Forearm (reference px): radius, wrist below the palm centre, segments of one
#: disparity each, the sleeve's share of the length.
_FOREARM_RADIUS, _WRIST_BELOW, _FOREARM_SEGMENTS, _SLEEVE_SHARE = 15.0, 20.0, 12, 1 / 3
#: Sub-positions the hand is averaged over with motion blur.
_BLUR_SAMPLES = 7

# Clothing colours (Cb, Cr, mean Y): every one fails the skin box (Cr < 133 or Cb > 127).
_SHIRT_PALETTE = ((150, 112, 90), (112, 104, 110), (128, 124, 70), (142, 100, 120),
                  (138, 118, 55), (156, 128, 100))
# Furniture / poster colours on the wall, also outside the skin box.
_WALL_PALETTE = ((128, 128), (140, 110), (115, 100), (150, 120), (120, 126), (135, 95),
                 (100, 118))

_SKIN_CB, _SKIN_CR = (92, 116), (141, 165)   # well inside the box Cb 77..127, Cr 133..173


# --------------------------------------------------------------------------- textures

def _noise_field(rng: np.random.Generator, height: int, width: int, cell: float) -> np.ndarray:
    """Smooth random field with features of about ``cell`` pixels, unit std, float32.

    Value noise: normal samples on a grid of pitch ``cell`` (random phase),
    interpolated with a smoothstep; ``cell <= 1`` gives white noise.
    """
    if cell <= 1.0:
        return rng.standard_normal((height, width), dtype=np.float32)
    phase_y, phase_x = rng.uniform(0.0, cell, size=2)
    pos_y = (np.arange(height) + phase_y) / cell
    pos_x = (np.arange(width) + phase_x) / cell
    iy, ix = pos_y.astype(np.int64), pos_x.astype(np.int64)
    fy, fx = pos_y - iy, pos_x - ix
    fy, fx = fy * fy * (3 - 2 * fy), fx * fx * (3 - 2 * fx)
    coarse = rng.standard_normal((iy[-1] + 2, ix[-1] + 2))
    rows = coarse[iy] * (1 - fy)[:, None] + coarse[iy + 1] * fy[:, None]
    field = rows[:, ix] * (1 - fx) + rows[:, ix + 1] * fx
    field -= field.mean()
    std = field.std()
    return (field / std if std > 0 else field).astype(np.float32)


def _fractal(rng: np.random.Generator, height: int, width: int, scale: float,
             cells: tuple[float, ...], weights: tuple[float, ...]) -> np.ndarray:
    """Weighted sum of noise fields; ``cells`` are in reference pixels (scaled by ``scale``)."""
    out = np.zeros((height, width), dtype=np.float32)
    for cell, weight in zip(cells, weights):
        out += np.float32(weight) * _noise_field(rng, height, width, max(1.0, cell * scale))
    return out


def _ellipse(xs, ys, cx, cy, ax, ay) -> np.ndarray:
    """Normalised squared radius of points w.r.t. an axis-aligned ellipse (<= 1 inside)."""
    return ((xs - cx) / ax) ** 2 + ((ys - cy) / ay) ** 2


def _segment_distance(xs, ys, x0, y0, x1, y1) -> tuple[np.ndarray, np.ndarray]:
    """Distance of points to the segment (x0,y0)-(x1,y1) and the position t along it."""
    dx, dy = x1 - x0, y1 - y0
    t = np.clip(((xs - x0) * dx + (ys - y0) * dy) / (dx * dx + dy * dy), 0.0, 1.0)
    return np.hypot(xs - (x0 + t * dx), ys - (y0 + t * dy)), t


_NOISE_TABLE_SIZE = 1 << 16


@functools.lru_cache(maxsize=None)
def _rounded_gaussian_table(sigma: float) -> np.ndarray:
    """Inverse-CDF table of ``rint(sigma * z)``, ``z`` standard normal.

    Entry ``i`` is the value of the rounded Gaussian at probability
    ``(i + 0.5) / 65536``, so a uniform 16-bit index draws the rounded noise
    (tails cut at about 4.2 sigma).
    """
    if sigma <= 0:
        return np.zeros(_NOISE_TABLE_SIZE, np.int16)
    dist = NormalDist(0.0, sigma)
    k_max = math.ceil(6 * sigma) + 1
    values = np.arange(-k_max, k_max + 1)
    upper = np.array([dist.cdf(k + 0.5) for k in values])   # P(rint(sigma z) <= k)
    probability = (np.arange(_NOISE_TABLE_SIZE) + 0.5) / _NOISE_TABLE_SIZE
    index = np.minimum(np.searchsorted(upper, probability), values.size - 1)
    table = values[index].astype(np.int16)
    table.flags.writeable = False
    return table


def _right_luma(luma):
    """The right camera's Y for the left camera's (its illumination difference)."""
    return RIGHT_Y_GAIN * luma + RIGHT_Y_OFFSET


def _to_u8(values: np.ndarray) -> np.ndarray:
    return np.clip(np.rint(values), 0, 255).astype(np.uint8)


# ----------------------------------------------------------------------------- layers

class _Sprite(NamedTuple):
    """The hand as drawn: mask, the two cameras' (Y, Cb, Cr) planes, and the
    offset (y, x) of its top-left pixel from the palm centre."""
    mask: np.ndarray
    left: np.ndarray
    right: np.ndarray
    offset: tuple


def _turn(mask, ycc, centre, degrees):
    """``mask`` (h, w) and ``ycc`` (3, h, w) turned by ``degrees`` anticlockwise
    as seen (y down) about ``centre`` (row, column), nearest pixel, same size."""
    h, w = mask.shape
    angle = math.radians(degrees)
    ys, xs = np.mgrid[0:h, 0:w].astype(np.float64)
    dy, dx = ys - centre[0], xs - centre[1]
    # the source of each output pixel: the inverse turn
    src_x = np.rint(centre[1] + math.cos(angle) * dx - math.sin(angle) * dy).astype(np.int64)
    src_y = np.rint(centre[0] + math.sin(angle) * dx + math.cos(angle) * dy).astype(np.int64)
    inside = (src_x >= 0) & (src_x < w) & (src_y >= 0) & (src_y < h)
    sx, sy = np.clip(src_x, 0, w - 1), np.clip(src_y, 0, h - 1)
    return mask[sy, sx] & inside, ycc[:, sy, sx]


class _Intruder(NamedTuple):
    """The intruder ball: radius, centre x per frame (NaN out of view), centre y,
    disparity and texture."""
    radius: float
    x: np.ndarray
    y: float
    disparity: int
    texture: np.ndarray


@dataclass
class _Layer:
    """A fronto-parallel layer in left-image coordinates (a bounding box of it)."""

    name: str
    disparity: int
    y0: int
    x0: int
    mask: np.ndarray           # (h, w) bool
    ycc: np.ndarray            # (3, h, w) float32: Y, Cb, Cr

    @property
    def label(self) -> int:
        return LAYER_LABELS[self.name]


class StereoScene:
    """A rendered-on-demand stereo scene of one gesture (see the module docstring).

    Parameters
    ----------
    gesture : str
        One of :data:`sim.gesture_shapes.GESTURE_NAMES`.
    seed : int in [0, 2**63 - 1]
    width : even int in [96, 4096]
    height : even int in [64, 4096]
    fps : int in [5, 240]
        Frame rate; the seeded durations (pre-rest 0.5-1 s, motion 1.33-2.67 s,
        post-rest 0.5-1 s, i.e. 15-30 / 40-80 / 15-30 frames at 30 fps) scale with it.
    hand_disparity, face_disparity, torso_disparity : int in [0, 47]
    background_disparity : int in [0, 47] or None
        ``None``: seeded in [4, 10].
    n_pre_rest, n_motion, n_post_rest : int or None
        Frame counts overriding the seeded ones (``n_motion >= 2``; the rests may be 0).
    noise : bool
        Add the sensor noise in :meth:`stereo_frame`.
    difficulties : sim.difficulties.Difficulties, optional
        Exposure drift and flicker, motion blur, skin tone, camera misalignment
        (all off by default: the easy scene, bit for bit).

    Attributes
    ----------
    frames : int
    motion_span : (int, int)
        First and last (inclusive) frame of the motion.
    hand_anchor : (frames, 2) int64
        Palm centre ``(x, y)`` of the hand in the left image, per frame.
    hand_disparities : (frames,) int64
        The hand's disparity per frame (``hand_disparity`` but in a ``depth``
        distractor, :class:`DistractorScene`).
    amplitude : float
        Gesture amplitude in pixels (may be reduced so that the hand stays in view).
    rest : (float, float)
        Rest position of the palm centre.
    disparities : dict
        Layer name -> disparity.

    Notes
    -----
    The static layers are composed once per camera; each frame only pastes the
    hand, which sits at integer pixel positions (so its texture moves rigidly and
    its truth centroid is exact). Every frame can be rendered on its own
    (:meth:`stereo_frame`), and the noise-free views (:meth:`views444`), the
    per-pixel layer labels (:meth:`label_map`) and the true disparity maps
    (:meth:`disparity_map`) serve as ground truth for the stereo and
    segmentation stages.
    """

    def __init__(self, gesture: str, seed: int, width: int = REFERENCE_WIDTH,
                 height: int = REFERENCE_HEIGHT, *, fps: int = 30, hand_disparity: int = 40,
                 face_disparity: int = 24, torso_disparity: int = 28,
                 background_disparity: int | None = None, n_pre_rest: int | None = None,
                 n_motion: int | None = None, n_post_rest: int | None = None,
                 noise: bool = True, difficulties: Difficulties | None = None,
                 posture: str | None = None, roll: int | None = None) -> None:
        if difficulties is not None and not isinstance(difficulties, Difficulties):
            raise ValueError(f"difficulties must be a sim.difficulties.Difficulties, got "
                             f"{type(difficulties).__name__}")
        self.difficulties = difficulties or Difficulties()
        self.gesture_id = gesture_id(gesture)
        self.gesture = gesture
        self.seed = check_int("seed", seed, 0, 2 ** 63 - 1)
        self.width = check_int("width", width, *WIDTH_RANGE)
        self.height = check_int("height", height, *HEIGHT_RANGE)
        if self.width % 2:
            raise ValueError(f"width must be even, in [{WIDTH_RANGE[0]}, {WIDTH_RANGE[1]}] "
                             f"(4:2:2 pixel pairs), got {width}")
        if self.height % 2:
            raise ValueError(f"height must be even, in [{HEIGHT_RANGE[0]}, {HEIGHT_RANGE[1]}], "
                             f"got {height}")
        self.fps = check_int("fps", fps, 5, 240)
        top = MAX_DISPARITY - 1
        self.disparities = {
            "hand": check_int("hand_disparity", hand_disparity, 0, top),
            "face": check_int("face_disparity", face_disparity, 0, top),
            "torso": check_int("torso_disparity", torso_disparity, 0, top),
        }
        self.noise = bool(noise)
        self.scale = min(self.width / REFERENCE_WIDTH, self.height / REFERENCE_HEIGHT)

        layout = self._rng(_STREAM_LAYOUT)
        if background_disparity is None:
            background_disparity = int(layout.integers(4, 11))
        self.disparities["background"] = check_int("background_disparity",
                                                    background_disparity, 0, top)
        self.disparities["hair"] = self.disparities["face"]
        self._layout(layout)

        self.posture = None if posture is None else resolve_hand(posture)
        self._roll = None if roll is None else check_int("roll", roll, *ROLL_RANGE)
        if self.posture is None and roll is not None:
            raise ValueError("roll needs a posture (the open hand of a clip without one "
                             "is drawn upright)")
        self._build_hand_sprite()
        self._plan_motion(n_pre_rest, n_motion, n_post_rest)
        self._plan_rolls()
        self._build_static_layers()
        hard = self.difficulties
        self._gains = camera_gains(hard, self.frames, self._rng(_STREAM_EXPOSURE,
                                                                 self.gesture_id)) \
            if hard.exposure_drift or hard.flicker else None
        if hard.forearm:
            self._build_forearm()
        self._intruder = None
        if hard.intruder:
            self._plan_intruder()
        self._rig = None
        if hard.misaligned:
            from sim.calibration import StereoRig, rig_calibration
            self._rig = rig_calibration(StereoRig().resized(self.width, self.height))

    # ---------------------------------------------------------------- set-up

    def _rng(self, *words: int) -> np.random.Generator:
        return np.random.default_rng([self.seed, *words])

    def _layout(self, rng: np.random.Generator) -> None:
        """Where the person stands (reference proportions, seeded jitter)."""
        s, w, h = self.scale, self.width, self.height
        self.person_x = w / 2 + rng.uniform(-12, 12) * s
        self.face_center = (self.person_x + rng.uniform(-4, 4) * s,
                            0.23 * h + rng.uniform(-6, 6) * s)
        self.face_axes = (rng.uniform(46, 54) * s, rng.uniform(60, 68) * s)
        self.shoulder_y = 0.42 * h + rng.uniform(-6, 6) * s
        self.torso_half_width = rng.uniform(150, 185) * s
        self.chest = (self.person_x + rng.uniform(-20, 20) * s,
                      0.66 * h + rng.uniform(-12, 12) * s)

    def _build_hand_sprite(self) -> None:
        """The hand's sprites: without a posture one, today's open hand, for every
        frame; with one, a sprite per roll the clip shows (built on demand), and
        a square about the palm centre that holds all of them for planning."""
        if self.posture is None:
            self.roll = 0
            self._hand_sprite = self._draw_hand(None, 0)
            self._sprite_offset = self._hand_sprite.offset
            self._sprite_mask = self._hand_sprite.mask
            sprite = self._hand_sprite
        else:
            rng = self._rng(_STREAM_POSTURE)
            s = self.scale * self.difficulties.hand_scale
            # the person: palm size, finger length and width, skin tone
            self._person = {"palm": float(rng.uniform(0.92, 1.08)),
                            "length": float(rng.uniform(0.88, 1.12)),
                            "width": float(rng.uniform(0.85, 1.15)),
                            "cb": float(rng.uniform(-6, 6)), "cr": float(rng.uniform(-6, 6))}
            self.roll = int(rng.integers(ROLL_RANGE[0], ROLL_RANGE[1] + 1)) \
                if self._roll is None else self._roll
            self._sprites = {}
            radius = int(math.ceil(76 * s * 1.12)) + 2
            self._sprite_offset = (-radius, -radius)
            self._sprite_mask = np.ones((2 * radius + 1, 2 * radius + 1), bool)
            sprite = self._draw_hand(self.posture, self.roll)
        rows, cols = np.nonzero(sprite.mask)
        self.hand_size = (int(cols.max() - cols.min() + 1), int(rows.max() - rows.min() + 1))

    def _plan_rolls(self) -> None:
        """Per frame, the hand's roll in degrees: the clip's, wandering by at most
        ``_ROLL_STEP`` a frame and ``_ROLL_WOBBLE`` from it (0 without a posture);
        and the hand's shape (:attr:`hand_shapes`: the posture, unless the
        motion planned its own)."""
        if getattr(self, "hand_shapes", None) is None:
            self.hand_shapes = (self.posture,) * self.frames
        self.hand_rolls = np.zeros(self.frames, np.int64)
        if self.posture is None:
            return
        rng = self._rng(_STREAM_ROLL, self.gesture_id)
        wobble = 0
        for frame in range(self.frames):
            wobble = int(np.clip(wobble + rng.integers(-_ROLL_STEP, _ROLL_STEP + 1),
                                 -_ROLL_WOBBLE, _ROLL_WOBBLE))
            self.hand_rolls[frame] = self.roll + wobble

    def _sprite(self, frame: int) -> "_Sprite":
        """The hand's sprite in ``frame``."""
        if self.posture is None:
            return self._hand_sprite
        key = (self.hand_shapes[frame], int(self.hand_rolls[frame]))
        if key not in self._sprites:
            self._sprites[key] = self._draw_hand(*key)
        return self._sprites[key]

    def _draw_hand(self, posture: str | None, roll: int) -> "_Sprite":
        """Palm, four fingers and a thumb (a right hand, palm to the cameras), ~80 px
        tall (times ``hand_scale``): the open hand without ``posture``, else that
        posture of :data:`sim.hand_postures.POSTURES` with the person's
        proportions, turned by ``roll`` degrees (anticlockwise as seen)."""
        s = self.scale * self.difficulties.hand_scale
        rng = self._rng(_STREAM_HAND)
        if posture is None:
            x_lo, x_hi = math.floor(-42 * s) - 1, math.ceil(32 * s) + 1
            y_lo, y_hi = math.floor(-60 * s) - 1, math.ceil(26 * s) + 1
            palm_size = length_k = width_k = 1.0
            extension, thumb, spread = (1.0,) * 4, "out", 1.25
        else:
            reach = int(math.ceil(76 * s * 1.12)) + 1
            x_lo, x_hi, y_lo, y_hi = -reach, reach, -reach, reach
            person = self._person
            palm_size, length_k, width_k = person["palm"], person["length"], person["width"]
            extension, thumb, spread = HAND_SHAPES[posture]
        ys, xs = np.mgrid[y_lo:y_hi + 1, x_lo:x_hi + 1].astype(np.float32)
        shape = xs.shape

        shade = np.zeros(shape, np.float32)        # darkening towards the outline
        palm_r2 = _ellipse(xs, ys, 0.0, 0.0, 24 * s * palm_size, 23 * s * palm_size)
        palm = palm_r2 <= 1.0
        shade[palm] = 24 * palm_r2[palm] ** 2
        fingers = np.zeros(shape, bool)
        creases = np.zeros(shape, bool)
        finger_radius = max(4.6 * s * width_k, 0.8)
        tips = {}
        # index, middle, ring, little: base x, length (reference px)
        for name, (base_x, length), reach in zip(
                FINGERS, ((-15.5, 30.0), (-5.2, 34.0), (5.2, 31.0), (15.5, 25.0)), extension):
            base_x *= palm_size
            length *= length_k * reach
            base_y = -23 * palm_size * math.sqrt(max(0.0, 1 - (base_x / (24 * palm_size)) ** 2)) + 7
            tip_x = base_x * spread if reach >= 0.9 else base_x + (1 - reach) * (-12 - base_x) * 0.5
            tips[name] = (tip_x * s, (base_y - length) * s)
            dist, t = _segment_distance(xs, ys, base_x * s, base_y * s, *tips[name])
            inside = (dist <= finger_radius) & ~palm
            fingers |= inside
            shade[inside] = 34 * (dist[inside] / finger_radius) ** 2
            for joint in (0.45, 0.75):           # knuckle lines move with the hand
                creases |= inside & (np.abs(t - joint) * length * s < max(0.7 * s, 0.5))
        thumb_base = (-17 * s * palm_size, 9 * s * palm_size)
        thumb_tip = {"out": (-33 * s * palm_size, -13 * s * palm_size),
                     "in": (-2 * s * palm_size, -4 * s * palm_size)}.get(thumb) or tips.get(thumb)
        dist, _ = _segment_distance(xs, ys, *thumb_base, *thumb_tip)
        thumb_radius = max(6.0 * s * width_k, 1.0)
        thumb_mask = (dist <= thumb_radius) & ~palm & ~fingers
        shade[thumb_mask] = 30 * (dist[thumb_mask] / thumb_radius) ** 2
        for cx, cy, radius in ((-30.0, -30.0, 34.0), (28.0, -26.0, 36.0), (-2.0, 40.0, 30.0)):
            ring = np.abs(np.hypot(xs - cx * s, ys - cy * s) - radius * s)
            creases |= palm & (palm_r2 < 0.75) & (ring < max(0.8 * s, 0.5))

        mask = palm | fingers | thumb_mask
        texture = _fractal(rng, *shape, s, (10, 5, 2.5, 1), (7.0, 6.0, 6.0, 3.0))
        low = _fractal(rng, *shape, s, (16,), (1.0,))
        y_plane = 174 + texture - shade - 32 * creases
        if self.difficulties.skin_tone:
            cb0, cr0 = self.difficulties.skin_chroma()
            cb_plane = np.clip(cb0 + 3 * low, cb0 - 12, cb0 + 12)
            cr_plane = np.clip(cr0 + 3 * low, cr0 - 12, cr0 + 12)
        elif posture is None:
            cb_plane = np.clip(104 + 3 * low, *_SKIN_CB)
            cr_plane = np.clip(153 + 3 * low, *_SKIN_CR)
        else:
            cb_plane = np.clip(104 + self._person["cb"] + 3 * low, *_SKIN_CB)
            cr_plane = np.clip(153 + self._person["cr"] + 3 * low, *_SKIN_CR)
        ycc = np.stack([y_plane, cb_plane, cr_plane]).astype(np.float32)
        if roll:
            mask, ycc = _turn(mask, ycc, (-y_lo, -x_lo), roll)

        rows, cols = np.nonzero(mask)
        top, bottom, left, right = rows.min(), rows.max(), cols.min(), cols.max()
        sprite = ycc[:, top:bottom + 1, left:right + 1]
        right_sprite = sprite.copy()
        right_sprite[0] = _right_luma(right_sprite[0])
        # offset of the sprite's top-left pixel from the palm centre
        return _Sprite(mask[top:bottom + 1, left:right + 1], _to_u8(sprite),
                       _to_u8(right_sprite), (int(y_lo + top), int(x_lo + left)))

    def _plan_motion(self, n_pre_rest, n_motion, n_post_rest) -> None:
        """Timing, amplitude, aspect and rest position; keeps the whole hand in view."""
        rng = self._rng(_STREAM_MOTION, self.gesture_id)
        rate = self.fps / 30.0

        def frames_in(span_s: tuple[float, float], floor: int) -> int:
            lo, hi = (max(floor, round(v * 30 * rate)) for v in span_s)
            return int(rng.integers(lo, hi + 1))

        pre = frames_in(_PRE_REST_S, 1)
        motion = frames_in(_MOTION_S, 2)
        post = frames_in(_PRE_REST_S, 1)
        pre = pre if n_pre_rest is None else check_int("n_pre_rest", n_pre_rest, 0,
                                                           MAX_SEGMENT_FRAMES)
        motion = motion if n_motion is None else check_int("n_motion", n_motion, 2,
                                                               MAX_SEGMENT_FRAMES)
        post = post if n_post_rest is None else check_int("n_post_rest", n_post_rest, 0,
                                                              MAX_SEGMENT_FRAMES)
        self.n_pre_rest, self.n_motion, self.n_post_rest = pre, motion, post
        self.frames = pre + motion + post
        self.motion_span = (pre, pre + motion - 1)

        amplitude = _AMPLITUDE_PX * self.scale * (1 + rng.uniform(-1, 1) * _AMPLITUDE_SPREAD)
        self.aspect = float(rng.uniform(*_ASPECT_RANGE))
        warp = random_time_warp(motion + 2, rng, strength=_TIME_WARP_STRENGTH)
        path = gesture_path(self.gesture, motion + 2, aspect=self.aspect, time_warp=warp)
        extent = gesture_path(self.gesture, 257, aspect=self.aspect, speed_profile="constant")
        lo, hi = extent.min(axis=0), extent.max(axis=0)

        # Palm-centre range that keeps the sprite inside the image; on the left the
        # margin includes the hand disparity so the right camera sees the whole hand.
        off_y, off_x = self._sprite_offset
        sprite_h, sprite_w = self._sprite_mask.shape
        room_lo = np.array([self.disparities["hand"] + _EDGE_MARGIN_PX - off_x,
                            _EDGE_MARGIN_PX - off_y], float)
        room_hi = np.array([self.width - 1 - _EDGE_MARGIN_PX - (off_x + sprite_w - 1),
                            self.height - 1 - _EDGE_MARGIN_PX - (off_y + sprite_h - 1)], float)
        room = room_hi - room_lo - 1.0                  # 1 px slack for rounding
        span = hi - lo
        for axis, name in ((0, "width"), (1, "height")):
            if room[axis] <= 0 or (span[axis] > 0 and room[axis] / span[axis]
                                   < 0.25 * _AMPLITUDE_PX * self.scale):
                size = self.width if axis == 0 else self.height
                raise ValueError(
                    f"{name} {size} leaves no room for the {self.gesture} gesture with "
                    f"hand_disparity {self.disparities['hand']}; use a larger {name}")
            if span[axis] > 0:
                amplitude = min(amplitude, room[axis] / span[axis])
        self.amplitude = float(amplitude)
        self._room = (room_lo, room_hi)
        rest = np.clip(np.array(self.chest), room_lo + 0.5 - amplitude * lo,
                       room_hi - 0.5 - amplitude * hi)
        self.rest = (float(rest[0]), float(rest[1]))

        anchors = np.empty((self.frames, 2))
        anchors[:] = rest
        anchors[pre:pre + motion] = rest + amplitude * path[1:-1]
        self.hand_anchor = np.rint(anchors).astype(np.int64)
        self.hand_disparities = np.full(self.frames, self.disparities["hand"], np.int64)

    def _build_static_layers(self) -> None:
        """Background, hair, face and torso, composed once per camera."""
        h = self.height
        canvas_w = self.width + MAX_DISPARITY   # right view reads x + d < width + 48
        layers = [self._background(canvas_w), *self._head(), self._torso(canvas_w)]
        if self.difficulties.clutter:
            layers += self._clutter(canvas_w)
        if self.difficulties.defocus:
            layers = [self._defocused(layer) for layer in layers]
        order = sorted(layers, key=lambda layer: layer.disparity)   # stable: far to near
        self._static = {}
        self._static_labels = {}
        self._static_disparity = {}
        for view in ("left", "right"):
            image = np.zeros((3, h, self.width), np.float32)
            labels = np.zeros((h, self.width), np.uint8)
            disparity = np.zeros((h, self.width), np.uint8)
            for layer in order:
                shift = layer.disparity if view == "right" else 0
                region = self._view_region(layer, shift)
                if region is None:
                    continue
                (vy, vx), (ly, lx) = region
                mask = layer.mask[ly, lx]
                image[:, vy, vx] = np.where(mask, layer.ycc[:, ly, lx], image[:, vy, vx])
                labels[vy, vx] = np.where(mask, layer.label, labels[vy, vx])
                disparity[vy, vx] = np.where(mask, layer.disparity, disparity[vy, vx])
            if view == "right":
                image[0] = _right_luma(image[0])
            self._static[view] = _to_u8(image)
            self._static_labels[view] = labels
            self._static_disparity[view] = disparity

    def _defocused(self, layer: _Layer) -> _Layer:
        """The layer's picture blurred by its depth's distance from the hand's."""
        import cv2
        sigma = (self.difficulties.defocus * abs(layer.disparity - self.disparities["hand"])
                 / 10 * self.scale)
        if sigma < 0.3:
            return layer
        ycc = np.stack([cv2.GaussianBlur(np.ascontiguousarray(c), (0, 0), sigma,
                                         borderType=cv2.BORDER_REPLICATE) for c in layer.ycc])
        return _Layer(layer.name, layer.disparity, layer.y0, layer.x0, layer.mask, ycc)

    def _clutter(self, canvas_w: int) -> list[_Layer]:
        """A wooden board on the wall and a second person's face further back, both
        inside the Cb/Cr box and outside the disparity band."""
        s, h = self.scale, self.height
        rng = self._rng(_STREAM_CLUTTER)
        side = 1 if self.face_center[0] < self.width / 2 else -1     # away from the face
        bw, bh = rng.uniform(90, 140) * s, rng.uniform(120, 180) * s
        bx = self.width / 2 + side * rng.uniform(0.28, 0.36) * self.width - bw / 2
        by = rng.uniform(0.05, 0.25) * h
        x0, y0 = int(bx), int(by)
        ys, xs = np.mgrid[0:int(bh), 0:int(bw)].astype(np.float32)
        grain = 10 * np.sin(2 * np.pi * (xs + 6 * _fractal(rng, *xs.shape, s, (30,), (1.0,)))
                            / max(3.0, 9 * s))
        luma = 140 + grain + _fractal(rng, *xs.shape, s, (12, 3), (4.0, 2.0))
        board = np.stack([luma, np.full_like(luma, 100.0), np.full_like(luma, 150.0)])
        d_board = min(self.disparities["background"] + 2, MAX_DISPARITY - 1)
        layers = [_Layer("clutter", d_board, y0, x0, np.ones(xs.shape, bool),
                         board.astype(np.float32))]
        # a second face, smaller (further back), on the other side of the picture
        fa, fb = rng.uniform(30, 38) * s, rng.uniform(40, 48) * s
        fcx = self.width / 2 - side * rng.uniform(0.3, 0.38) * self.width
        fcy = rng.uniform(0.2, 0.35) * h
        fx0, fy0 = int(fcx - fa) - 1, int(fcy - fb) - 1
        ys, xs = np.mgrid[fy0:int(fcy + fb) + 2, fx0:int(fcx + fa) + 2].astype(np.float32)
        r2 = _ellipse(xs, ys, fcx, fcy, fa, fb)
        luma = 158 + _fractal(rng, *xs.shape, s, (12, 4, 1), (6, 5, 2)) - 20 * np.clip(r2, 0, 1)
        for eye in (-1, 1):
            luma = np.where(_ellipse(xs, ys, fcx + eye * 0.38 * fa, fcy - 0.1 * fb,
                                     0.18 * fa, 0.08 * fb) <= 1, 60, luma)
        face = np.stack([luma, np.full_like(luma, 108.0), np.full_like(luma, 148.0)])
        d_face = max(0, min(self.disparities["face"] - 8, MAX_DISPARITY - 1))
        layers.append(_Layer("clutter", d_face, fy0, fx0, r2 <= 1, face.astype(np.float32)))
        return layers

    def _plan_intruder(self) -> None:
        """The ball's path: in from the side and out again, in a horizontal band
        the hand never enters, for a third of the clip (seeded)."""
        s = self.scale
        rng = self._rng(_STREAM_INTRUDER, self.gesture_id)
        radius = _INTRUDER_RADIUS * s
        off_y, _ = self._sprite_offset
        sprite_h = self._sprite_mask.shape[0]
        top = self.hand_anchor[:, 1].min() + off_y - 8 * s
        bottom = self.hand_anchor[:, 1].max() + off_y + sprite_h + 8 * s
        if self.difficulties.forearm:
            bottom = self.height          # the forearm reaches the bottom edge
        bands = [(0.0, top), (bottom, float(self.height))]
        lo, hi = max(bands, key=lambda b: b[1] - b[0])
        radius = min(radius, (hi - lo) / 2 - 2)
        self._intruder = None
        if radius < 6 * s:
            return                        # no room in this scene: no ball
        cy = (lo + hi) / 2
        span = max(2, self.frames // 3)
        start = int(rng.integers(0, max(1, self.frames - span)))
        side = int(rng.choice([-1, 1]))
        reach = rng.uniform(0.15, 0.3) * self.width
        frames = np.arange(self.frames)
        phase = np.clip((frames - start) / span, 0, 1)
        depth_in = np.sin(np.pi * phase) * reach        # 0 outside the span
        edge = -radius if side < 0 else self.width + radius + self.disparities["hand"]
        cx = edge - side * depth_in
        inside = (phase > 0) & (phase < 1)
        self._intruder = _Intruder(radius, np.where(inside, cx, np.nan), cy,
                                   max(0, self.disparities["hand"] - _INTRUDER_BELOW_HAND),
                          _fractal(rng, int(2 * radius) + 3, int(2 * radius) + 3, s, (8, 3, 1),
                                   (6.0, 5.0, 3.0)))

    @property
    def intruder_in_view(self) -> np.ndarray:
        """(frames,) bool: the frames in which the intruder ball is in the picture
        (all False without one)."""
        if self._intruder is None:
            return np.zeros(self.frames, bool)
        return np.isfinite(self._intruder.x)

    def _paste_intruder(self, image, plane, frame: int, view: str, label: bool = False):
        if self._intruder is None:
            return
        radius, cxs, cy, d, texture = self._intruder
        cx = cxs[frame]
        if not np.isfinite(cx):
            return
        x0, y0 = int(round(cx - radius)) - 1, int(round(cy - radius)) - 1
        size = texture.shape[0]
        ys, xs = np.mgrid[y0:y0 + size, x0:x0 + size].astype(np.float32)
        mask = _ellipse(xs, ys, cx, cy, radius, radius) <= 1
        luma = 165 + texture - 25 * np.clip(_ellipse(xs, ys, cx, cy, radius, radius), 0, 1)
        if view == "right":
            luma = _right_luma(luma)
        ycc = np.stack([luma, np.full_like(luma, 102.0), np.full_like(luma, 152.0)])
        self._paste(_Layer("intruder", d, y0, x0, mask, ycc), image, plane, view, label)

    def _paste(self, layer: _Layer, image, plane, view: str, label: bool) -> None:
        """Draw a per-frame layer (its ``ycc`` already the ``view``'s) into ``image``
        (3, H, W) uint8, or its disparity (with ``label``, its label) into ``plane``."""
        region = self._view_region(layer, layer.disparity if view == "right" else 0)
        if region is None:
            return
        (vy, vx), (ly, lx) = region
        m = layer.mask[ly, lx]
        if image is not None:
            image[:, vy, vx] = np.where(m, _to_u8(layer.ycc[:, ly, lx]), image[:, vy, vx])
        else:
            value = layer.label if label else layer.disparity
            plane[vy, vx] = np.where(m, value, plane[vy, vx])

    def _view_region(self, layer: _Layer, shift: int):
        """Slices of the view and of the layer where the layer (shifted by -shift) lands."""
        lh, lw = layer.mask.shape
        vx0, vy0 = layer.x0 - shift, layer.y0
        x_start, x_end = max(vx0, 0), min(vx0 + lw, self.width)
        y_start, y_end = max(vy0, 0), min(vy0 + lh, self.height)
        if x_start >= x_end or y_start >= y_end:
            return None
        return ((slice(y_start, y_end), slice(x_start, x_end)),
                (slice(y_start - vy0, y_end - vy0), slice(x_start - vx0, x_end - vx0)))

    def _background(self, canvas_w: int) -> _Layer:
        """A far wall: multi-scale texture and a few posters / pieces of furniture."""
        s, h = self.scale, self.height
        rng = self._rng(_STREAM_BACKGROUND)
        luma = 118 + _fractal(rng, h, canvas_w, s, (96, 48, 24, 12, 6, 3, 1),
                              (16, 14, 11, 9, 8, 7, 4))
        cb = 127 + 10 * _fractal(rng, h, canvas_w, s, (160, 48), (0.8, 0.6))
        cr = 116 + 7 * _fractal(rng, h, canvas_w, s, (160, 48), (0.8, 0.6))
        ys, xs = np.mgrid[0:h, 0:canvas_w]
        for _ in range(int(rng.integers(3, 7))):
            rw, rh = rng.uniform(60, 220) * s, rng.uniform(50, 200) * s
            rx, ry = rng.uniform(-rw / 2, canvas_w - rw / 2), rng.uniform(-rh / 2, h - rh / 2)
            inside = (xs >= rx) & (xs < rx + rw) & (ys >= ry) & (ys < ry + rh)
            pcb, pcr = _WALL_PALETTE[int(rng.integers(len(_WALL_PALETTE)))]
            level = rng.uniform(50, 200)
            luma = np.where(inside, level + 0.6 * (luma - 118), luma)
            cb = np.where(inside, pcb + 0.3 * (cb - 127), cb)
            cr = np.where(inside, pcr + 0.3 * (cr - 116), cr)
        ycc = np.stack([luma, cb, cr]).astype(np.float32)
        return _Layer("background", self.disparities["background"], 0, 0,
                      np.ones((h, canvas_w), bool), ycc)

    def _head(self) -> list[_Layer]:
        """Hair, then the skin-coloured face and neck (same disparity)."""
        s = self.scale
        rng = self._rng(_STREAM_FACE)
        fcx, fcy = self.face_center
        fa, fb = self.face_axes
        neck_half = 20 * s
        x0 = math.floor(fcx - fa - 10 * s) - 1
        x1 = math.ceil(fcx + fa + 10 * s) + 1
        y0 = math.floor(fcy - fb - 14 * s) - 1
        y1 = math.ceil(self.shoulder_y + 24 * s) + 1
        ys, xs = np.mgrid[y0:y1 + 1, x0:x1 + 1].astype(np.float32)
        shape = xs.shape

        r2 = _ellipse(xs, ys, fcx, fcy, fa, fb)
        face = r2 <= 1.0
        neck = (np.abs(xs - fcx) <= neck_half) & (ys >= fcy + 0.5 * fb) & \
               (ys <= self.shoulder_y + 24 * s)
        hair = (_ellipse(xs, ys, fcx, fcy - 6 * s, fa + 6 * s, fb + 10 * s) <= 1.0) & \
               (ys <= fcy - 0.2 * fb)

        texture = _fractal(rng, *shape, s, (16, 8, 4, 2, 1), (6, 6, 5, 4, 2))
        low = _fractal(rng, *shape, s, (24,), (1.0,))
        luma = 162 + texture - 26 * np.clip(r2, 0, 1) ** 2
        cr_extra = np.zeros(shape, np.float32)
        for side in (-1, 1):
            ex, ey = fcx + side * 0.38 * fa, fcy - 0.12 * fb
            luma = np.where(_ellipse(xs, ys, ex, ey, 0.2 * fa, 0.09 * fb) <= 1, 60, luma)
            brow = _ellipse(xs, ys, ex, fcy - 0.3 * fb, 0.24 * fa, 0.045 * fb) <= 1
            luma = np.where(brow, 75 + 0.5 * texture, luma)
        nose = _ellipse(xs, ys, fcx, fcy + 0.18 * fb, 0.1 * fa, 0.16 * fb) <= 1
        luma = luma - 18 * nose
        mouth = _ellipse(xs, ys, fcx, fcy + 0.52 * fb, 0.32 * fa, 0.07 * fb) <= 1
        luma = np.where(mouth, 110 + 0.5 * texture, luma)
        cr_extra[mouth] = 8
        luma = np.where(neck & ~face, luma - 20, luma)     # the neck is in the chin's shadow
        skin = np.stack([luma, np.clip(106 + 3 * low, *_SKIN_CB),
                         np.clip(149 + 3 * low + cr_extra, *_SKIN_CR)]).astype(np.float32)
        hair_ycc = np.stack([45 + 1.6 * texture, 128 + 2 * low, 121 + 2 * low]).astype(np.float32)
        d = self.disparities["face"]
        return [_Layer("hair", d, y0, x0, hair, hair_ycc),
                _Layer("face", d, y0, x0, face | neck, skin)]

    def _torso(self, canvas_w: int) -> _Layer:
        """Clothing: a superellipse (flat top, rounded shoulders), non-skin, textured."""
        s, h = self.scale, self.height
        rng = self._rng(_STREAM_TORSO)
        half = self.torso_half_width
        x0 = max(0, math.floor(self.person_x - half) - 1)
        x1 = min(canvas_w - 1, math.ceil(self.person_x + half) + 1)
        y0 = max(0, math.floor(self.shoulder_y) - 1)
        ys, xs = np.mgrid[y0:h, x0:x1 + 1].astype(np.float32)
        depth = h - self.shoulder_y + 80 * s
        centre_y = self.shoulder_y + depth
        mask = (((xs - self.person_x) / half) ** 4 + ((ys - centre_y) / depth) ** 4 <= 1.0)
        cb0, cr0, luma0 = _SHIRT_PALETTE[int(rng.integers(len(_SHIRT_PALETTE)))]
        luma = luma0 + _fractal(rng, *xs.shape, s, (40, 12, 4, 2, 1), (8, 6, 6, 5, 3))
        period = max(4.0, rng.uniform(10, 24) * s)
        pattern = int(rng.integers(3))        # 0 plain, 1 stripes, 2 checks
        if pattern >= 1:
            luma = luma + 14 * np.sign(np.sin(2 * np.pi * xs / period))
        if pattern == 2:
            luma = luma + 14 * np.sign(np.sin(2 * np.pi * ys / period))
        low = _fractal(rng, *xs.shape, s, (64,), (1.0,))
        ycc = np.stack([luma, cb0 + 3 * low, cr0 + 3 * low]).astype(np.float32)
        return _Layer("torso", self.disparities["torso"], y0, x0, mask, ycc)

    # ---------------------------------------------------------------- per frame

    def _check_frame(self, frame) -> int:
        return check_int("frame", frame, 0, self.frames - 1)

    def _hand_region(self, frame: int, shift: int, anchor=None):
        """View and sprite slices of the hand in a view whose layer shift is ``shift``
        (at ``anchor`` instead of the frame's palm centre, if given)."""
        ax, ay = self.hand_anchor[frame] if anchor is None else anchor
        sprite = self._sprite(frame)
        layer = _Layer("hand", int(self.hand_disparities[frame]),
                       int(ay) + sprite.offset[0], int(ax) + sprite.offset[1],
                       sprite.mask, None)
        return self._view_region(layer, shift)

    def views444(self, frame: int) -> tuple[np.ndarray, np.ndarray]:
        """Noise-free left and right images of a frame, each (3, H, W) uint8 (Y, Cb, Cr)."""
        frame = self._check_frame(frame)
        anchors = self._blur_anchors(frame) if self.difficulties.motion_blur else [None]
        views = []
        hand = self._sprite(frame)
        for view, sprite, shift in (("left", hand.left, 0),
                                    ("right", hand.right,
                                     int(self.hand_disparities[frame]))):
            total = None
            for anchor in anchors:
                image = self._static[view].copy()
                if self.difficulties.forearm:
                    self._paste_forearm(image, None, frame, view, anchor)
                self._paste_intruder(image, None, frame, view)
                region = self._hand_region(frame, shift, anchor)
                if region is not None:
                    (vy, vx), (ly, lx) = region
                    mask = hand.mask[ly, lx]
                    image[:, vy, vx] = np.where(mask, sprite[:, ly, lx], image[:, vy, vx])
                if len(anchors) == 1:
                    total = image
                else:
                    total = image.astype(np.float32) if total is None else total + image
            if len(anchors) > 1:
                total = np.rint(total / len(anchors)).astype(np.uint8)
            views.append(total)
        return views[0], views[1]

    def _build_forearm(self) -> None:
        """The forearm's texture field (in arm coordinates, so both views see the
        same skin) and its elbow, below the chest on the hand's side."""
        s = self.scale * self.difficulties.hand_scale
        rng = self._rng(_STREAM_FOREARM)
        self._arm_length = int(math.ceil(max(self.width, self.height) * 1.5))
        radius = _FOREARM_RADIUS * s
        self._arm_radius = radius
        rows = int(math.ceil(2 * radius)) + 3
        texture = _fractal(rng, rows, self._arm_length, s, (10, 5, 2.5, 1), (6.0, 5.0, 5.0, 3.0))
        self._arm_texture = texture
        self._elbow = (self.rest[0] + rng.uniform(10, 40) * s, self.height + 30 * s)
        self._sleeve = (int(rng.integers(60, 200)), 120.0 + rng.uniform(-8, 8),
                        rng.uniform(135, 150))

    def _forearm_segments(self, frame: int, anchor=None):
        """(disparity, mask, ycc, y0, x0) of each segment in left-image coordinates,
        far (elbow) to near (wrist)."""
        s = self.scale * self.difficulties.hand_scale
        ax, ay = self.hand_anchor[frame] if anchor is None else anchor
        wrist = np.array([ax, ay + _WRIST_BELOW * s], float)
        elbow = np.array(self._elbow)
        axis = elbow - wrist
        length = float(np.hypot(*axis))
        if length < 1:
            return []
        unit = axis / length
        normal = np.array([-unit[1], unit[0]])
        near = int(self.hand_disparities[frame]) - 1
        far = self.disparities["torso"] + 1
        radius = self._arm_radius
        out = []
        for k in reversed(range(_FOREARM_SEGMENTS)):
            t0, t1 = k / _FOREARM_SEGMENTS, (k + 1) / _FOREARM_SEGMENTS
            d = int(round(near - (near - far) * (k + 0.5) / _FOREARM_SEGMENTS))
            p0, p1 = wrist + t0 * axis, wrist + t1 * axis
            x0 = int(math.floor(min(p0[0], p1[0]) - radius)) - 1
            x1 = int(math.ceil(max(p0[0], p1[0]) + radius)) + 1
            y0 = int(math.floor(min(p0[1], p1[1]) - radius)) - 1
            y1 = int(math.ceil(max(p0[1], p1[1]) + radius)) + 1
            ys, xs = np.mgrid[y0:y1 + 1, x0:x1 + 1].astype(np.float32)
            rel_x, rel_y = xs - wrist[0], ys - wrist[1]
            u = rel_x * unit[0] + rel_y * unit[1]            # along the arm from the wrist
            v = rel_x * normal[0] + rel_y * normal[1]        # across it
            mask = (u >= t0 * length) & (u < t1 * length) & (np.abs(v) <= radius)
            if not mask.any():
                continue
            ui = np.clip(u, 0, self._arm_length - 1).astype(np.int64)
            vi = np.clip(v + radius + 1, 0, self._arm_texture.shape[0] - 1).astype(np.int64)
            shade = 30 * (np.abs(v) / radius) ** 2
            luma = 168 + self._arm_texture[vi, ui] - shade
            sleeve = u >= (1 - _SLEEVE_SHARE) * length
            sl_y, sl_cb, sl_cr = self._sleeve
            cb0, cr0 = self.difficulties.skin_chroma()
            ycc = np.stack([np.where(sleeve, sl_y + 0.5 * (luma - 168), luma),
                            np.where(sleeve, sl_cb, cb0), np.where(sleeve, sl_cr, cr0)])
            out.append((d, mask, ycc.astype(np.float32), y0, x0))
        return out

    def _paste_forearm(self, image, plane, frame: int, view: str, anchor=None,
                       label: bool = False) -> None:
        """Draw the forearm into ``image`` (3, H, W) uint8, or its disparity (or,
        with ``label``, its label) into ``plane`` (H, W)."""
        for d, mask, ycc, y0, x0 in self._forearm_segments(frame, anchor):
            if view == "right":
                right = ycc.copy()
                right[0] = _right_luma(right[0])
                ycc = right
            self._paste(_Layer("forearm", d, y0, x0, mask, ycc), image, plane, view, label)

    def _blur_anchors(self, frame: int) -> list:
        """Palm centres over the exposure: ``motion_blur`` of the frame interval
        centred on the frame time, the hand moving towards the previous frame's
        position before it and the next one's after it."""
        here = self.hand_anchor[frame].astype(float)
        before = self.hand_anchor[max(frame - 1, 0)].astype(float)
        after = self.hand_anchor[min(frame + 1, self.frames - 1)].astype(float)
        half = self.difficulties.motion_blur / 2
        out = []
        for t in np.linspace(-half, half, _BLUR_SAMPLES):
            point = here + t * (here - before) if t < 0 else here + t * (after - here)
            out.append(tuple(int(v) for v in np.rint(point)))
        return out

    def _check_view(self, view, frame: int) -> int:
        """Layer shift of a view: 0 for the left camera, the disparity for the right."""
        if view not in ("left", "right"):
            raise ValueError(f"view must be 'left' or 'right', got {view!r}")
        return int(self.hand_disparities[frame]) if view == "right" else 0

    def hand_mask(self, frame: int, view: str = "left") -> np.ndarray:
        """(H, W) bool: the hand's pixels in the left (or right) image."""
        frame = self._check_frame(frame)
        mask = np.zeros((self.height, self.width), bool)
        region = self._hand_region(frame, self._check_view(view, frame))
        if region is not None:
            (vy, vx), (ly, lx) = region
            mask[vy, vx] = self._sprite(frame).mask[ly, lx]
        return mask

    def label_map(self, frame: int, view: str = "left") -> np.ndarray:
        """(H, W) uint8: the :data:`LAYER_LABELS` id of each pixel of a view.

        Comparing the two views' maps tells which pixels are occluded in the other
        camera.
        """
        hand = self.hand_mask(frame, view)
        labels = self._static_labels[view].copy()
        if self.difficulties.forearm:
            self._paste_forearm(None, labels, frame, view, label=True)
        self._paste_intruder(None, labels, frame, view, label=True)
        labels[hand] = LAYER_LABELS["hand"]
        return labels

    def disparity_map(self, frame: int, view: str = "left") -> np.ndarray:
        """(H, W) uint8: the true disparity of each pixel (ground truth for the matcher).

        A left pixel ``x`` with disparity ``d`` shows the same point as the right
        pixel ``x - d``; for ``view="right"`` it is the disparity of the layer seen
        at each right pixel.
        """
        hand = self.hand_mask(frame, view)
        disparity = self._static_disparity[view].copy()
        if self.difficulties.forearm:
            self._paste_forearm(None, disparity, frame, view)
        self._paste_intruder(None, disparity, frame, view)
        disparity[hand] = self.hand_disparities[frame]
        return disparity

    def hand_truth(self, frame: int) -> tuple[float, float, int]:
        """Exact centroid ``(x, y)`` and pixel count of the hand in the left image."""
        frame = self._check_frame(frame)
        region = self._hand_region(frame, 0)
        if region is None:
            return math.nan, math.nan, 0
        (vy, vx), (ly, lx) = region
        rows, cols = np.nonzero(self._sprite(frame).mask[ly, lx])
        if rows.size == 0:
            return math.nan, math.nan, 0
        return float(cols.mean() + vx.start), float(rows.mean() + vy.start), int(rows.size)

    def stereo_frame(self, frame: int) -> tuple[np.ndarray, np.ndarray]:
        """The two cameras' 4:2:2 byte streams of a frame, each (H, 2W) uint8.

        With ``noise`` the sensor noise is added to the streams (sigma
        :data:`NOISE_SIGMA_Y` on the Y bytes, :data:`NOISE_SIGMA_C` on the chroma
        bytes), independently per camera and per frame.
        """
        left444, right444 = self.views444(frame)
        streams = [ycbcr444_to_422(*left444), ycbcr444_to_422(*right444)]
        if self._rig is not None:
            from sim.calibration import camera_frames
            streams = [camera_frames(stream[None], self._rig, side)[0]
                       for stream, side in zip(streams, ("left", "right"))]
        if self._gains is not None:
            for camera, stream in enumerate(streams):
                luma = stream[:, 0::2].astype(np.float32) * self._gains[camera, frame]
                stream[:, 0::2] = np.clip(np.rint(luma), 0, 255).astype(np.uint8)
        if not self.noise:
            return streams[0], streams[1]
        rng = self._rng(_STREAM_NOISE, self.gesture_id, frame)
        table_y = _rounded_gaussian_table(NOISE_SIGMA_Y)
        table_c = _rounded_gaussian_table(NOISE_SIGMA_C)
        noisy = []
        for stream in streams:
            # The stream is integer, so rint(stream + sigma*z) = stream + rint(sigma*z):
            # draw the rounded noise directly by an inverse-CDF table (4x faster
            # than standard_normal here).
            index = rng.integers(0, _NOISE_TABLE_SIZE, size=stream.shape, dtype=np.uint16)
            noise = np.empty(stream.shape, np.int16)
            noise[:, 0::2] = table_y[index[:, 0::2]]
            noise[:, 1::2] = table_c[index[:, 1::2]]
            noise += stream
            noisy.append(np.clip(noise, 0, 255).astype(np.uint8))
        return noisy[0], noisy[1]

    def parameters(self) -> dict:
        """JSON-serialisable description of the scene (stored as ``renderer`` in a clip)."""
        return {
            "name": "sim.render", "version": 1,
            "reference_size": [REFERENCE_WIDTH, REFERENCE_HEIGHT],
            "scale": round(self.scale, 6),
            "torso_disparity": self.disparities["torso"],
            "background_disparity": self.disparities["background"],
            "amplitude_px": round(self.amplitude, 3),
            "aspect": round(self.aspect, 4),
            "speed_profile": "smooth",
            "time_warp_strength": _TIME_WARP_STRENGTH,
            "rest_position": [round(self.rest[0], 3), round(self.rest[1], 3)],
            "pre_rest_frames": self.n_pre_rest,
            "motion_length": self.n_motion,
            "post_rest_frames": self.n_post_rest,
            "hand_size_px": list(self.hand_size),
            **({"posture": self.posture, "roll_degrees": self.roll,
                "person": {k: round(v, 4) for k, v in self._person.items()}}
               if self.posture is not None else {}),
            "noise": self.noise,
            "noise_sigma_y": NOISE_SIGMA_Y, "noise_sigma_c": NOISE_SIGMA_C,
            "right_y_gain": RIGHT_Y_GAIN, "right_y_offset": RIGHT_Y_OFFSET,
            **({"difficulties": self.difficulties.as_dict()} if self.difficulties.any else {}),
        }


class DistractorScene(StereoScene):
    """The person and room of ``StereoScene(..., seed)`` making a non-gesture
    motion (:mod:`sim.distractors`) from the rest position ``gesture``'s scene
    would have, and back (issue 28).

    Parameters
    ----------
    kind : str
        One of :data:`sim.distractors.DISTRACTOR_KINDS`.
    seed : int
    index : int in [0, 65535]
        Which distractor of a stream: the path and the sensor noise depend on
        ``(seed, index)``.
    gesture : str
        The gesture whose rest position the hand starts from.
    n_pre_rest, n_post_rest : int
        Frames of rest before and after the motion.
    command : str, optional
        Make it in this posture throughout (a distractor in the command
        posture); by default the hands of its kind
        (:func:`sim.distractors.distractor_hands`).

    The other parameters are :class:`StereoScene`'s. ``motion_span`` is the
    distractor's; the hand leaves the picture in ``out-of-view`` (its truth is
    then NaN with area 0) and its disparity leaves the band in ``depth``
    (:attr:`hand_disparities`).
    """

    def __init__(self, kind: str, seed: int, width: int = REFERENCE_WIDTH,
                 height: int = REFERENCE_HEIGHT, *, index: int = 0, gesture: str = "stop",
                 fps: int = 30, hand_disparity: int = 40, face_disparity: int = 24,
                 torso_disparity: int = 28, background_disparity: int | None = None,
                 n_pre_rest: int = 0, n_post_rest: int = 0, noise: bool = True,
                 difficulties: Difficulties | None = None, command: str | None = None) -> None:
        self.kind = check_kind(kind)
        self.index = check_int("index", index, 0, 65535)
        self.command = None if command is None else resolve_posture(command)
        # a posture, so the person's hand proportions are drawn; the shapes are planned
        super().__init__(gesture, seed, width, height, fps=fps, hand_disparity=hand_disparity,
                         face_disparity=face_disparity, torso_disparity=torso_disparity,
                         background_disparity=background_disparity, n_pre_rest=n_pre_rest,
                         n_motion=2, n_post_rest=n_post_rest, noise=noise,
                         difficulties=difficulties, posture="relaxed")

    def _plan_motion(self, n_pre_rest, n_motion, n_post_rest) -> None:
        super()._plan_motion(n_pre_rest, n_motion, n_post_rest)   # rest and room
        self.gesture_id = _DISTRACTOR_ID + self.index             # own noise, exposure
        unit = _AMPLITUDE_PX * self.scale
        rest = np.array(self.rest)
        off_y = self._sprite_offset[0]
        path = distractor_motion(
            self.kind, self._rng(_STREAM_DISTRACTOR, self.index), fps=self.fps,
            face=(np.array(self.face_center) - rest) / unit,
            exit_below=(self.height + 2 - off_y - rest[1]) / unit)
        pre, post = self.n_pre_rest, self.n_post_rest
        self.n_motion = path.frames
        self.frames = pre + path.frames + post
        self.motion_span = (pre, pre + path.frames - 1)
        room_lo, room_hi = self._room
        anchors = np.empty((self.frames, 2))
        anchors[:] = rest
        moved = rest + unit * path.offset
        moved[:, 0] = np.clip(moved[:, 0], room_lo[0], room_hi[0])
        moved[:, 1] = np.maximum(moved[:, 1], room_lo[1])
        if self.kind != "out-of-view":
            moved[:, 1] = np.minimum(moved[:, 1], room_hi[1])
        anchors[pre:pre + path.frames] = moved
        self.hand_anchor = np.rint(anchors).astype(np.int64)
        disparity = np.full(self.frames, float(self.disparities["hand"]))
        disparity[pre:pre + path.frames] += path.disparity
        self.hand_disparities = np.clip(np.rint(disparity), 0,
                                        MAX_DISPARITY - 1).astype(np.int64)
        hands = distractor_hands(path, self._rng(_STREAM_HANDS, self.index), self.command)
        self.hand_shapes = (hands[0],) * pre + hands + (hands[-1],) * post

    def parameters(self) -> dict:
        return dict(super().parameters(), distractor=self.kind, distractor_index=self.index,
                    distractor_command=self.command)


class HoldScene(StereoScene):
    """The person and room of ``StereoScene(..., seed)`` holding the hand
    still at the rest position ``gesture``'s scene would have: ``before``
    frames in ``around``, ``hold`` frames in ``posture`` (a stop posture held,
    say), ``after`` frames in ``around`` again. ``motion_span`` is the hold.
    The other parameters are :class:`StereoScene`'s."""

    def __init__(self, posture: str, seed: int, width: int = REFERENCE_WIDTH,
                 height: int = REFERENCE_HEIGHT, *, before: int = 15, hold: int = 30,
                 after: int = 15, around: str = COMMAND_POSTURE, gesture: str = "stop",
                 index: int = 0, **options) -> None:
        self._hold = (check_int("before", before, 0, MAX_SEGMENT_FRAMES),
                      check_int("hold", hold, 1, MAX_SEGMENT_FRAMES),
                      check_int("after", after, 0, MAX_SEGMENT_FRAMES))
        self._shapes = (resolve_posture(around), resolve_posture(posture))
        self.index = check_int("index", index, 0, 65535)
        super().__init__(gesture, seed, width, height, posture=self._shapes[0], **options)

    def _plan_motion(self, n_pre_rest, n_motion, n_post_rest) -> None:
        super()._plan_motion(n_pre_rest, n_motion, n_post_rest)   # rest and room
        self.gesture_id = _HOLD_ID + self.index                   # own noise, exposure
        before, hold, after = self._hold
        self.n_pre_rest, self.n_motion, self.n_post_rest = before, hold, after
        self.frames = before + hold + after
        self.motion_span = (before, before + hold - 1)
        self.hand_anchor = np.repeat(np.rint(np.array(self.rest))[None].astype(np.int64),
                                     self.frames, axis=0)
        self.hand_disparities = np.full(self.frames, self.disparities["hand"], np.int64)
        around, posture = self._shapes
        self.hand_shapes = (around,) * before + (posture,) * hold + (around,) * after

    def parameters(self) -> dict:
        return dict(super().parameters(), hold_posture=self._shapes[1], hold_index=self.index)


def render_hold(posture: str, seed: int, width: int = REFERENCE_WIDTH,
                height: int = REFERENCE_HEIGHT, **options) -> Clip:
    """A :class:`HoldScene` rendered (``gesture`` of the clip: None)."""
    return render_scene(HoldScene(posture, seed, width, height, **options))


def render_scene(scene: StereoScene) -> Clip:
    """Every frame of ``scene`` and its truth as a :class:`~sim.clip.Clip`
    (``gesture``: the scene's, None for a :class:`DistractorScene`)."""
    shape = (scene.frames, scene.height, 2 * scene.width)
    left = np.empty(shape, np.uint8)
    right = np.empty(shape, np.uint8)
    hand_xy = np.empty((scene.frames, 2))
    hand_area = np.empty(scene.frames, np.int64)
    for frame in range(scene.frames):
        left[frame], right[frame] = scene.stereo_frame(frame)
        x, y, area = scene.hand_truth(frame)
        hand_xy[frame] = (x, y)
        hand_area[frame] = area
    return Clip(gesture=None if isinstance(scene, (DistractorScene, HoldScene))
                else scene.gesture,
                seed=scene.seed, fps=scene.fps,
                hand_disparity=scene.disparities["hand"],
                face_disparity=scene.disparities["face"], motion_frames=scene.motion_span,
                left=left, right=right, hand_xy=round_truth(hand_xy), hand_area=hand_area,
                postures=tuple(name or DEFAULT_POSTURE for name in scene.hand_shapes),
                renderer=scene.parameters())


def render_clip(gesture: str, seed: int, width: int = REFERENCE_WIDTH,
                height: int = REFERENCE_HEIGHT, *, fps: int = 30, hand_disparity: int = 40,
                face_disparity: int = 24, torso_disparity: int = 28,
                background_disparity: int | None = None, n_pre_rest: int | None = None,
                n_motion: int | None = None, n_post_rest: int | None = None,
                noise: bool = True, difficulties: Difficulties | None = None,
                posture: str | None = None, roll: int | None = None) -> Clip:
    """Render a synthetic stereo clip of one gesture (thesis Figs. 16 and 77).

    The parameters are those of :class:`StereoScene`. The clip's truth is the
    exact centroid and area of the hand's pixels in the left image, per frame.

    Returns
    -------
    Clip
        ``left``/``right`` are (frames, height, 2*width) uint8 YCbCr 4:2:2 streams.

    Raises
    ------
    ValueError
        A parameter out of range (the message names it and the range).
    """
    return render_scene(StereoScene(
        gesture, seed, width, height, fps=fps, hand_disparity=hand_disparity,
        face_disparity=face_disparity, torso_disparity=torso_disparity,
        background_disparity=background_disparity, n_pre_rest=n_pre_rest, n_motion=n_motion,
        n_post_rest=n_post_rest, noise=noise, difficulties=difficulties, posture=posture,
        roll=roll))


#: Frames of rest before the first gesture of a sequence (before the others:
#: the pause after the previous one).
SEQUENCE_LEAD = 10
#: Frames of rest after a sequence's last gesture: enough for the thesis' hold.
SEQUENCE_TAIL = 30


#: Most frames ``render_sequence(frames=...)`` renders.
MAX_SEQUENCE_FRAMES = 1_000_000


def render_sequence(gestures, seed: int, width: int = REFERENCE_WIDTH,
                    height: int = REFERENCE_HEIGHT, *, pause=(0, 15), fps: int = 30,
                    noise: bool = True, difficulties: Difficulties | None = None,
                    distractors: bool = False, frames: int | None = None,
                    postures=None, command: str | None = COMMAND_POSTURE) -> Clip:
    """One clip of several gestures one after another (issue 28): the same
    person and room (``seed``), each gesture as :func:`render_clip` draws it
    (every gesture path starts and ends at the rest position in front of the
    chest), a pause of ``pause`` = (min, max) frames of rest between two
    gestures (0: the hand flows from one into the next), drawn from ``seed``.

    With ``distractors``, a non-gesture motion (:class:`DistractorScene`, the
    kinds of :data:`sim.distractors.DISTRACTOR_KINDS` in a seeded order, each
    as often as the others) comes before every gesture, followed by a pause
    drawn from ``pause``. With no gestures (``[]``) and ``distractors``, the
    clip holds distractors only, one after another, cut at ``frames`` frames
    (required then, and only then). ``postures``: per gesture, the posture it
    is made in (None: the open hand), e.g. from ``NAME@POSTURE`` entries.
    Distractors have their kind's hands (:func:`sim.distractors.distractor_hands`),
    but a share of them, drawn from ``seed`` in
    :data:`sim.distractors.COMMAND_SHARE`, is made in ``command`` (None: none).

    Returns
    -------
    Clip
        ``sequence`` holds every gesture and its motion span (empty without
        gestures); ``distractors`` every distractor's kind and span (None
        without); ``gesture`` is the last gesture (None without) and
        ``motion_frames`` spans the gestures (without gestures: the
        distractors).
    """
    gestures = list(gestures)
    postures = [None] * len(gestures) if postures is None else list(postures)
    if len(postures) != len(gestures):
        raise ValueError(f"postures must name one posture (or None) per gesture, got "
                         f"{len(postures)} for {len(gestures)} gestures")
    postures = [None if p is None else resolve_posture(p) for p in postures]
    command = None if command is None else resolve_posture(command)
    if any(g not in GESTURE_NAMES for g in gestures) or not (gestures or distractors):
        raise ValueError(f"sequence must name one or more of {', '.join(GESTURE_NAMES)} "
                         f"(or none, with distractors), got "
                         f"{','.join(map(str, gestures)) or 'nothing'}")
    if gestures and frames is not None:
        raise ValueError("frames is for a clip of distractors only (no gestures); a sequence "
                         "of gestures is as long as they are")
    if not gestures:
        if frames is None:
            raise ValueError("a clip of distractors only needs frames (how long it is)")
        frames = check_int("frames", frames, 1, MAX_SEQUENCE_FRAMES)
    lo, hi = pause
    check_int("pause", lo, 0, MAX_SEGMENT_FRAMES)
    check_int("pause", hi, lo, MAX_SEGMENT_FRAMES)
    seed = check_int("seed", seed, 0, 2 ** 63 - 1)
    rng = np.random.default_rng([seed, _STREAM_SEQUENCE])
    others = np.random.default_rng([seed, _STREAM_DISTRACTOR])
    scene_options = dict(fps=fps, noise=noise, difficulties=difficulties)
    parts, spans, extra, offset = [], [], [], 0

    def add(part, name, into):
        nonlocal offset
        first, last = part.motion_frames
        into.append((name, first + offset, last + offset))
        offset += part.frames
        parts.append(part)

    kinds = []
    hands = np.random.default_rng([seed, _STREAM_HANDS])
    share = hands.uniform(*COMMAND_SHARE)
    due = [hands.uniform()]            # the share's running count: one in command each 1/share

    def distractor(before, after):
        if not kinds:                     # each kind as often as the others
            kinds.extend(others.permutation(len(DISTRACTOR_KINDS)).tolist())
        kind = DISTRACTOR_KINDS[kinds.pop(0)]
        due[0] += share
        in_command = command is not None and due[0] >= 1.0
        due[0] -= in_command
        scene = DistractorScene(kind, seed, width, height, index=len(extra),
                                gesture=gestures[len(spans)] if gestures else "stop",
                                n_pre_rest=before, n_post_rest=after,
                                command=command if in_command else None, **scene_options)
        add(render_scene(scene), kind, extra)

    if not gestures:
        while offset < frames:
            distractor(SEQUENCE_LEAD if not parts else 0, int(others.integers(lo, hi + 1)))
    for k, gesture in enumerate(gestures):
        after = SEQUENCE_TAIL if k == len(gestures) - 1 else int(rng.integers(lo, hi + 1))
        if distractors:
            distractor(SEQUENCE_LEAD if k == 0 else 0, int(others.integers(lo, hi + 1)))
        add(render_clip(gesture, seed, width, height,
                        n_pre_rest=SEQUENCE_LEAD if k == 0 and not distractors else 0,
                        n_post_rest=after, posture=postures[k], **scene_options), gesture, spans)
    # the scene's description: the first gesture's (a distractor's names its kind)
    head = next((p for p in parts if p.gesture is not None), parts[0])
    end = frames if not gestures else offset
    extra = [(kind, first, min(last, end - 1)) for kind, first, last in extra if first < end]
    covered = spans if gestures else extra
    renderer = dict(head.renderer, sequence_pause=[lo, hi])
    if distractors:
        renderer["distractors"] = True
        renderer["distractor_command_share"] = round(float(share), 4) \
            if command is not None else 0.0
    return Clip(gesture=gestures[-1] if gestures else None, seed=head.seed, fps=head.fps,
                hand_disparity=head.hand_disparity, face_disparity=head.face_disparity,
                motion_frames=(covered[0][1], covered[-1][2]),
                left=np.concatenate([p.left for p in parts])[:end],
                right=np.concatenate([p.right for p in parts])[:end],
                hand_xy=np.concatenate([p.hand_xy for p in parts])[:end],
                hand_area=np.concatenate([p.hand_area for p in parts])[:end],
                sequence=tuple(spans), distractors=tuple(extra) if distractors else None,
                postures=sum((p.postures for p in parts), ())[:end], renderer=renderer)
