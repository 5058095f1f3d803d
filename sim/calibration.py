"""Stereo calibration from chessboard pairs (OpenCV's ``stereoCalibrate`` and
``stereoRectify``), the calibration file, and chessboard pairs rendered from a
known rig, so that tests can check what the calibration recovers.

The file (``stereogest calibrate PAIRS -o CALIB.json``) holds both cameras'
intrinsics and distortion, the right camera's pose R, T relative to the left
one, the rectifying rotations and projections R1, R2, P1, P2, Q, and the RMS
reprojection error; :func:`load_calibration` validates every field.
:func:`stereo_rectification` turns it into the compressed maps the model and
the hardware use (:mod:`sim.model.rectify`).
"""
from __future__ import annotations

import json
import math
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from sim.model.rectify import StereoRectification, compress_map, map_size
from sim.model.validation import check_int, check_number

__all__ = ["FORMAT", "DEFAULT_PATTERN", "DEFAULT_SQUARE_MM", "StereoRig", "Calibration",
           "parse_pattern", "render_chessboard_pairs", "find_corners", "calibrate",
           "save_calibration", "load_calibration", "stereo_rectification", "rig_calibration",
           "misalign_frames", "camera_frames"]

FORMAT = "stereogest-calibration"
VERSION = 1
#: Inner corners (columns x rows) and square side of the default chessboard.
DEFAULT_PATTERN = (9, 6)
DEFAULT_SQUARE_MM = 25.0
#: Pairs the calibration needs at least (OpenCV's needs several views).
MIN_PAIRS = 5


def parse_pattern(text: str) -> tuple[int, int]:
    """``"9x6"`` -> (9, 6): inner corners per row and per column, each in [3, 40]."""
    try:
        cols, rows = (int(part) for part in str(text).lower().split("x"))
    except ValueError:
        raise ValueError(f"--pattern must be COLSxROWS inner corners (e.g. 9x6), "
                         f"got {text!r}") from None
    return check_int("--pattern columns", cols, 3, 40), check_int("--pattern rows", rows, 3, 40)


def _rotation(roll: float, pitch: float, yaw: float) -> np.ndarray:
    """Rotation matrix of angles in degrees about z (roll), x (pitch), y (yaw)."""
    r, p, y = (math.radians(a) for a in (roll, pitch, yaw))
    rz = np.array([[math.cos(r), -math.sin(r), 0], [math.sin(r), math.cos(r), 0], [0, 0, 1]])
    rx = np.array([[1, 0, 0], [0, math.cos(p), -math.sin(p)], [0, math.sin(p), math.cos(p)]])
    ry = np.array([[math.cos(y), 0, math.sin(y)], [0, 1, 0], [-math.sin(y), 0, math.cos(y)]])
    return rz @ rx @ ry


@dataclass(frozen=True)
class StereoRig:
    """A pair of pinhole cameras with lens distortion: what a test renders
    chessboards (and misaligned clips) from and checks the calibration against.

    ``rotation`` (roll, pitch, yaw in degrees) and ``translation`` (mm) take a
    point from the left camera's frame to the right one's: X_r = R X_l + T.
    Distortion is OpenCV's (k1, k2, p1, p2, k3).
    """
    width: int = 640
    height: int = 480
    focal: tuple[float, float] = (600.0, 606.0)            #: left, right (pixels)
    centre_left: tuple[float, float] = (321.0, 238.0)
    centre_right: tuple[float, float] = (318.0, 242.0)
    distortion_left: tuple = (-0.03, 0.01, 0.0, 0.0, 0.0)
    distortion_right: tuple = (-0.02, 0.005, 0.0, 0.0, 0.0)
    rotation: tuple[float, float, float] = (0.6, 0.4, -0.5)  #: roll, pitch, yaw (degrees)
    translation: tuple[float, float, float] = (-60.0, 1.2, 0.8)  #: mm

    def camera_matrix(self, side: str) -> np.ndarray:
        f = self.focal[0 if side == "left" else 1]
        cx, cy = self.centre_left if side == "left" else self.centre_right
        return np.array([[f, 0, cx], [0, f, cy], [0, 0, 1]], np.float64)

    def distortion(self, side: str) -> np.ndarray:
        return np.array(self.distortion_left if side == "left" else self.distortion_right,
                        np.float64)

    def resized(self, width: int, height: int) -> "StereoRig":
        """The same rig with ``width`` x ``height`` pictures: focal lengths scale
        with the width, principal points with each axis; the pose and the lens
        distortion (in normalised coordinates) stay."""
        import dataclasses
        fx, fy = width / self.width, height / self.height
        return dataclasses.replace(
            self, width=width, height=height, focal=tuple(f * fx for f in self.focal),
            centre_left=(self.centre_left[0] * fx, self.centre_left[1] * fy),
            centre_right=(self.centre_right[0] * fx, self.centre_right[1] * fy))

    @property
    def R(self) -> np.ndarray:
        return _rotation(*self.rotation)

    @property
    def T(self) -> np.ndarray:
        return np.array(self.translation, np.float64)


