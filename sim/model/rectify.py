"""Stereo rectification from a compressed map (thesis §10.1, future work; the
stage :class:`hdl.rectify.Rectifier` computes the same integers).

Each camera's rectifying map gives, for every output pixel (x, y), the source
position in the camera image. It is kept as a grid sampled every ``grid_step``
(S, a power of two) pixels in both directions, of displacements ``source -
output`` in fixed point with ``frac_bits`` (F) fraction bits, as published FPGA
rectifiers keep it (8x sub-sampled maps, Junger et al., SPIE 11144, 2019).
For an output pixel with ``x = gx * S + fx`` and ``y = gy * S + fy``:

    V(i)  = (S - fy) * G[gy, i] + fy * G[gy + 1, i]          i = gx, gx + 1
    disp  = ((S - fx) * V(gx) + fx * V(gx + 1) + S*S / 2) >> 2 log2(S)
    src   = (x << F) + disp                                  (per axis)

then, with ``ix = sx >> F``, ``ax = sx & (2^F - 1)`` (and so for y), the pixel is
the bilinear blend of the four source pixels around it,

    ((2^F - ax)(2^F - ay) P[iy, ix] + ax (2^F - ay) P[iy, ix + 1]
     + (2^F - ax) ay P[iy + 1, ix] + ax ay P[iy + 1, ix + 1] + 2^(2F - 1)) >> 2F,

or (``interpolation="nearest"``) the pixel at ``(sx + 2^(F-1)) >> F``. A source
pixel outside the image counts 0 (OpenCV's ``BORDER_CONSTANT``). The grid has
``(W - 1) // S + 2`` columns and ``(H - 1) // S + 2`` rows, so that ``gx + 1``
and ``gy + 1`` always exist; its last column and row may lie beyond the frame
(the map is a smooth function there too).

The full float maps come from a calibration (:mod:`sim.calibration`,
``cv2.initUndistortRectifyMap``) or from a known warp (:func:`homography_maps`);
``cv2.remap`` on those full maps is the oracle the tests measure this against.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .validation import check_image, check_int

__all__ = ["GRID_STEP_RANGE", "FRAC_BITS_RANGE", "INTERPOLATIONS", "RectifyGrid",
           "StereoRectification", "rectify_pair",
           "grid_shape", "map_size", "compress_map", "source_positions", "rectify",
           "homography_maps", "misalignment", "identity_grid"]

#: Grid steps S (powers of two).
GRID_STEP_RANGE = (2, 64)
#: Fraction bits F of the grid and of the source positions.
FRAC_BITS_RANGE = (1, 8)
INTERPOLATIONS = ("bilinear", "nearest")
#: Largest displacement a grid holds, pixels (a row buffer of twice as many rows).
MAX_SHIFT = 255


def _check_grid_step(grid_step) -> int:
    step = check_int("grid_step", grid_step, *GRID_STEP_RANGE)
    if step & (step - 1):
        raise ValueError(f"grid_step must be a power of two in {list(GRID_STEP_RANGE)}, "
                         f"got {step}")
    return step


def grid_shape(width: int, height: int, grid_step: int) -> tuple[int, int]:
    """Rows and columns of the grid for a ``width`` x ``height`` frame."""
    step = _check_grid_step(grid_step)
    return (height - 1) // step + 2, (width - 1) // step + 2


def map_size(width: int, height: int, grid_step: int) -> tuple[int, int]:
    """``(width, height)`` of the full map the grid is sampled from: it reaches the
    grid's last column and row (pass this size to ``cv2.initUndistortRectifyMap``)."""
    rows, cols = grid_shape(width, height, grid_step)
    return (cols - 1) * grid_step + 1, (rows - 1) * grid_step + 1


