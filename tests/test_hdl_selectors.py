# amaranth: UnusedElaboratable=no
"""hdl/selectors.py: DisparitySelectors, bit for bit against sim.model.matching.winner_take_all."""
import numpy as np
import pytest

from hdl.selectors import DisparitySelectors
from verif.streams import field
from sim.model.matching import winner_take_all
from tests.hdl_helpers import run_frames


@pytest.mark.parametrize("max_disparity", [1, 5, 16])
def test_selectors_l2r_r2l(max_disparity):
    w, h, nd = 20, 6, max_disparity
    rng = np.random.default_rng(nd)
    # A small cost range makes ties frequent: ties must keep the smaller d.
    vols = [rng.integers(0, 6, (nd, h, w)), rng.integers(0, 1000, (nd, h, w))]
    dut = DisparitySelectors(w, h, nd, 10)
    frames = [[{"cost": vol[:, y, x]} for y in range(h) for x in range(w)] for vol in vols]
    layout, out, sels = run_frames(dut, frames, flush=nd - 1)
    l2r, r2l = field(layout, out, "l2r"), field(layout, out, "r2l")
    for vol, sel in zip(vols, sels):
        ref_l, ref_r = winner_take_all(vol)
        assert (l2r[sel].reshape(h, w) == ref_l).all()
        # r2l of right pixel p rides on the beat of left pixel p + D - 1.
        r_idx = np.arange(sel[0], sel[0] + w * h) + nd - 1
        assert (r2l[r_idx].reshape(h, w) == ref_r).all()