def _board_image(rig: StereoRig, side: str, board_r, board_t, pattern, square, samples=2):
    """One camera's view of the board (board frame -> left camera: board_r,
    board_t), anti-aliased over samples x samples points per pixel."""
    import cv2
    cols, rows = pattern
    if side == "right":
        board_r, board_t = rig.R @ board_r, rig.R @ board_t + rig.T
    k, d = rig.camera_matrix(side), rig.distortion(side)
    offsets = (np.arange(samples) + 0.5) / samples - 0.5
    total = np.zeros((rig.height, rig.width))
    ys, xs = np.mgrid[0:rig.height, 0:rig.width].astype(np.float64)
    normal = board_r[:, 2]
    for oy in offsets:
        for ox in offsets:
            pts = np.stack([xs + ox, ys + oy], -1).reshape(-1, 1, 2)
            rays = cv2.undistortPoints(pts, k, d, criteria=(
                cv2.TERM_CRITERIA_COUNT | cv2.TERM_CRITERIA_EPS, 20, 1e-6)).reshape(-1, 2)
            rays = np.column_stack([rays, np.ones(len(rays))])
            depth = (normal @ board_t) / (rays @ normal)
            points = rays * depth[:, None] - board_t
            u, v = (points @ board_r)[:, 0], (points @ board_r)[:, 1]
            # squares from -1 to cols (rows): a white margin of one square around
            iu, iv = np.floor(u / square), np.floor(v / square)
            on_board = (iu >= -2) & (iu <= cols + 1) & (iv >= -2) & (iv <= rows + 1) & (depth > 0)
            inner = (iu >= -1) & (iu <= cols - 1) & (iv >= -1) & (iv <= rows - 1)
            value = np.where(on_board, np.where(inner & ((iu + iv) % 2 == 0), 30.0, 225.0), 110.0)
            total += value.reshape(rig.height, rig.width)
    return np.clip(np.rint(total / samples ** 2), 0, 255).astype(np.uint8)


