# amaranth: UnusedElaboratable=no
"""hdl/median3x3.py: Median3x3, bit for bit against sim.model.median.median3x3."""
import numpy as np
import pytest

from hdl.median3x3 import Median3x3
from verif.streams import field
from sim.model.median import median3x3
from tests.hdl_helpers import pixels, random_image, run_frames


@pytest.mark.parametrize("pixel_bits", [8, 6])
def test_median3x3(pixel_bits):
    w, h = 24, 16
    imgs = [random_image(h, w, 4, 1 << pixel_bits), random_image(h, w, 5, 4)]
    dut = Median3x3(w, h, pixel_bits)
    layout, out, frames = run_frames(dut, [pixels(i) for i in imgs])
    pix = field(layout, out, "pixel")
    for img, sel in zip(imgs, frames):
        ref = median3x3(img.astype(np.uint16))
        assert (pix[sel].reshape(h, w) == ref).all()
