"""YCbCr 4:2:2 <-> 4:4:4 conversion of the camera byte stream (thesis §5.4, Table 11).

The camera sends each image row as a byte stream ``Y0 Cb0 Y1 Cr0 Y2 Cb1 Y3 Cr1 ...``:
every pixel carries its own luma, and each pair of pixels ``(2k, 2k+1)`` shares one
``Cb_k`` and one ``Cr_k``. The hardware demultiplexes the stream into three 8-bit
planes and repeats each chroma sample for both pixels of its pair.
"""
from __future__ import annotations

import numpy as np

from .validation import check_image, check_same_shape

__all__ = ["ycbcr422_to_444", "ycbcr444_to_422"]


def ycbcr422_to_444(frame) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Unpack a 4:2:2 camera frame into full-resolution Y, Cb and Cr planes.

    Thesis §5.4, Table 11 (byte order of the YCbCr 4:2:2 output of the camera).

    Parameters
    ----------
    frame : (H, 2W) array of unsigned integers in [0, 255]
        One row per image line, bytes in the order ``Y0 Cb0 Y1 Cr0 Y2 Cb1 Y3 Cr1 ...``.
        The row length ``2W`` must be a positive multiple of 4 bytes (``W`` even).

    Returns
    -------
    y, cb, cr : (H, W) uint8 arrays
        ``y[:, i] = frame[:, 2i]``; chroma is replicated, not interpolated:
        ``cb[:, 2k] = cb[:, 2k+1] = frame[:, 4k+1]`` and
        ``cr[:, 2k] = cr[:, 2k+1] = frame[:, 4k+3]``. There is no border effect.

    Raises
    ------
    ValueError
        If ``frame`` is not 2-D, not unsigned, has values above 255, or its row
        length is not a multiple of 4.
    """
    frame = check_image("frame", frame, dtype_kind="u", max_value=255)
    row_bytes = frame.shape[1]
    if row_bytes % 4:
        raise ValueError(
            f"frame row length must be a multiple of 4 bytes (Y Cb Y Cr per pixel pair), "
            f"got {row_bytes}")
    frame = frame.astype(np.uint8, copy=False)
    y = frame[:, 0::2].copy()
    cb = np.repeat(frame[:, 1::4], 2, axis=1)
    cr = np.repeat(frame[:, 3::4], 2, axis=1)
    return y, cb, cr


def ycbcr444_to_422(y, cb, cr) -> np.ndarray:
    """Pack full-resolution Y, Cb, Cr planes into the camera's 4:2:2 byte stream.

    Inverse of :func:`ycbcr422_to_444` (thesis §5.4, Table 11); used by the scene
    renderer to produce what the camera would send.

    Parameters
    ----------
    y, cb, cr : (H, W) arrays of unsigned integers in [0, 255], same shape, ``W`` even.

    Returns
    -------
    frame : (H, 2W) uint8
        ``frame[:, 2i] = y[:, i]``; for pixel pair ``k`` the chroma byte is the
        rounded-half-up mean ``(c[:, 2k] + c[:, 2k+1] + 1) >> 1`` of the pair, placed at
        ``frame[:, 4k+1]`` (Cb) and ``frame[:, 4k+3]`` (Cr). Hence unpacking then
        repacking a 4:2:2 frame returns it unchanged.

    Raises
    ------
    ValueError
        If a plane is malformed, the shapes differ, or ``W`` is odd.
    """
    y = check_image("y", y, dtype_kind="u", max_value=255)
    cb = check_image("cb", cb, dtype_kind="u", max_value=255)
    cr = check_image("cr", cr, dtype_kind="u", max_value=255)
    check_same_shape(y=y, cb=cb, cr=cr)
    height, width = y.shape
    if width % 2:
        raise ValueError(f"y width must be even (pixels are packed in pairs), got {width}")

    def pair_mean(chroma: np.ndarray) -> np.ndarray:
        wide = chroma.astype(np.uint16)
        return ((wide[:, 0::2] + wide[:, 1::2] + 1) >> 1).astype(np.uint8)

    frame = np.empty((height, 2 * width), dtype=np.uint8)
    frame[:, 0::2] = y
    frame[:, 1::4] = pair_mean(cb)
    frame[:, 3::4] = pair_mean(cr)
    return frame