def render_chessboard_pairs(rig: StereoRig = StereoRig(), count: int = 12, *, seed: int = 1,
                            pattern=DEFAULT_PATTERN, square: float = DEFAULT_SQUARE_MM):
    """``count`` (left, right) grey pairs of a chessboard at random poses that both
    cameras see whole: tilted up to 35 degrees, 450-800 mm away, anywhere in
    the picture (a calibration needs boards near the corners, where the lens
    distorts most)."""
    import cv2
    count = check_int("count", count, 1, 1000)
    rng = np.random.default_rng(seed)
    cols, rows = pattern
    corners = np.array([[x * square, y * square, 0] for y in range(-1, rows + 1)
                        for x in range(-1, cols + 1)], np.float64)
    pairs = []
    while len(pairs) < count:
        board_r = _rotation(rng.uniform(-20, 20), rng.uniform(-35, 35), rng.uniform(-35, 35))
        distance = rng.uniform(450, 800)
        lateral = rng.uniform(-0.45, 0.45, 2) * distance * np.array([1.0, 0.75])
        centre = np.array([lateral[0], lateral[1], distance])
        board_t = centre - board_r @ np.array([(cols - 1) * square / 2,
                                               (rows - 1) * square / 2, 0])
        visible = True
        for side, r, t in (("left", board_r, board_t),
                           ("right", rig.R @ board_r, rig.R @ board_t + rig.T)):
            img_pts, _ = cv2.projectPoints(corners, cv2.Rodrigues(r)[0], t,
                                           rig.camera_matrix(side), rig.distortion(side))
            img_pts = img_pts.reshape(-1, 2)
            margin = 12
            if not ((img_pts[:, 0] > margin).all() and (img_pts[:, 0] < rig.width - margin).all()
                    and (img_pts[:, 1] > margin).all()
                    and (img_pts[:, 1] < rig.height - margin).all()):
                visible = False
        if visible:
            pairs.append(tuple(_board_image(rig, side, board_r, board_t, pattern, square)
                               for side in ("left", "right")))
    return pairs


def find_corners(image, pattern):
    """The chessboard's inner corners (N, 2) float32, refined to sub-pixel, or
    None if the board is not found."""
    import cv2
    found, corners = cv2.findChessboardCorners(
        image, tuple(pattern), flags=cv2.CALIB_CB_ADAPTIVE_THRESH | cv2.CALIB_CB_NORMALIZE_IMAGE)
    if not found:
        return None
    return cv2.cornerSubPix(image, corners, (5, 5), (-1, -1),
                            (cv2.TERM_CRITERIA_EPS | cv2.TERM_CRITERIA_COUNT, 50, 1e-4)
                            ).reshape(-1, 2)


@dataclass(frozen=True, eq=False)
class Calibration:
    """A calibrated stereo pair (OpenCV conventions; lengths in the unit of the
    chessboard square, mm)."""
    width: int
    height: int
    camera_left: np.ndarray         #: 3x3
    distortion_left: np.ndarray     #: 5
    camera_right: np.ndarray
    distortion_right: np.ndarray
    R: np.ndarray                   #: 3x3, left -> right
    T: np.ndarray                   #: 3
    R1: np.ndarray                  #: 3x3 rectifying rotations
    R2: np.ndarray
    P1: np.ndarray                  #: 3x4 rectified projections
    P2: np.ndarray
    Q: np.ndarray                   #: 4x4 disparity-to-depth
    rms: float                      #: RMS reprojection error, pixels
    pairs: int = 0                  #: chessboard pairs used
    pattern: tuple = DEFAULT_PATTERN
    square: float = DEFAULT_SQUARE_MM

    @property
    def baseline(self) -> float:
        return float(np.linalg.norm(self.T))


_SHAPES = {"camera_left": (3, 3), "distortion_left": (5,), "camera_right": (3, 3),
           "distortion_right": (5,), "R": (3, 3), "T": (3,), "R1": (3, 3), "R2": (3, 3),
           "P1": (3, 4), "P2": (3, 4), "Q": (4, 4)}


