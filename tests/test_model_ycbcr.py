"""Tests for sim.model.ycbcr (thesis §5.4, Table 11)."""
import numpy as np
import pytest

from sim.model.ycbcr import ycbcr422_to_444, ycbcr444_to_422


def _random_frame(rng, height, width):
    return rng.integers(0, 256, size=(height, 2 * width), dtype=np.uint8)


def test_unpack_matches_byte_order_loop():
    rng = np.random.default_rng(1)
    frame = _random_frame(rng, 5, 8)
    y, cb, cr = ycbcr422_to_444(frame)
    for plane in (y, cb, cr):
        assert plane.shape == (5, 8) and plane.dtype == np.uint8
    for row in range(5):
        stream = list(frame[row])
        for pair in range(4):
            y0, cb_k, y1, cr_k = stream[4 * pair:4 * pair + 4]
            assert (y[row, 2 * pair], y[row, 2 * pair + 1]) == (y0, y1)
            assert cb[row, 2 * pair] == cb[row, 2 * pair + 1] == cb_k
            assert cr[row, 2 * pair] == cr[row, 2 * pair + 1] == cr_k


def test_pack_matches_loop_reference():
    rng = np.random.default_rng(2)
    y, cb, cr = (rng.integers(0, 256, size=(4, 6), dtype=np.uint8) for _ in range(3))
    frame = ycbcr444_to_422(y, cb, cr)
    assert frame.shape == (4, 12) and frame.dtype == np.uint8
    for row in range(4):
        expected = []
        for pair in range(3):
            a, b = 2 * pair, 2 * pair + 1
            cb_k = (int(cb[row, a]) + int(cb[row, b]) + 1) // 2
            cr_k = (int(cr[row, a]) + int(cr[row, b]) + 1) // 2
            expected += [y[row, a], cb_k, y[row, b], cr_k]
        assert frame[row].tolist() == expected


def test_chroma_rounding_half_up_without_overflow():
    y = np.zeros((1, 4), np.uint8)
    cb = np.array([[255, 255, 0, 1]], np.uint8)
    cr = np.array([[254, 255, 2, 3]], np.uint8)
    frame = ycbcr444_to_422(y, cb, cr)
    assert frame[0, 1::4].tolist() == [255, 1]
    assert frame[0, 3::4].tolist() == [255, 3]


def test_round_trip_422_444_422_is_identity():
    rng = np.random.default_rng(3)
    for height, width in [(1, 2), (7, 10), (48, 64)]:
        frame = _random_frame(rng, height, width)
        assert np.array_equal(ycbcr444_to_422(*ycbcr422_to_444(frame)), frame)


@pytest.mark.parametrize("bad", [
    np.zeros((4, 6), np.uint8),          # W odd: 6 bytes per row
    np.zeros((4, 2), np.uint8),
    np.zeros((4,), np.uint8),
    np.zeros((2, 4, 2), np.uint8),
    np.zeros((4, 8), np.float32),
    np.full((4, 8), 256, np.uint16),
    np.zeros((4, 8), np.int16),
])
def test_unpack_rejects_bad_frame(bad):
    with pytest.raises(ValueError, match="frame"):
        ycbcr422_to_444(bad)


def test_pack_rejects_bad_planes():
    good = np.zeros((3, 4), np.uint8)
    with pytest.raises(ValueError, match=r"^y\b"):
        ycbcr444_to_422(np.zeros((3, 5), np.uint8), np.zeros((3, 5), np.uint8),
                        np.zeros((3, 5), np.uint8))
    with pytest.raises(ValueError, match=r"\bcb \(3, 6\)"):
        ycbcr444_to_422(good, np.zeros((3, 6), np.uint8), good)
    with pytest.raises(ValueError, match=r"^cr\b"):
        ycbcr444_to_422(good, good, np.full((3, 4), 300, np.uint16))
    with pytest.raises(ValueError, match=r"^y\b"):
        ycbcr444_to_422(good.astype(float), good, good)
