"""sim/model/posture.py: the posture mask and the one-pass descriptor. The
vectorised golden model equals a pixel-by-pixel raster pass (what the hardware
does); the sectors equal the angle's; fingers survive the mask."""
from __future__ import annotations

import math

import numpy as np
import pytest

from sim.model import posture as P


def _raster(mask, ref: P.PostureReference):
    """The descriptor pixel by pixel in raster order, with the integer
    comparisons written out: the reference the vectorised model must equal."""
    height, width = mask.shape
    polar = [0] * (P.RINGS * P.SECTORS)
    band_sum, band_rows, band_max = [0] * P.BANDS, [0] * P.BANDS, [0] * P.BANDS
    area = sx = sy = sxx = syy = sxy = 0
    x_min, x_max, y_min, y_max = width, -1, height, -1
    w, ay = ref.width, ref.top + ref.width // 2
    for y in range(height):
        starts, previous = 0, False
        for x in range(width):
            pixel = bool(mask[y, x])
            if pixel:
                area += 1
                sx, sy, sxx, syy, sxy = sx + x, sy + y, sxx + x * x, syy + y * y, sxy + x * y
                x_min, x_max = min(x_min, x), max(x_max, x)
                y_min, y_max = min(y_min, y), max(y_max, y)
                if w:
                    dx, dyu = x - ref.x, ay - y
                    ring = sum(16 * (dx * dx + dyu * dyu) >= e * w * w
                               for e in P.RING_EDGES_16THS)
                    polar[ring * P.SECTORS + int(P.sector_of(dx, dyu))] += 1
                if not previous:
                    starts += 1
            previous = pixel
        up = ay - y
        if w and up >= 0 and 16 * up < 3 * w * P.BANDS:
            b = 16 * up // (3 * w)
            band_sum[b] += starts
            band_rows[b] += 1
            band_max[b] = max(band_max[b], starts)
    box = (x_min, x_max, y_min, y_max) if area else (0, 0, 0, 0)
    return P.PostureRegisters(area, sx, sy, sxx, syy, sxy, *box, tuple(polar),
                              tuple(band_sum), tuple(band_rows), tuple(band_max))


def _hand(height=60, width=50, fingers=4, finger_width=5, gap=4, top=6):
    """A palm with ``fingers`` raised fingers above it and a wrist below."""
    mask = np.zeros((height, width), bool)
    palm_left, palm_right = 8, 8 + fingers * (finger_width + gap)
    mask[30:48, palm_left:palm_right] = True
    mask[48:, palm_left + 6:palm_right - 6] = True        # wrist to the bottom edge
    for k in range(fingers):
        left = palm_left + 2 + k * (finger_width + gap)
        mask[top:30, left:left + finger_width] = True
    return mask


def test_sectors_follow_the_angle():
    ys, xs = np.mgrid[-40:41, -40:41]
    sector = P.sector_of(xs, ys)
    angle = np.mod(np.arctan2(ys, xs), 2 * math.pi)
    step = 2 * math.pi / P.SECTORS
    expected = np.floor(angle / step).astype(int) % P.SECTORS
    # away from a boundary (the Q12 tangents round it by < 1e-3 rad) they agree
    off = np.abs(angle / step - np.round(angle / step)) * step
    clear = off > 2e-3
    assert np.array_equal(sector[clear], expected[clear])
    assert sector[40, 40] == 0 and set(np.unique(sector)) == set(range(P.SECTORS))
    assert P.sector_of(5, 0) == 0 and P.sector_of(0, 5) == P.SECTORS // 4
    assert P.sector_of(-5, 0) == P.SECTORS // 2 and P.sector_of(0, -5) == 3 * P.SECTORS // 4


@pytest.mark.parametrize("seed", range(4))
def test_registers_equal_a_raster_pass(seed):
    rng = np.random.default_rng(seed)
    mask = rng.random((23, 31)) < (0.2 + 0.2 * seed)
    ref = P.PostureReference(int(rng.integers(0, 31)), int(rng.integers(0, 23)),
                             int(rng.integers(1, 31)))
    assert P.posture_registers(mask, ref) == _raster(mask, ref)


def test_a_hand_still_picture():
    hand = _hand()
    registers, features = P.describe_still(hand)
    mask = P.posture_mask(hand)
    ref = P.posture_reference(P.posture_registers(mask, P.PostureReference(0, 0, 0)))
    assert registers == _raster(mask, ref)
    # the reference: the centroid's column, the top, the width of the hand
    ys, xs = np.nonzero(mask)
    assert ref == P.PostureReference(int(xs.sum()) // len(xs), int(ys.min()),
                                     int(xs.max() - xs.min() + 1))
    assert sum(registers.polar) == registers.area == mask.sum()
    assert features.shape == (P.FEATURES,)
    # the four 5 px fingers survive the 3x3 opening and are crossed as four runs
    # in the bands that cover them
    assert np.array_equal(mask[6:30], hand[6:30])
    assert max(registers.band_max) == 4


def test_fingers_tell_postures_apart():
    fist = P.describe_still(_hand(fingers=4, top=30))[1]      # no finger raised
    four = P.describe_still(_hand(fingers=4))[1]
    two = P.describe_still(_hand(fingers=2))[1]
    crossings = slice(P.RINGS * P.SECTORS + 1, None, 2)
    assert max(four[crossings]) == 4 and max(two[crossings]) == 2
    assert max(fist[crossings]) == 1


def test_the_next_reference_moves_on_as_the_hand_moved():
    R = P.PostureReference
    # moving right and up by (5, -3) a frame: described about where it is now
    assert P.next_reference(R(40, 20, 30), R(35, 23, 28), 64, 48) == R(45, 17, 30)
    # clamped to the frame; the width is the latest
    assert P.next_reference(R(62, 2, 9), R(50, 9, 12), 64, 48) == R(63, 0, 9)
    assert P.next_reference(R(3, 45, 9), R(10, 40, 9), 64, 48) == R(0, 47, 9)
    # still: its own; no hand in either frame: the latest alone
    assert P.next_reference(R(40, 20, 30), R(40, 20, 30), 64, 48) == R(40, 20, 30)
    assert P.next_reference(R(40, 20, 30), R(0, 0, 0), 64, 48) == R(40, 20, 30)
    assert P.next_reference(R(0, 0, 0), R(35, 23, 28), 64, 48) == R(0, 0, 0)


def test_no_hand_gives_zeros():
    empty = np.zeros((10, 12), bool)
    registers, features = P.describe_still(empty)
    assert registers.area == 0 and not any(registers.polar) and not any(registers.band_rows)
    assert P.posture_reference(registers) == P.PostureReference(0, 0, 0)
    assert not features.any()


def test_bad_mask():
    with pytest.raises(ValueError, match="mask must be a 2-D mask"):
        P.posture_registers(np.zeros(5, bool), P.PostureReference(0, 0, 1))
    with pytest.raises(ValueError, match="hand must be a boolean mask"):
        P.posture_mask(np.full((4, 4), 2))