def calibrate(pairs, pattern=DEFAULT_PATTERN, square: float = DEFAULT_SQUARE_MM) -> Calibration:
    """Calibrate from (left, right) grey image pairs of a chessboard with
    ``pattern`` inner corners and ``square`` mm squares; pairs where either
    camera misses the board are skipped."""
    import cv2
    pairs = list(pairs)
    if not pairs:
        raise ValueError("PAIRS holds no image pairs")
    shape = pairs[0][0].shape
    for left, right in pairs:
        if left.shape != shape or right.shape != shape or left.ndim != 2:
            raise ValueError(f"every image must be one grey {shape[1]}x{shape[0]} picture")
    cols, rows = pattern
    board = np.zeros((cols * rows, 3), np.float32)
    board[:, :2] = np.mgrid[0:cols, 0:rows].T.reshape(-1, 2) * square
    objects, points_l, points_r = [], [], []
    for left, right in pairs:
        cl, cr = find_corners(left, pattern), find_corners(right, pattern)
        if cl is not None and cr is not None:
            objects.append(board)
            points_l.append(cl.reshape(-1, 1, 2))
            points_r.append(cr.reshape(-1, 1, 2))
    if len(objects) < MIN_PAIRS:
        raise ValueError(f"PAIRS: the {cols}x{rows} chessboard was found in both images of "
                         f"{len(objects)} of {len(pairs)} pairs; at least {MIN_PAIRS} are needed "
                         f"(check --pattern: inner corners, not squares)")
    size = (shape[1], shape[0])
    _, k1, d1, _, _ = cv2.calibrateCamera(objects, points_l, size, None, None)
    _, k2, d2, _, _ = cv2.calibrateCamera(objects, points_r, size, None, None)
    criteria = (cv2.TERM_CRITERIA_COUNT | cv2.TERM_CRITERIA_EPS, 200, 1e-9)
    rms, k1, d1, k2, d2, r, t, _, _ = cv2.stereoCalibrate(
        objects, points_l, points_r, k1, d1, k2, d2, size, criteria=criteria,
        flags=cv2.CALIB_USE_INTRINSIC_GUESS)
    r1, r2, p1, p2, q = rectify_rig(k1, d1, k2, d2, size, r, t)
    return Calibration(size[0], size[1], k1, d1.ravel()[:5], k2, d2.ravel()[:5], r, t.ravel(),
                       r1, r2, p1, p2, q, float(rms), len(objects), tuple(pattern), float(square))


def rectify_rig(k1, d1, k2, d2, size, r, t):
    """R1, R2, P1, P2, Q of ``cv2.stereoRectify`` (principal points equal, alpha
    -1: OpenCV's own scaling; alpha 0, no black border, zooms in and doubles the
    largest displacement, measured on StereoRig()), then both rectified images
    moved by the same whole offset that centres the range of displacements
    (source minus output) over both cameras: rows stay aligned and disparities
    unchanged, and the row buffers need reach only half that range (the
    default rig's vertical reach: 17 -> 14 pixels)."""
    import cv2
    r1, r2, p1, p2, q, _, _ = cv2.stereoRectify(k1, d1, k2, d2, size, r,
                                                np.asarray(t, np.float64).reshape(3, 1),
                                                flags=cv2.CALIB_ZERO_DISPARITY, alpha=-1)
    p1, p2, q = p1.copy(), p2.copy(), q.copy()
    for _ in range(2):          # the range moves a little with the sampled region
        low, high = np.full(2, np.inf), np.full(2, -np.inf)
        for k, d, rr, pp in ((k1, d1, r1, p1), (k2, d2, r2, p2)):
            mx, my = cv2.initUndistortRectifyMap(k, d, rr, pp, size, cv2.CV_32FC1)
            ys, xs = np.mgrid[0:size[1], 0:size[0]]
            for axis, disp in enumerate((mx - xs, my - ys)):
                low[axis] = min(low[axis], float(disp.min()))
                high[axis] = max(high[axis], float(disp.max()))
        centre = np.round((low + high) / 2)
        for pp in (p1, p2):
            pp[0, 2] += centre[0]
            pp[1, 2] += centre[1]
        q[0, 3] -= centre[0]
        q[1, 3] -= centre[1]
    return r1, r2, p1, p2, q


def _document(calib: Calibration) -> dict:
    doc = {"format": FORMAT, "version": VERSION, "image_size": [calib.width, calib.height],
           "pattern": list(calib.pattern), "square_mm": calib.square, "pairs": calib.pairs,
           "rms_px": calib.rms}
    for name in _SHAPES:
        doc[name] = np.asarray(getattr(calib, name), np.float64).tolist()
    return doc


