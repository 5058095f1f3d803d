# amaranth: UnusedElaboratable=no
"""hdl/ycbcr422.py: YCbCr422To444, bit for bit against sim.model.ycbcr.ycbcr422_to_444."""
import numpy as np
import pytest

from verif.streams import field
from hdl.ycbcr422 import YCbCr422To444
from sim.model.ycbcr import ycbcr422_to_444
from tests.hdl_helpers import run_frames


@pytest.mark.parametrize("w, h", [(24, 12), (8, 3)])
def test_ycbcr422_to_444(w, h):
    rng = np.random.default_rng(w)
    cams = [rng.integers(0, 256, (h, 2 * w)).astype(np.uint8) for _ in range(2)]
    dut = YCbCr422To444(w, h)
    frames = [[{"luma": cam[y, 2 * k], "chroma": cam[y, 2 * k + 1]}
               for y in range(h) for k in range(w)] for cam in cams]
    layout, out, sels = run_frames(dut, frames)
    got = {name: field(layout, out, name) for name in ("y", "cb", "cr")}
    for cam, sel in zip(cams, sels):
        for name, ref in zip(("y", "cb", "cr"), ycbcr422_to_444(cam)):
            assert (got[name][sel].reshape(h, w) == ref).all(), name


@pytest.mark.parametrize("make, name", [
    (lambda: YCbCr422To444(25, 8), r"width must be even in \[8, 4096\]"),
    (lambda: YCbCr422To444(24, 1), r"height must be in \[2, 4096\]"),
])
def test_bad_parameters_name_the_parameter(make, name):
    with pytest.raises(ValueError, match=name):
        make()
