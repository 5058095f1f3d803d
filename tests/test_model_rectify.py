"""sim/model/rectify.py: the compressed map and the integer remap, exactly on
grids whose answer is known, against loops, and against OpenCV's ``cv2.remap``
with the full float maps (the error distribution docs/figures/stereo.md quotes)."""
import math

import cv2
import numpy as np
import pytest

from sim.images import read_grey
from sim.model.rectify import (RectifyGrid, compress_map, grid_shape, homography_maps,
                               identity_grid, map_size, misalignment, rectify,
                               source_positions)
from tests.hdl_helpers import MIDDLEBURY


def rotation_homography(width, height, degrees, shift_x=0.0, shift_y=0.0):
    return misalignment(width, height, roll=degrees, shift_x=shift_x, shift_y=shift_y)


def grid_of(homography, width, height, grid_step=8, frac_bits=5):
    mw, mh = map_size(width, height, grid_step)
    mx, my = homography_maps(homography, mw, mh)
    return compress_map(mx, my, width, height, grid_step=grid_step, frac_bits=frac_bits)


def test_grid_shape_reaches_past_the_frame():
    assert grid_shape(640, 480, 8) == (61, 81)
    assert map_size(640, 480, 8) == (641, 481)
    assert grid_shape(17, 9, 8) == (3, 4) and map_size(17, 9, 8) == (25, 17)


def test_identity_and_whole_pixel_shifts_are_exact():
    img = np.random.default_rng(0).integers(0, 256, (20, 30)).astype(np.uint8)
    assert (rectify(img, identity_grid(30, 20)) == img).all()
    for dx, dy in ((3, 0), (-2, 1), (0, -4)):
        hom = np.array([[1, 0, dx], [0, 1, dy], [0, 0, 1]], float)
        for interpolation in ("bilinear", "nearest"):
            got = rectify(img, grid_of(hom, 30, 20, grid_step=4, frac_bits=3), interpolation)
            expected = np.zeros_like(img)
            ys, xs = np.mgrid[0:20, 0:30]
            inside = (xs + dx >= 0) & (xs + dx < 30) & (ys + dy >= 0) & (ys + dy < 20)
            expected[inside] = img[(ys + dy)[inside], (xs + dx)[inside]]
            assert (got == expected).all(), (dx, dy, interpolation)


def test_source_positions_against_loops():
    rng = np.random.default_rng(3)
    w, h, step, f = 21, 11, 4, 3
    rows, cols = grid_shape(w, h, step)
    dx, dy = rng.integers(-40, 40, (rows, cols)), rng.integers(-40, 40, (rows, cols))
    grid = RectifyGrid(dx, dy, w, h, step, f)
    sx, sy = source_positions(grid)
    for y in range(h):
        for x in range(w):
            gx, fx, gy, fy = x // step, x % step, y // step, y % step
            for g, base, got in ((dx, x, sx), (dy, y, sy)):
                v0 = (step - fy) * int(g[gy, gx]) + fy * int(g[gy + 1, gx])
                v1 = (step - fy) * int(g[gy, gx + 1]) + fy * int(g[gy + 1, gx + 1])
                disp = math.floor(((step - fx) * v0 + fx * v1 + step * step // 2)
                                  / (step * step))
                assert got[y, x] == (base << f) + disp


def test_homography_maps_equal_opencv():
    hom = rotation_homography(40, 30, 1.5, 0.7, -2.2)
    mx, my = homography_maps(hom, 40, 30)
    pts = np.stack(np.meshgrid(np.arange(40.0), np.arange(30.0)), -1).reshape(-1, 1, 2)
    ref = cv2.perspectiveTransform(pts, hom).reshape(30, 40, 2)
    assert np.abs(mx - ref[..., 0]).max() < 1e-4 and np.abs(my - ref[..., 1]).max() < 1e-4


@pytest.mark.parametrize("scene", ["tsukuba", "cones"])
def test_error_against_cv2_remap(scene):
    image = read_grey(MIDDLEBURY / scene / "left.png")
    h, w = image.shape
    from sim.evaluate import remap_errors
    grey, position = remap_errors(image, rotation_homography(w, h, 0.8, 0.6, 1.7),
                                  grid_step=8, frac_bits=5)
    # OpenCV blends with 5-bit weights too: what is left is the map's rounding
    assert grey.mean() < 0.2 and np.percentile(grey, 99) <= 2 and grey.max() <= 8
    assert position.mean() < 0.02 and position.max() < 0.05
    coarse, _ = remap_errors(image, rotation_homography(w, h, 0.8, 0.6, 1.7),
                             grid_step=8, frac_bits=3)
    assert coarse.mean() > 2 * grey.mean()      # fewer fraction bits, larger error


@pytest.mark.parametrize("call, name", [
    (lambda: grid_shape(64, 48, 3), "grid_step must be a power of two"),
    (lambda: grid_shape(64, 48, 128), "grid_step"),
    (lambda: identity_grid(64, 48, frac_bits=0), "frac_bits"),
    (lambda: RectifyGrid(np.zeros((2, 2), int), np.zeros((2, 2), int), 64, 48, 8, 4), "dx"),
    (lambda: RectifyGrid(*(np.full(grid_shape(16, 8, 8), 256 << 4),) * 2, 16, 8, 8, 4),
     "dx must stay within"),
    (lambda: compress_map(np.zeros((8, 16)), np.zeros((8, 16)), 16, 8), "map_x and map_y"),
    (lambda: compress_map(*(np.full((17, 17), np.nan),) * 2, 16, 8), "finite"),
    (lambda: rectify(np.zeros((8, 17), np.uint8), identity_grid(16, 8)), "image must be 16x8"),
    (lambda: rectify(np.zeros((8, 16), np.uint8), identity_grid(16, 8), "cubic"),
     "interpolation"),
    (lambda: homography_maps(np.eye(2), 4, 4), "homography"),
])
def test_bad_arguments_name_themselves(call, name):
    with pytest.raises(ValueError, match=name):
        call()


@pytest.mark.parametrize("scene, ndisp, scale", [("tsukuba", 32, 16), ("venus", 32, 8),
                                                  ("cones", 64, 4)])
def test_rectification_recovers_middlebury_accuracy(scene, ndisp, scale):
    """Both cameras misaligned (sim.evaluate.MISALIGNMENT: under a degree of roll,
    about a pixel of shift): unrectified the matcher fails, rectified it comes
    back within a point of the aligned pair, as cv2.remap's float maps do
    (over the pixels whose windows both cameras saw whole)."""
    from sim.evaluate import misaligned_scores
    from sim.images import read_array
    folder = MIDDLEBURY / scene
    r = misaligned_scores(read_grey(folder / "left.png"), read_grey(folder / "right.png"),
                          read_array(folder / "disp_left.png"), scale,
                          matcher=dict(census_window=7, hamming_window=13, lrcc_threshold=8,
                                       max_disparity=ndisp))
    good = {k: r[k]["pct_good"] for k in ("original", "unrectified", "rectified",
                                          "rectified_cv2")}
    assert good["unrectified"] < good["original"] - 30
    assert abs(good["rectified"] - good["original"]) <= 1.0
    assert abs(r["rectified"]["pct_good_excluding_left"]
               - r["original"]["pct_good_excluding_left"]) <= 1.0
    assert abs(good["rectified"] - good["rectified_cv2"]) < 0.1
    assert r["seen_pixels_pct"] > 85
