# amaranth: UnusedElaboratable=no
"""hdl/census.py: SparseCensus, bit for bit against sim.model.census.sparse_census."""
import numpy as np
import pytest

from hdl.census import SparseCensus
from verif.streams import field
from sim.model.census import census_bits, sparse_census
from tests.hdl_helpers import crop, pixels, random_image, run_frames


@pytest.mark.parametrize("census_window", [3, 5, 7])
def test_sparse_census_with_dual_window(census_window):
    w, h, sep = 24, 16, 5
    imgs = [random_image(h, w, 3), crop("cones", "left", h, w)]
    dut = SparseCensus(w, h, census_window, 8, separation=sep)
    layout, out, frames = run_frames(dut, [pixels(i) for i in imgs])
    code, code2 = field(layout, out, "code"), field(layout, out, "code2")
    for img, sel in zip(imgs, frames):
        ref = sparse_census(img.astype(np.uint8), census_window).astype(np.int64)
        assert (code[sel].reshape(h, w) == ref).all()
        assert (code2[sel].reshape(h, w)[sep:] == ref[:-sep]).all()


def test_census_bits_and_validation():
    assert len(sparse_census(np.zeros((3, 3), np.uint8), 7).shape) == 2
    assert census_bits(7) == 24
    with pytest.raises(ValueError, match="census_window"):
        SparseCensus(16, 8, 4)
    with pytest.raises(ValueError, match=r"width must be in \[8, 4096\]"):
        SparseCensus(4, 8, 3)
