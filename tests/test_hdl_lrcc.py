# amaranth: UnusedElaboratable=no
"""hdl/lrcc.py: LeftRightCheck, bit for bit against sim.model.matching.lr_consistency."""
import numpy as np
import pytest

from hdl.lrcc import LeftRightCheck
from verif.streams import field
from sim.model.matching import lr_consistency
from tests.hdl_helpers import run_frames


@pytest.mark.parametrize("max_disparity, threshold",
                         [(1, 1), (5, 2), (8, 1), (8, 3), (16, 16), (20, 4)])
def test_lrcc(max_disparity, threshold):
    w, h, nd = 20, 6, max_disparity
    rng = np.random.default_rng(nd + threshold)
    maps = [(rng.integers(0, nd, (h, w)), rng.integers(0, nd, (h, w))) for _ in range(2)]
    dut = LeftRightCheck(w, h, nd)
    frames = []
    for l2r, r2l in maps:
        # The selectors' stream: l2r of pixel p with r2l of pixel p - (D - 1).
        flat_r = np.concatenate([np.zeros(nd - 1, np.int64), r2l.ravel()])
        frames.append([{"l2r": a, "r2l": b} for a, b in zip(l2r.ravel(), flat_r[:w * h])])
    flush = [[{"r2l": b} for b in r2l.ravel()[w * h - (nd - 1):]] for _, r2l in maps]
    layout, out, sels = run_frames(dut, frames, flush_values=flush,
                                   setup=lambda ctx: ctx.set(dut.threshold, threshold))
    disp = field(layout, out, "disparity")
    for (l2r, r2l), sel in zip(maps, sels):
        ref = lr_consistency(l2r.astype(np.uint8), r2l.astype(np.uint8), threshold)
        assert (disp[sel].reshape(h, w) == ref).all()