@dataclass(frozen=True, eq=False)
class RectifyGrid:
    """The compressed map of one camera.

    Attributes
    ----------
    dx, dy : (rows, cols) int32 arrays
        Source minus output position at the grid points, in 1/2^F pixels.
    width, height : int
        The frame size the grid is for.
    grid_step : int
        S, a power of two in :data:`GRID_STEP_RANGE`.
    frac_bits : int
        F, in :data:`FRAC_BITS_RANGE`.
    """
    dx: np.ndarray
    dy: np.ndarray
    width: int
    height: int
    grid_step: int
    frac_bits: int

    def __post_init__(self):
        check_int("width", self.width, 2, 4096)
        check_int("height", self.height, 2, 4096)
        _check_grid_step(self.grid_step)
        check_int("frac_bits", self.frac_bits, *FRAC_BITS_RANGE)
        shape = grid_shape(self.width, self.height, self.grid_step)
        limit = MAX_SHIFT << self.frac_bits
        for name in ("dx", "dy"):
            arr = np.asarray(getattr(self, name))
            if arr.shape != shape or arr.dtype.kind not in "iu":
                raise ValueError(f"{name} must be an integer grid of shape {shape}, "
                                 f"got {arr.dtype} {arr.shape}")
            if arr.size and np.abs(arr.astype(np.int64)).max() > limit:
                raise ValueError(f"{name} must stay within +-{MAX_SHIFT} pixels, got "
                                 f"{np.abs(arr.astype(np.int64)).max() / (1 << self.frac_bits):g}")
            object.__setattr__(self, name, arr.astype(np.int32))

    @property
    def max_shift(self) -> tuple[int, int]:
        """``(x, y)``: the largest whole-pixel displacement the grid asks for
        (rounded up), which the hardware's row buffers must reach."""
        one = 1 << self.frac_bits
        return tuple(int(-(-int(np.abs(a.astype(np.int64)).max()) // one))
                     for a in (self.dx, self.dy))


def compress_map(map_x, map_y, width: int, height: int, *, grid_step: int = 8,
                 frac_bits: int = 4) -> RectifyGrid:
    """The grid of a full float map (``map_x[y, x]``, ``map_y[y, x]``: source
    position of output pixel (x, y)) of at least :func:`map_size`, rounded to F
    fraction bits."""
    step = _check_grid_step(grid_step)
    frac_bits = check_int("frac_bits", frac_bits, *FRAC_BITS_RANGE)
    need_w, need_h = map_size(width, height, step)
    map_x, map_y = np.asarray(map_x, np.float64), np.asarray(map_y, np.float64)
    if map_x.shape != map_y.shape or map_x.ndim != 2 \
            or map_x.shape[0] < need_h or map_x.shape[1] < need_w:
        raise ValueError(f"map_x and map_y must be equal float maps of at least "
                         f"{need_w}x{need_h} (map_size), got {map_x.shape} and {map_y.shape}")
    if not (np.isfinite(map_x[:need_h, :need_w]).all()
            and np.isfinite(map_y[:need_h, :need_w]).all()):
        raise ValueError("map_x and map_y must be finite")
    ys = np.arange(0, need_h, step)
    xs = np.arange(0, need_w, step)
    scale = 1 << frac_bits
    dx = np.rint((map_x[np.ix_(ys, xs)] - xs[None, :]) * scale).astype(np.int64)
    dy = np.rint((map_y[np.ix_(ys, xs)] - ys[:, None]) * scale).astype(np.int64)
    return RectifyGrid(dx, dy, width, height, step, frac_bits)


def identity_grid(width: int, height: int, *, grid_step: int = 8,
                  frac_bits: int = 4) -> RectifyGrid:
    """A grid that moves nothing."""
    shape = grid_shape(width, height, grid_step)
    zero = np.zeros(shape, np.int32)
    return RectifyGrid(zero, zero, width, height, grid_step, frac_bits)


def source_positions(grid: RectifyGrid) -> tuple[np.ndarray, np.ndarray]:
    """``(sx, sy)``: every output pixel's source position in 1/2^F pixels, (H, W)
    int64 each, interpolated from the grid as the hardware does."""
    s = grid.grid_step
    shift = 2 * (s.bit_length() - 1)
    ys, xs = np.arange(grid.height), np.arange(grid.width)
    gy, fy = ys // s, (ys % s)[:, None]
    gx, fx = xs // s, (xs % s)[None, :]
    out = []
    for g, axis in ((grid.dx, xs[None, :]), (grid.dy, ys[:, None])):
        g = g.astype(np.int64)
        v = (s - fy) * g[gy] + fy * g[gy + 1]                      # (H, cols)
        disp = ((s - fx) * v[:, gx] + fx * v[:, gx + 1] + (1 << (shift - 1))) >> shift
        out.append((axis.astype(np.int64) << grid.frac_bits) + disp)
    return out[0], out[1]


def _taps(image, ix, iy):
    """``image[iy, ix]``, 0 where (ix, iy) lies outside."""
    h, w = image.shape
    inside = (ix >= 0) & (ix < w) & (iy >= 0) & (iy < h)
    values = image[np.clip(iy, 0, h - 1), np.clip(ix, 0, w - 1)].astype(np.int64)
    return np.where(inside, values, 0)


def rectify(image, grid: RectifyGrid, interpolation: str = "bilinear") -> np.ndarray:
    """The rectified ``image`` (H, W) of 8-bit values, uint8."""
    image = check_image("image", image, max_value=255)
    if image.shape != (grid.height, grid.width):
        raise ValueError(f"image must be {grid.width}x{grid.height} (the grid's frame), "
                         f"got {image.shape[1]}x{image.shape[0]}")
    if interpolation not in INTERPOLATIONS:
        raise ValueError(f"interpolation must be one of {', '.join(INTERPOLATIONS)}, "
                         f"got {interpolation!r}")
    f = grid.frac_bits
    sx, sy = source_positions(grid)
    if interpolation == "nearest":
        half = 1 << (f - 1)
        return _taps(image, (sx + half) >> f, (sy + half) >> f).astype(np.uint8)
    ix, iy = sx >> f, sy >> f
    one = 1 << f
    ax, ay = sx & (one - 1), sy & (one - 1)
    total = ((one - ax) * (one - ay) * _taps(image, ix, iy)
             + ax * (one - ay) * _taps(image, ix + 1, iy)
             + (one - ax) * ay * _taps(image, ix, iy + 1)
             + ax * ay * _taps(image, ix + 1, iy + 1)
             + (1 << (2 * f - 1)))
    return (total >> (2 * f)).astype(np.uint8)


@dataclass(frozen=True, eq=False)
class StereoRectification:
    """Both cameras' grids and the interpolation: what the pipeline rectifies
    with (made by :func:`sim.calibration.stereo_rectification`)."""
    left: RectifyGrid
    right: RectifyGrid
    interpolation: str = "bilinear"

    def __post_init__(self):
        for side in ("left", "right"):
            if not isinstance(getattr(self, side), RectifyGrid):
                raise ValueError(f"{side} must be a RectifyGrid")
        a, b = self.left, self.right
        if (a.width, a.height, a.grid_step, a.frac_bits) != \
                (b.width, b.height, b.grid_step, b.frac_bits):
            raise ValueError("left and right grids must share frame size, grid_step and "
                             "frac_bits")
        if self.interpolation not in INTERPOLATIONS:
            raise ValueError(f"interpolation must be one of {', '.join(INTERPOLATIONS)}, "
                             f"got {self.interpolation!r}")

    @property
    def size(self) -> tuple[int, int]:
        return self.left.width, self.left.height

    def digest(self) -> str:
        """A short hash of both grids and the interpolation (build caches)."""
        import hashlib
        h = hashlib.sha256(self.interpolation.encode())
        for g in (self.left, self.right):
            h.update(repr((g.width, g.height, g.grid_step, g.frac_bits)).encode())
            h.update(g.dx.tobytes())
            h.update(g.dy.tobytes())
        return h.hexdigest()[:12]

    @property
    def max_shift(self) -> tuple[int, int]:
        """``(x, y)`` reach of both cameras' row buffers (one value, so that both
        stages have the same latency)."""
        (lx, ly), (rx, ry) = self.left.max_shift, self.right.max_shift
        return max(lx, rx), max(ly, ry)


def rectify_pair(left_channels, right_channels, rectification: StereoRectification):
    """Each channel of the left camera (a sequence of (H, W) images: Y, Cb, Cr)
    and of the right camera, rectified with its camera's grid."""
    return ([rectify(c, rectification.left, rectification.interpolation)
             for c in left_channels],
            [rectify(c, rectification.right, rectification.interpolation)
             for c in right_channels])


def homography_maps(homography, width: int, height: int) -> tuple[np.ndarray, np.ndarray]:
    """Full float maps (``map_x``, ``map_y``, float32, ``height`` x ``width``) of the
    source positions ``homography @ (x, y, 1)`` of every output pixel (a camera
    rotated about its centre, or shifted, is such a warp)."""
    hom = np.asarray(homography, np.float64)
    if hom.shape != (3, 3) or not np.isfinite(hom).all():
        raise ValueError(f"homography must be a finite 3x3 matrix, got shape {hom.shape}")
    ys, xs = np.mgrid[0:height, 0:width].astype(np.float64)
    den = hom[2, 0] * xs + hom[2, 1] * ys + hom[2, 2]
    if np.any(np.abs(den) < 1e-9):
        raise ValueError("homography sends a pixel to infinity")
    map_x = (hom[0, 0] * xs + hom[0, 1] * ys + hom[0, 2]) / den
    map_y = (hom[1, 0] * xs + hom[1, 1] * ys + hom[1, 2]) / den
    return map_x.astype(np.float32), map_y.astype(np.float32)


def misalignment(width: int, height: int, *, roll: float = 0.0, shift_x: float = 0.0,
                 shift_y: float = 0.0) -> np.ndarray:
    """The homography (rectified pixel -> camera pixel) of a camera rolled by
    ``roll`` degrees about the image centre and whose image is shifted by
    (``shift_x``, ``shift_y``) pixels: the misalignment a test warps a rectified
    pair with, and whose :func:`homography_maps` undo it."""
    a = np.radians(roll)
    c, s = np.cos(a), np.sin(a)
    cx, cy = width / 2, height / 2
    return np.array([[c, -s, cx - c * cx + s * cy + shift_x],
                     [s, c, cy - s * cx - c * cy + shift_y], [0.0, 0.0, 1.0]])
