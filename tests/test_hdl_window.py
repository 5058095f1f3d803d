# amaranth: UnusedElaboratable=no
"""hdl/window.py: WindowGenerator, bit for bit against the taps and masks of the padded frame."""
import numpy as np
import pytest

from verif.streams import field
from hdl.window import WindowGenerator
from tests.hdl_helpers import pixels, random_image, run_frames


@pytest.mark.parametrize("window, separation", [(3, 0), (5, 4), (3, 7)])
def test_window_generator_taps_and_masks(window, separation):
    w, h = 16, 12
    imgs = [random_image(h, w, 1), random_image(h, w, 2)]
    dut = WindowGenerator(w, h, 8, window, separation)
    layout, out, frames = run_frames(dut, [pixels(i) for i in imgs])
    r = window // 2
    v1 = field(layout, out, "v1", window * window)
    rows1, cols = field(layout, out, "rows1"), field(layout, out, "cols")
    v2 = field(layout, out, "v2", window * window) if separation else None
    rows2 = field(layout, out, "rows2") if separation else None
    for img, sel in zip(imgs, frames):
        pad = np.full((h + 2 * r + separation, w + 2 * r), -1)
        pad[r + separation:r + separation + h, r:r + w] = img
        for k, (y, x) in zip(sel, np.ndindex(h, w)):
            for i in range(window):
                for j in range(window):
                    inside = bool((rows1[k] >> i) & 1 and (cols[k] >> j) & 1)
                    expect = pad[y + separation + i, x + j]
                    assert inside == (expect >= 0)
                    if inside:
                        assert v1[k, i * window + j] == expect
                    if separation:
                        inside2 = bool((rows2[k] >> i) & 1 and (cols[k] >> j) & 1)
                        expect2 = pad[y + i, x + j]
                        assert inside2 == (expect2 >= 0)
                        if inside2:
                            assert v2[k, i * window + j] == expect2
