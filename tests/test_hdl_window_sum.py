# amaranth: UnusedElaboratable=no
"""hdl/window_sum.py: WindowSum, bit for bit against sim.model.matching.row_sum."""
import numpy as np
import pytest

from hdl.window_sum import FLAG_GROUP, WindowSum
from sim.model.matching import row_sum
from verif.streams import field
from tests.hdl_helpers import run_frames


@pytest.mark.parametrize("hamming_window, max_disparity", [(1, 2), (3, 3), (5, 5), (7, 4)])
def test_window_sum_equals_model(hamming_window, max_disparity):
    w, h, max_term = 12, 5, 50
    dut = WindowSum(width=w, height=h, hamming_window=hamming_window,
                    max_disparity=max_disparity, max_term=max_term)
    rng = np.random.default_rng(hamming_window * 10 + max_disparity)
    sums = [rng.integers(0, max_term + 1, (max_disparity, h, w)) for _ in range(3)]
    frames = [[dict(csum=s[:, y, x]) for y in range(h) for x in range(w)] for s in sums]
    layout, out, sels = run_frames(dut, frames)
    cost = field(layout, out, "cost", max_disparity)
    for s, sel in zip(sums, sels):
        got = cost[sel].reshape(h, w, max_disparity).transpose(2, 0, 1)
        np.testing.assert_array_equal(got, row_sum(s, hamming_window))


def test_ring_buffer_is_grouped():
    dut = WindowSum(width=40, height=4, hamming_window=29, max_disparity=5, max_term=9)
    assert dut.ring_depth == 32 and FLAG_GROUP == 2
    assert dut.memory_bits == 32 * 5 * 4


def test_bad_parameters_name_themselves():
    args = dict(width=12, height=5, hamming_window=7, max_disparity=3, max_term=9)
    for change, name in ((dict(hamming_window=2), "hamming_window"),
                         (dict(width=6), "width"), (dict(max_term=0), "max_term")):
        with pytest.raises(ValueError, match=name):
            WindowSum(**{**args, **change})
