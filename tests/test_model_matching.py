"""Hamming distance, SHD, best-of selection and LRCC against loop references."""
import numpy as np
import pytest

from sim.model.census import census_bits, sparse_census
from sim.model.matching import (column_sum, default_no_match_cost, disparity_maps,
                                hamming_volume, lr_consistency, row_sum, shd_volume,
                                window_sum, winner_take_all)


def loop_shd(cl, cr, wh, ndisp, no_match):
    h, w = cl.shape
    r = wh // 2
    ham = np.zeros((ndisp, h, w), dtype=np.int64)
    for d in range(ndisp):
        for y in range(h):
            for x in range(w):
                ham[d, y, x] = bin(int(cl[y, x]) ^ int(cr[y, x - d])).count("1") if x >= d else no_match
    shd = np.zeros_like(ham)
    for d in range(ndisp):
        for y in range(h):
            for x in range(w):
                total = 0
                for yy in range(y - r, y + r + 1):
                    for xx in range(x - r, x + r + 1):
                        if 0 <= yy < h and 0 <= xx < w:
                            total += ham[d, yy, xx]
                shd[d, y, x] = total
    return ham, shd


def loop_select(shd):
    ndisp, h, w = shd.shape
    l2r = np.zeros((h, w), np.int64)
    r2l = np.zeros((h, w), np.int64)
    for y in range(h):
        for x in range(w):
            best = None
            for d in range(ndisp):  # C1 > C2 takes 2: later wins only if strictly smaller
                if best is None or shd[d, y, x] < best:
                    best, l2r[y, x] = shd[d, y, x], d
            best = None
            for d in range(min(ndisp, w - x)):
                if best is None or shd[d, y, x + d] < best:
                    best, r2l[y, x] = shd[d, y, x + d], d
    return l2r, r2l


def loop_lrcc(l2r, r2l, th):
    out = np.zeros_like(l2r)
    for y in range(l2r.shape[0]):
        for x in range(l2r.shape[1]):
            d = l2r[y, x]
            if x - d < 0 or abs(d - r2l[y, x - d]) < th:
                out[y, x] = d
    return out


def pair(rng, h, w, shift):
    left = rng.integers(0, 256, (h, w), dtype=np.uint8)
    right = np.roll(left, -shift, axis=1)
    noise = rng.integers(-6, 7, (h, w))
    return left, np.clip(right.astype(int) + noise, 0, 255).astype(np.uint8)


@pytest.mark.parametrize("h, w, wc, wh, ndisp", [(9, 14, 3, 3, 5), (11, 13, 5, 5, 6), (8, 10, 7, 1, 10)])
def test_against_loop_reference(h, w, wc, wh, ndisp):
    rng = np.random.default_rng(h * w)
    left, right = pair(rng, h, w, 2)
    cl, cr = sparse_census(left, wc), sparse_census(right, wc)
    bits = census_bits(wc)
    nmc = default_no_match_cost(bits)
    ham_ref, shd_ref = loop_shd(cl, cr, wh, ndisp, nmc)
    np.testing.assert_array_equal(hamming_volume(cl, cr, ndisp, bits), ham_ref)
    shd = shd_volume(cl, cr, wh, ndisp, bits)
    np.testing.assert_array_equal(shd, shd_ref)
    l2r_ref, r2l_ref = loop_select(shd_ref)
    l2r, r2l = winner_take_all(shd)
    np.testing.assert_array_equal(l2r, l2r_ref)
    np.testing.assert_array_equal(r2l, r2l_ref)
    for th in (1, 2, 4):
        np.testing.assert_array_equal(lr_consistency(l2r, r2l, th), loop_lrcc(l2r_ref, r2l_ref, th))
    maps = disparity_maps(cl, cr, wh, ndisp, bits, threads=2)
    np.testing.assert_array_equal(maps.l2r, l2r_ref)
    np.testing.assert_array_equal(maps.r2l, r2l_ref)


@pytest.mark.parametrize("wh, ndisp, threads, nmc", [(13, 16, 1, None), (5, 4, 3, 0), (29, 32, 2, 24), (63, 8, 4, None)])
def test_streaming_maps_equal_volume_maps(wh, ndisp, threads, nmc):
    rng = np.random.default_rng(wh)
    left, right = pair(rng, 37, 53, 5)
    cl, cr = sparse_census(left, 7), sparse_census(right, 7)
    l2r, r2l = winner_take_all(shd_volume(cl, cr, wh, ndisp, 24, nmc))
    maps = disparity_maps(cl, cr, wh, ndisp, 24, nmc, threads=threads)
    np.testing.assert_array_equal(maps.l2r, l2r)
    np.testing.assert_array_equal(maps.r2l, r2l)


def test_ties_keep_the_smaller_disparity():
    shd = np.zeros((4, 2, 6), np.uint16)
    shd[0] = 5
    l2r, r2l = winner_take_all(shd)
    assert (l2r == 1).all()            # d = 1, 2, 3 tie at 0: the first wins
    assert r2l[0, -1] == 0 and r2l[0, 0] == 1  # right edge can only see d = 0


def test_window_sum_wide_values_use_a_wide_dtype():
    vals = np.full((70, 70), 60, np.uint8)
    out = window_sum(vals, 63)
    assert out.dtype == np.uint32 and out[35, 35] == 63 * 63 * 60 and out[0, 0] == 32 * 32 * 60


@pytest.mark.parametrize("window", [1, 3, 7])
def test_column_and_row_sums_against_loops(window):
    vals = np.random.default_rng(window).integers(0, 40, (3, 9, 11))
    r = window // 2
    cols, rows = np.zeros_like(vals), np.zeros_like(vals)
    for d, y, x in np.ndindex(vals.shape):
        cols[d, y, x] = vals[d, max(0, y - r):y + r + 1, x].sum()
        rows[d, y, x] = vals[d, y, max(0, x - r):x + r + 1].sum()
    np.testing.assert_array_equal(column_sum(vals, window), cols)
    np.testing.assert_array_equal(row_sum(vals, window), rows)
    np.testing.assert_array_equal(window_sum(vals, window), row_sum(cols, window))


def test_shifted_texture_is_found_exactly():
    rng = np.random.default_rng(7)
    left, right = pair(rng, 40, 80, 6)
    maps = disparity_maps(sparse_census(left, 7), sparse_census(right, 7), 9, 16, 24)
    assert (maps.l2r[8:-8, 20:-8] == 6).all()


@pytest.mark.parametrize("call, name", [
    (lambda c: disparity_maps(c, c, 4, 8, 24), "hamming_window"),
    (lambda c: disparity_maps(c, c, 5, 0, 24), "max_disparity"),
    (lambda c: disparity_maps(c, c, 5, 21, 24), "max_disparity"),
    (lambda c: disparity_maps(c, c, 5, 8, 24, no_match_cost=25), "no_match_cost"),
    (lambda c: disparity_maps(c, c, 5, 8, 24, threads=0), "threads"),
    (lambda c: disparity_maps(c, c[:, :-1], 5, 8, 24), "census_left and census_right"),
    (lambda c: disparity_maps(c.astype(np.int32), c, 5, 8, 24), "census_left"),
    (lambda c: hamming_volume(c, c, 8, 0), "census_bits"),
    (lambda c: lr_consistency(np.zeros((4, 4), np.uint8), np.zeros((4, 4), np.uint8), 0), "threshold"),
    (lambda c: winner_take_all(np.zeros((4, 4))), "shd"),
])
def test_bad_parameters(call, name):
    codes = np.zeros((10, 20), np.uint32)
    with pytest.raises(ValueError, match=name):
        call(codes)
