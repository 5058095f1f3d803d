# amaranth: UnusedElaboratable=no
"""hdl/rectify.py: Rectifier, bit for bit against sim.model.rectify.rectify: two
frames back to back with idle cycles, one to three lanes, both interpolations,
several grid steps and fraction bits, row buffers reaching further than needed."""
import numpy as np
import pytest

from hdl.rectify import MAX_SHIFT_Y, Rectifier, rectify_timing, ring_rows
from sim.model.rectify import identity_grid, rectify
from verif.streams import field
from tests.hdl_helpers import run_frames
from tests.test_model_rectify import grid_of, rotation_homography


def run_rectifier(dut, images, seed=1):
    """Images (H, W, lanes) through ``dut``; the output frames, same shape."""
    frames = [[{"pixel": img[y, x]} for y in range(dut.height) for x in range(dut.width)]
              for img in images]
    layout, out, sels = run_frames(dut, frames, seed=seed)
    pixels = field(layout, out, "pixel", dut.lanes)
    return [pixels[sel].reshape(dut.height, dut.width, dut.lanes) for sel in sels]


@pytest.mark.parametrize("w, h, lanes, interpolation, degrees, shift_y, step, frac_bits, extra", [
    (24, 12, 1, "bilinear", 2.0, -1.3, 4, 4, 0),
    (40, 18, 3, "nearest", -1.5, 0.8, 8, 5, 0),
    (32, 16, 2, "bilinear", 3.0, 2.4, 2, 3, 0),
    (30, 14, 1, "bilinear", 0.5, 0.4, 8, 6, 2),
])
def test_rectifier_equals_model(w, h, lanes, interpolation, degrees, shift_y, step, frac_bits,
                                extra):
    grid = grid_of(rotation_homography(w, h, degrees, 0.6, shift_y), w, h, step, frac_bits)
    need_x, need_y = grid.max_shift
    dut = Rectifier(w, h, grid, lanes=lanes, interpolation=interpolation,
                    max_shift_x=need_x + extra, max_shift_y=need_y + extra)
    rng = np.random.default_rng(w + lanes)
    images = [rng.integers(0, 256, (h, w, lanes)) for _ in range(2)]
    for image, got in zip(images, run_rectifier(dut, images, seed=lanes)):
        for lane in range(lanes):
            expected = rectify(image[:, :, lane].astype(np.uint8), grid, interpolation)
            np.testing.assert_array_equal(got[:, :, lane], expected)


def test_identity_passes_the_image_through():
    dut = Rectifier(16, 8, identity_grid(16, 8, grid_step=4, frac_bits=2))
    image = np.random.default_rng(5).integers(0, 256, (8, 16, 1))
    assert (run_rectifier(dut, [image])[0] == image).all()


def test_timing_and_memory():
    grid = grid_of(rotation_homography(64, 32, 2.0, 1.0, 3.0), 64, 32, 8, 4)
    need_x, need_y = grid.max_shift
    dut = Rectifier(64, 32, grid, lanes=3)
    assert (dut.lag, dut.cycles) == tuple(rectify_timing(64, need_x, need_y))
    assert dut.lag == (need_y + 1) * 64 + need_x + 2
    assert dut.rows == ring_rows(need_y) == 2 * need_y + 4
    assert dut.memory_bits["row buffers"] == dut.rows * 64 * 24
    assert dut.memory_bits["map grid"] == 5 * 9 * 2 * dut.grid_bits


@pytest.mark.parametrize("kwargs, name", [
    (dict(grid="identity"), "grid must be a RectifyGrid"),
    (dict(width=32), "grid is for 16x8"),
    (dict(lanes=5), "lanes"),
    (dict(interpolation="cubic"), "interpolation"),
    (dict(max_shift_y=MAX_SHIFT_Y + 1), "max_shift_y"),
    (dict(max_shift_x=-1), "max_shift_x"),
    (dict(width=12, grid=identity_grid(12, 8, grid_step=2)), "grid_step 2 is too fine"),
    (dict(max_shift_x=3), r"width must be in \[18, 4096\]"),
])
def test_bad_parameters_name_themselves(kwargs, name):
    args = dict(width=16, height=8, grid=identity_grid(16, 8))
    with pytest.raises(ValueError, match=name):
        Rectifier(**{**args, **kwargs})


def test_a_grid_that_reaches_further_than_the_buffers_is_refused():
    grid = grid_of(rotation_homography(48, 24, 0, 0, 3.5), 48, 24, 8, 4)
    assert grid.max_shift[1] == 4
    with pytest.raises(ValueError, match=r"max_shift_y must be in \[4, "):
        Rectifier(48, 24, grid, max_shift_y=3)


@pytest.mark.parametrize("chunk_words", [32, 64])
def test_banks_in_several_chunks_equal_the_model(monkeypatch, chunk_words):
    """Row-buffer banks deeper than a chunk (small chunks, so a small frame has
    several, the last one partial): the chunk multiplexers choose the right words."""
    import hdl.rectify
    monkeypatch.setattr(hdl.rectify, "CHUNK_WORDS", chunk_words)
    w, h = 40, 18
    grid = grid_of(rotation_homography(w, h, -1.5, 0.6, 0.8), w, h, 8, 5)
    dut = Rectifier(w, h, grid, lanes=2)
    depth = dut.rows // 2 * w // 2
    assert depth > chunk_words and depth % chunk_words
    rng = np.random.default_rng(chunk_words)
    images = [rng.integers(0, 256, (h, w, 2)) for _ in range(2)]
    for image, got in zip(images, run_rectifier(dut, images, seed=3)):
        for lane in range(2):
            expected = rectify(image[:, :, lane].astype(np.uint8), grid, "bilinear")
            np.testing.assert_array_equal(got[:, :, lane], expected)
