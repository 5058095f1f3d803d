"""Image files: reading stereo inputs as 8-bit grey, writing 16-bit disparity PNGs."""
from __future__ import annotations

from pathlib import Path

import numpy as np
from PIL import Image

__all__ = ["rgb_to_grey", "read_grey", "read_array", "write_png"]


def rgb_to_grey(rgb) -> np.ndarray:
    """ITU-R BT.601 luma in integers: ``(77 R + 150 G + 29 B + 128) >> 8``."""
    arr = np.asarray(rgb, dtype=np.int32)
    if arr.ndim != 3 or arr.shape[2] < 3:
        raise ValueError(f"rgb must be an (H, W, 3) image, got shape {arr.shape}")
    return ((77 * arr[..., 0] + 150 * arr[..., 1] + 29 * arr[..., 2] + 128) >> 8).astype(np.uint8)


def _open(path) -> Image.Image:
    path = Path(path)
    if not path.is_file():
        raise FileNotFoundError(f"no such image file: {path}")
    try:
        img = Image.open(path)
        img.load()
    except Exception as exc:  # PIL raises several unrelated types
        raise ValueError(f"{path}: not a readable image ({exc})") from None
    return img


def read_grey(path) -> np.ndarray:
    """Read an image file as (H, W) uint8 grey (colour through :func:`rgb_to_grey`)."""
    img = _open(path)
    if img.mode in ("L", "P", "I;16", "I"):
        arr = np.asarray(img.convert("L") if img.mode == "P" else img)
        if arr.dtype != np.uint8:
            if arr.max() > 255:
                raise ValueError(f"{path}: expected an 8-bit image, got values up to {arr.max()}")
            arr = arr.astype(np.uint8)
        return arr
    return rgb_to_grey(np.asarray(img.convert("RGB")))


def read_array(path) -> np.ndarray:
    """Read a single-channel image file (8 or 16 bit) as an integer array; a
    grey image stored as RGB(A) is accepted, a colour one refused (ValueError
    naming the file: a photo is not a map)."""
    img = _open(path)
    arr = np.asarray(img)
    if arr.ndim == 3:
        colour = arr[..., :3]
        if (colour != colour[..., :1]).any():
            raise ValueError(f"{path}: a colour image, expected a single-channel map")
        arr = arr[..., 0]
    return arr.astype(np.int64) if arr.dtype.kind in "iu" else arr


def write_png(path, image, *, bits: int | None = None) -> None:
    """Write an image as PNG through a temporary file (no half-written file).

    ``bits`` is 8 or 16; by default 8 for uint8/bool images, else 16. Bool
    images are written as 0/255.
    """
    arr = np.asarray(image)
    if arr.ndim not in (2, 3):
        raise ValueError(f"image must be (H, W) or (H, W, 3), got shape {arr.shape}")
    if bits is None:
        bits = 8 if arr.dtype == np.uint8 or arr.dtype == bool else 16
    path = Path(path)
    tmp = path.with_name(path.name + ".part")
    if arr.dtype == bool:
        arr = arr.astype(np.uint8) * 255
    if bits == 16:
        img = Image.fromarray(arr.astype(np.uint16))
    else:
        img = Image.fromarray(arr.astype(np.uint8))
    try:
        img.save(tmp, format="PNG")
        tmp.replace(path)
    finally:
        if tmp.exists():
            tmp.unlink()