def save_calibration(calib: Calibration, path) -> Path:
    """Write ``path`` (JSON) atomically: a failure leaves no half-written file."""
    from sim.atomic import write_text_atomic
    return write_text_atomic(path, json.dumps(_document(calib), indent=1) + "\n")


def load_calibration(path) -> Calibration:
    """Read and validate a calibration file; ``ValueError`` names the field."""
    path = Path(path)
    try:
        doc = json.loads(path.read_text())
    except (UnicodeDecodeError, json.JSONDecodeError) as exc:
        raise ValueError(f"{path}: not a calibration file (not JSON: {exc})") from None
    if not isinstance(doc, dict) or doc.get("format") != FORMAT:
        raise ValueError(f"{path}: not a calibration file (no \"format\": \"{FORMAT}\")")
    if doc.get("version") != VERSION:
        raise ValueError(f"{path}: version must be {VERSION}, got {doc.get('version')!r}")

    def where(name):
        return f"{path}: {name}"

    try:
        width, height = doc["image_size"]
    except (KeyError, TypeError, ValueError):
        raise ValueError(f"{where('image_size')} must be [width, height]") from None
    width = check_int(where("image_size[0]"), width, 16, 4096)
    height = check_int(where("image_size[1]"), height, 16, 4096)
    arrays = {}
    for name, shape in _SHAPES.items():
        try:
            arr = np.array(doc[name], np.float64)
        except KeyError:
            raise ValueError(f"{where(name)} is missing") from None
        except (TypeError, ValueError):
            raise ValueError(f"{where(name)} must be a {shape} array of numbers") from None
        if arr.shape != shape or not np.isfinite(arr).all():
            raise ValueError(f"{where(name)} must be a finite {shape} array, got shape "
                             f"{arr.shape}")
        arrays[name] = arr
    for name in ("camera_left", "camera_right"):
        k = arrays[name]
        if not (k[0, 0] > 0 and k[1, 1] > 0 and np.allclose(k[2], [0, 0, 1])):
            raise ValueError(f"{where(name)} must be a camera matrix (positive focal "
                             f"lengths, last row 0 0 1)")
    for name in ("R", "R1", "R2"):
        r = arrays[name]
        if not (np.allclose(r @ r.T, np.eye(3), atol=1e-6) and abs(np.linalg.det(r) - 1) < 1e-6):
            raise ValueError(f"{where(name)} must be a rotation matrix")
    rms = check_number(where("rms_px"), doc.get("rms_px"), 0, 1000)
    pairs = check_int(where("pairs"), doc.get("pairs", 0), 0, 100000)
    pattern = doc.get("pattern", list(DEFAULT_PATTERN))
    if not (isinstance(pattern, list) and len(pattern) == 2):
        raise ValueError(f"{where('pattern')} must be [columns, rows]")
    square = check_number(where("square_mm"), doc.get("square_mm", DEFAULT_SQUARE_MM), 0, 1e4,
                          lo_open=True)
    return Calibration(
        width, height, arrays["camera_left"], arrays["distortion_left"],
        arrays["camera_right"], arrays["distortion_right"], arrays["R"], arrays["T"],
        arrays["R1"], arrays["R2"], arrays["P1"], arrays["P2"], arrays["Q"], rms, pairs,
        tuple(int(v) for v in pattern), square)


