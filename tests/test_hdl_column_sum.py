# amaranth: UnusedElaboratable=no
"""hdl/column_sum.py: ColumnSum, bit for bit against sim.model.matching.column_sum."""
import numpy as np
import pytest

from hdl.column_sum import ColumnSum
from sim.model.matching import column_sum
from verif.streams import field
from tests.hdl_helpers import run_frames


def _terms(h, w, nd, max_term, no_match_cost, seed):
    """Random Hamming terms H_d(x, y), ``no_match_cost`` where x < d (no partner)."""
    terms = np.random.default_rng(seed).integers(0, max_term + 1, (nd, h, w))
    for d in range(nd):
        terms[d, :, :d] = no_match_cost
    return terms


@pytest.mark.parametrize("hamming_window, max_disparity, no_match_cost, idle",
                         [(1, 3, 0, 0.25), (3, 4, 2, 0.25), (5, 6, 5, 0.25),
                          # D = width: a row's partnerless pixels follow the last
                          # pixel of the row before within the pipeline's cycles
                          (3, 12, 4, 0.0), (3, 11, 6, 0.1)])
def test_column_sum_equals_model(hamming_window, max_disparity, no_match_cost, idle):
    w, h, max_term = 12, 9, 7
    dut = ColumnSum(width=w, height=h, hamming_window=hamming_window,
                    max_disparity=max_disparity, max_term=max_term,
                    no_match_cost=no_match_cost)
    vols = [_terms(h, w, max_disparity, max_term, no_match_cost, seed) for seed in (1, 2)]
    frames, flush = [], []
    for vol in vols:
        # Row y' enters; row y' - Wh leaves (the dual window's second tap), also
        # during the flush rows after the frame.
        rows = h + dut.lag // w
        padded = np.zeros((max_disparity, rows + hamming_window, w), np.int64)
        padded[:, hamming_window:hamming_window + h] = vol
        beats = [dict(enter=vol[:, y, x] if y < h else np.zeros(max_disparity, np.int64),
                      leave=padded[:, y, x]) for y in range(rows) for x in range(w)]
        frames.append(beats[:h * w])
        flush.append(beats[h * w:])
    layout, out, sels = run_frames(dut, frames, flush_values=flush, idle=idle)
    csum = field(layout, out, "csum", max_disparity)
    for vol, sel in zip(vols, sels):
        got = csum[sel].reshape(h, w, max_disparity).transpose(2, 0, 1)
        np.testing.assert_array_equal(got, column_sum(vol, hamming_window))


@pytest.mark.parametrize("kwargs, name", [
    (dict(hamming_window=4), "hamming_window"),
    (dict(max_disparity=0), "max_disparity"),
    (dict(max_disparity=13), "max_disparity"),
    (dict(no_match_cost=8), "no_match_cost"),
])
def test_bad_parameters_name_themselves(kwargs, name):
    args = dict(width=12, height=9, hamming_window=3, max_disparity=4, max_term=7)
    with pytest.raises(ValueError, match=name):
        ColumnSum(**dict(args, **kwargs))
