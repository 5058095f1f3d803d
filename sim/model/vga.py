"""VGA debug view (thesis Table 22, §7.5): what the frame buffer puts on the
DE1-SoC VGA pins during one whole frame, pixel clock by pixel clock.

The hardware (:class:`soc.frame_buffer.FrameBuffer`) keeps the top
``pixel_bits`` of each 8-bit pixel and widens them back to 8 bits by bit
replication (4 bits ``v``: ``v << 4 | v``), so black stays 0 and white 255. At
``scale`` 2 it keeps only the pixels at even x and even y and shows each as a
2x2 block, so the picture keeps its size. The image sits at the top-left of the
visible area; the rest of it is black.
"""
from __future__ import annotations

import numpy as np

from .validation import check_image, check_int

__all__ = ["VGA_CHANNELS", "SCALE_RANGE", "grey_levels", "stored_size", "vga_frame"]

#: Channel order of the last axis of :func:`vga_frame`.
VGA_CHANNELS = ("r", "g", "b", "hsync", "vsync", "blank_n")
#: Allowed ``scale`` of the frame buffer: 1 stores every pixel, 2 every second
#: pixel of every second row.
SCALE_RANGE = (1, 2)


def grey_levels(image, pixel_bits: int) -> np.ndarray:
    """8-bit pixels quantised to ``pixel_bits`` (top bits kept) and widened back
    to 8 bits by repeating the kept bits from the top down.

    Parameters
    ----------
    image : array of integers in [0, 255]
    pixel_bits : int in [1, 8]

    Returns
    -------
    array of uint8, the shape of ``image``
    """
    pixel_bits = check_int("pixel_bits", pixel_bits, 1, 8)
    stored = np.asarray(image).astype(np.int64) >> (8 - pixel_bits)
    copies = -(-8 // pixel_bits)
    repeated = sum(stored << (pixel_bits * k) for k in range(copies))
    return (repeated >> (pixel_bits * copies - 8)).astype(np.uint8)


def stored_size(width: int, height: int, scale: int) -> tuple[int, int]:
    """``(columns, rows)`` the frame buffer stores of a ``width`` x ``height``
    frame at ``scale`` (in :data:`SCALE_RANGE`): ``ceil(width / scale)`` x
    ``ceil(height / scale)``."""
    scale = check_int("scale", scale, *SCALE_RANGE)
    return -(-width // scale), -(-height // scale)


def vga_frame(image, mode, pixel_bits: int = 4, *, scale: int = 1) -> np.ndarray:
    """The VGA outputs of one frame for an 8-bit image written to the frame buffer.

    Parameters
    ----------
    image : (height, width) array of unsigned integers in [0, 255]
        The frame the pipeline sent; width <= ``mode.h_active``, height <=
        ``mode.v_active``.
    mode : soc.vga_timing.VgaMode
        (or any object with its fields ``h_active`` .. ``v_back``,
        ``hsync_negative``, ``vsync_negative``).
    pixel_bits : int in [1, 8]
        Bits kept per pixel in the frame buffer.
    scale : int in :data:`SCALE_RANGE`
        1: every pixel is stored and shown; 2: the pixel at (2i, 2j) is shown
        at (2i .. 2i+1, 2j .. 2j+1), cut at width x height.

    Returns
    -------
    (v_total, h_total, 6) array of uint8
        Entry ``[y, x]`` is the output at raster position (x, y), channels in
        :data:`VGA_CHANNELS` order: r = g = b (grey, 0 outside the image and in
        the blanking), hsync (pulse for ``h_sync_start <= x < h_sync_start +
        h_sync``), vsync (pulse for lines ``v_sync_start <= y < v_sync_start +
        v_sync``, whole lines), each at the mode's polarity, and blank_n (1 in
        the visible area). Flattened in C order it is the sequence of one frame
        starting at x = 0, y = 0.

    Raises
    ------
    ValueError
        If the image is not 2-D unsigned 8-bit, larger than the visible area,
        or ``pixel_bits`` or ``scale`` is out of range.
    """
    image = check_image("image", image, dtype_kind="u", max_value=255)
    pixel_bits = check_int("pixel_bits", pixel_bits, 1, 8)
    scale = check_int("scale", scale, *SCALE_RANGE)
    height, width = image.shape
    check_int("image width", width, 1, mode.h_active)
    check_int("image height", height, 1, mode.v_active)
    h_total = mode.h_active + mode.h_front + mode.h_sync + mode.h_back
    v_total = mode.v_active + mode.v_front + mode.v_sync + mode.v_back
    frame = np.zeros((v_total, h_total, len(VGA_CHANNELS)), dtype=np.uint8)
    stored = image[::scale, ::scale]
    shown = np.repeat(np.repeat(stored, scale, axis=0), scale, axis=1)[:height, :width]
    grey = grey_levels(shown, pixel_bits)
    for channel in range(3):
        frame[:height, :width, channel] = grey
    hs0 = mode.h_active + mode.h_front
    vs0 = mode.v_active + mode.v_front
    in_hsync = np.zeros(h_total, dtype=bool)
    in_hsync[hs0:hs0 + mode.h_sync] = True
    in_vsync = np.zeros(v_total, dtype=bool)
    in_vsync[vs0:vs0 + mode.v_sync] = True
    frame[:, :, 3] = in_hsync[None, :] ^ bool(mode.hsync_negative)
    frame[:, :, 4] = in_vsync[:, None] ^ bool(mode.vsync_negative)
    frame[:mode.v_active, :mode.h_active, 5] = 1
    return frame