def stereo_rectification(calib: Calibration, width: int | None = None,
                         height: int | None = None, *, grid_step: int = 16,
                         frac_bits: int = 5, interpolation: str = "bilinear"
                         ) -> StereoRectification:
    """The compressed maps of both cameras (``cv2.initUndistortRectifyMap``,
    sampled on the grid). The frame must be the calibrated size.

    ``grid_step`` 16: on the default rig the interpolated map is as close to the
    full one as with 8 (mean 0.014 px, max 0.044 px; the fraction's rounding
    dominates) at a quarter of the grid memory; ``frac_bits`` 5, as OpenCV's
    own bilinear weights (benchmarks/bench_rectify.py)."""
    import cv2
    width = calib.width if width is None else width
    height = calib.height if height is None else height
    if (width, height) != (calib.width, calib.height):
        raise ValueError(f"the calibration is for {calib.width}x{calib.height} frames, "
                         f"not {width}x{height}")
    size = map_size(width, height, grid_step)          # checks grid_step
    grids = []
    for k, d, r, p in ((calib.camera_left, calib.distortion_left, calib.R1, calib.P1),
                       (calib.camera_right, calib.distortion_right, calib.R2, calib.P2)):
        mx, my = cv2.initUndistortRectifyMap(k, d, r, p, size, cv2.CV_32FC1)
        grids.append(compress_map(mx, my, width, height, grid_step=grid_step,
                                  frac_bits=frac_bits))
    return StereoRectification(grids[0], grids[1], interpolation)


def rig_calibration(rig: StereoRig) -> Calibration:
    """The calibration a perfect calibration of ``rig`` would give: its own
    intrinsics and pose, rectified as :func:`calibrate` rectifies."""
    k1, d1, k2, d2 = (rig.camera_matrix("left"), rig.distortion("left"),
                      rig.camera_matrix("right"), rig.distortion("right"))
    r1, r2, p1, p2, q = rectify_rig(k1, d1, k2, d2, (rig.width, rig.height), rig.R, rig.T)
    return Calibration(rig.width, rig.height, k1, d1, k2, d2, rig.R, rig.T, r1, r2, p1, p2, q,
                       0.0)


def _remap_frames(frames, map_x, map_y):
    """YCbCr 4:2:2 frames (F, H, 2W), each channel of each frame resampled at
    (``map_x``, ``map_y``) in 4:4:4 (bilinear, black outside), then 4:2:2 again."""
    import cv2

    from sim.model.ycbcr import ycbcr422_to_444, ycbcr444_to_422
    out = np.empty_like(np.asarray(frames))
    for n, frame in enumerate(frames):
        channels = ycbcr422_to_444(frame)
        if channels[0].shape != map_x.shape:
            raise ValueError("frames must be {}x{} (the maps')".format(*map_x.shape[::-1]))
        warped = [cv2.remap(np.ascontiguousarray(c), map_x, map_y, cv2.INTER_LINEAR,
                            borderMode=cv2.BORDER_CONSTANT, borderValue=fill)
                  for c, fill in zip(channels, (0, 128, 128))]
        out[n] = ycbcr444_to_422(*warped)
    return out


def camera_frames(frames, calib: Calibration, side: str):
    """What ``side``'s camera of the calibrated rig sees of rectified frames: YCbCr
    4:2:2 frames (F, H, 2W) rendered as the rectified view (the renderer's
    cameras are perfectly aligned), warped through the camera's inverse
    rectification map (``cv2.initInverseRectificationMap``: lens distortion,
    rotation, principal point)."""
    import cv2
    if side not in ("left", "right"):
        raise ValueError(f"side must be left or right, got {side!r}")
    k, d, r, p = ((calib.camera_left, calib.distortion_left, calib.R1, calib.P1)
                  if side == "left" else
                  (calib.camera_right, calib.distortion_right, calib.R2, calib.P2))
    inv_x, inv_y = cv2.initInverseRectificationMap(k, d, r, p, (calib.width, calib.height),
                                                   cv2.CV_32FC1)
    return _remap_frames(frames, inv_x, inv_y)


def misalign_frames(frames, homography):
    """YCbCr 4:2:2 camera frames (F, H, 2W) as a camera misaligned by
    ``homography`` (rectified pixel -> camera pixel, as
    :func:`sim.model.rectify.homography_maps` takes it) would have taken them."""
    from sim.model.rectify import homography_maps
    h, w2 = np.shape(frames)[-2:]
    return _remap_frames(frames, *homography_maps(np.linalg.inv(homography), w2 // 2, h))
