# amaranth: UnusedElaboratable=no
"""hdl/shd.py: SumOfHammingDistances, bit for bit against sim.model.matching.shd_volume."""
import numpy as np
import pytest

from hdl.shd import SumOfHammingDistances
from verif.streams import field
from sim.model.census import census_bits, sparse_census
from sim.model.matching import shd_volume
from tests.hdl_helpers import crop, random_image, run_frames


def _shd_case(w, h, census_window, hamming_window, max_disparity, imgs, no_match_cost=None):
    bits = census_bits(census_window)
    dut = SumOfHammingDistances(w, h, bits, hamming_window, max_disparity, no_match_cost)
    frames, flush, refs = [], [], []
    rows = h + hamming_window + dut.lag // w + 2
    for left, right in imgs:
        cl = sparse_census(left.astype(np.uint8), census_window).astype(np.int64)
        cr = sparse_census(right.astype(np.uint8), census_window).astype(np.int64)
        # The dual window gives the codes hamming_window rows above, also during the flush.
        cl2, cr2 = np.zeros((rows, w), np.int64), np.zeros((rows, w), np.int64)
        cl2[hamming_window:hamming_window + h], cr2[hamming_window:hamming_window + h] = cl, cr
        frames.append([dict(left=a, right=b, left2=c, right2=d) for a, b, c, d in
                       zip(cl.ravel(), cr.ravel(), cl2[:h].ravel(), cr2[:h].ravel())])
        flush.append([dict(left2=c, right2=d) for c, d in
                      zip(cl2[h:].ravel()[:dut.lag], cr2[h:].ravel()[:dut.lag])])
        refs.append(shd_volume(cl.astype(np.uint32), cr.astype(np.uint32), hamming_window,
                               max_disparity, bits, no_match_cost))
    layout, out, sels = run_frames(dut, frames, flush_values=flush)
    cost = field(layout, out, "cost", max_disparity)
    for ref, sel in zip(refs, sels):
        got = cost[sel].reshape(h, w, max_disparity).transpose(2, 0, 1)
        assert (got == ref).all()


@pytest.mark.parametrize("hamming_window", [3, 5, 13])
@pytest.mark.parametrize("max_disparity", [4, 16, 32])
def test_shd_sweep(hamming_window, max_disparity):
    w, h = 34, 14
    seed = hamming_window * 100 + max_disparity
    imgs = [(random_image(h, w, seed), random_image(h, w, seed + 1)),
            (crop("tsukuba", "left", h, w), crop("tsukuba", "right", h, w))]
    _shd_case(w, h, 5, hamming_window, max_disparity, imgs)


def test_shd_census7_window1_and_no_match_cost():
    w, h = 16, 10
    imgs = [(random_image(h, w, 7), random_image(h, w, 8))] * 2
    _shd_case(w, h, 7, 1, 8, imgs, no_match_cost=0)
    _shd_case(w, h, 3, 7, 16, imgs, no_match_cost=4)


def test_parts_are_built_alone_on_request():
    """``stage(name)`` builds that part alone, with the parameters ``elaborate``
    gives it; the SHD's figures (cost bits, memory) come without building them."""
    from amaranth.hdl import Fragment

    from hdl.column_sum import ColumnSum
    from hdl.hamming import HammingDistances
    from hdl.shd import SHD_STAGES, shd_cost_bits, shd_memory_bits
    from hdl.window_sum import WindowSum
    dut = SumOfHammingDistances(40, 8, census_bits=12, hamming_window=5, max_disparity=6,
                                no_match_cost=2)
    assert dut.stage_names == SHD_STAGES == ("columns", "windows", "hamming")
    columns, windows, hamming = (dut.stage(name) for name in SHD_STAGES)
    for part in (columns, windows, hamming):
        Fragment.get(part, None)                # each elaborates alone
    assert (type(columns), type(windows), type(hamming)) == \
        (ColumnSum, WindowSum, HammingDistances)
    assert columns.no_match_cost == 2 and columns.max_term == 12
    assert windows.max_term == 5 * 12 and hamming.codes == 6
    assert dut.cost_bits == windows.sum_bits == shd_cost_bits(12, hamming_window=5)
    assert dut.memory_bits == shd_memory_bits(40, census_bits=12, hamming_window=5,
                                              max_disparity=6) == {
        "column sums": columns.memory_bits, "window-sum ring buffer": windows.memory_bits}
    assert dut.o_stream.payload.shape() == windows.o_stream.payload.shape()
    with pytest.raises(ValueError, match="stage must be one of columns, windows, hamming"):
        dut.stage("census")
