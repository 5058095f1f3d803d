"""50 % sparse census transform (thesis §6.2.1, Fig. 7b, Fig. 40, Fig. 54).

The census window of size ``census_window`` x ``census_window`` (the thesis'
Wc) is sampled on a checkerboard: the neighbours whose offset (dy, dx) from
the centre has an odd sum dy + dx. That keeps exactly half of the
Wc*Wc - 1 neighbours (24 bits for Wc = 7) and always includes the four
nearest neighbours, the most informative ones.
"""
from __future__ import annotations

from functools import lru_cache

import numpy as np

from .validation import check_image, check_odd_window

__all__ = ["CENSUS_WINDOW_RANGE", "census_offsets", "census_bits", "sparse_census"]

#: Allowed census windows: odd sizes whose bit count (Wc*Wc // 2) fits 64 bits.
CENSUS_WINDOW_RANGE = (3, 11)


@lru_cache(maxsize=None)
def census_offsets(census_window: int = 7) -> tuple[tuple[int, int], ...]:
    """Offsets (dy, dx) of the sampled neighbours, in raster order.

    Bit ``i`` of a census code (bit 0 = least significant) compares the
    neighbour at ``census_offsets(Wc)[i]`` with the centre.
    """
    wc = check_odd_window("census_window", census_window, *CENSUS_WINDOW_RANGE)
    r = wc // 2
    return tuple((dy, dx) for dy in range(-r, r + 1) for dx in range(-r, r + 1)
                 if (dy + dx) % 2 != 0)


def census_bits(census_window: int = 7) -> int:
    """Number of bits of a sparse census code: ``Wc*Wc // 2``."""
    return len(census_offsets(census_window))


def sparse_census(image, census_window: int = 7) -> np.ndarray:
    """50 % sparse census transform of an 8-bit image.

    Bit ``i`` of ``codes[y, x]`` is 1 when the neighbour
    ``image[y + dy, x + dx]`` (``(dy, dx) = census_offsets(Wc)[i]``) is
    greater than or equal to the centre ``image[y, x]`` (the ``>=`` of
    thesis Fig. 40 and of the author's VHDL, not the ``>`` of eq. 1; see the
    docs/figures/stereo.md for the measured difference).

    Border policy: a neighbour outside the frame gives bit 0 (the hardware
    masks that tap with its row/column counters), so every pixel has a code.

    Parameters
    ----------
    image : (H, W) uint8-valued integer array
    census_window : odd int in [3, 11]
        Wc, the side of the census window.

    Returns
    -------
    codes : (H, W) uint32 (uint64 when Wc*Wc // 2 > 32)
    """
    offsets = census_offsets(census_window)
    img = check_image("image", image, max_value=255).astype(np.uint8, copy=False)
    h, w = img.shape
    nbits = len(offsets)
    code_dtype = np.uint32 if nbits <= 32 else np.uint64
    # Build the code a byte at a time: 8-bit planes are 4x cheaper to OR into.
    planes = np.zeros(((nbits + 7) // 8, h, w), dtype=np.uint8)
    for bit, (dy, dx) in enumerate(offsets):
        # Region of centres whose neighbour (y+dy, x+dx) lies inside the frame.
        y0, y1 = max(0, -dy), min(h, h - dy)
        x0, x1 = max(0, -dx), min(w, w - dx)
        if y0 >= y1 or x0 >= x1:
            continue
        centre = img[y0:y1, x0:x1]
        neighbour = img[y0 + dy:y1 + dy, x0 + dx:x1 + dx]
        ge = np.greater_equal(neighbour, centre).view(np.uint8)
        planes[bit >> 3, y0:y1, x0:x1] |= ge << np.uint8(bit & 7)
    codes = np.zeros((h, w), dtype=code_dtype)
    for index, plane in enumerate(planes):
        codes |= plane.astype(code_dtype) << code_dtype(8 * index)
    return codes
