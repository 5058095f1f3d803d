"""Sparse census transform against a per-pixel loop reference."""
import numpy as np
import pytest

from sim.model.census import census_bits, census_offsets, sparse_census


def census_loop(img, wc):
    h, w = img.shape
    offsets = census_offsets(wc)
    out = np.zeros((h, w), dtype=np.uint64)
    for y in range(h):
        for x in range(w):
            code = 0
            for bit, (dy, dx) in enumerate(offsets):
                yy, xx = y + dy, x + dx
                if 0 <= yy < h and 0 <= xx < w and img[yy, xx] >= img[y, x]:
                    code |= 1 << bit
            out[y, x] = code
    return out


@pytest.mark.parametrize("wc", [3, 5, 7, 9, 11])
def test_offsets_are_half_the_window(wc):
    offsets = census_offsets(wc)
    assert len(offsets) == census_bits(wc) == wc * wc // 2
    assert len(set(offsets)) == len(offsets)
    assert all((dy + dx) % 2 == 1 and max(abs(dy), abs(dx)) <= wc // 2 for dy, dx in offsets)
    assert {(0, 1), (1, 0), (0, -1), (-1, 0)} <= set(offsets)


@pytest.mark.parametrize("wc", [3, 5, 7, 11])
def test_matches_loop_reference(wc):
    rng = np.random.default_rng(wc)
    img = rng.integers(0, 256, (13, 17), dtype=np.uint8)
    img[4:8, 5:9] = 77  # flat patch: exercises the >= on equal values
    codes = sparse_census(img, wc)
    assert codes.dtype == (np.uint32 if wc <= 7 else np.uint64)
    np.testing.assert_array_equal(codes.astype(np.uint64), census_loop(img, wc))


def test_tiny_image_smaller_than_window():
    img = np.array([[5, 9], [9, 5]], dtype=np.uint8)
    np.testing.assert_array_equal(sparse_census(img, 7).astype(np.uint64), census_loop(img, 7))


@pytest.mark.parametrize("kwargs, name", [
    (dict(census_window=4), "census_window"),
    (dict(census_window=13), "census_window"),
    (dict(census_window=1), "census_window"),
    (dict(census_window=7.0), "census_window"),
])
def test_bad_window(kwargs, name):
    with pytest.raises(ValueError, match=name):
        sparse_census(np.zeros((8, 8), np.uint8), **kwargs)


@pytest.mark.parametrize("image", [np.zeros((4, 4, 3), np.uint8), np.full((4, 4), 300),
                                   np.zeros((4, 4), np.float32)])
def test_bad_image(image):
    with pytest.raises(ValueError, match="image"):
        sparse_census(image)
