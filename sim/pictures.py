"""Pictures of the pipeline stages for people (PNG previews, not bit-exact data)."""
from __future__ import annotations

import numpy as np
from PIL import Image, ImageDraw

__all__ = ["disparity_picture", "mask_picture", "trajectory_picture"]

# Colour ramp (far = blue ... near = red), linearly interpolated.
_RAMP = np.array([[48, 18, 59], [40, 120, 230], [30, 200, 180], [140, 230, 60],
                  [250, 190, 40], [230, 70, 20], [122, 4, 3]], dtype=np.float64)


def disparity_picture(disparity, max_disparity: int) -> np.ndarray:
    """(H, W, 3) uint8 colour picture of a disparity map; invalid (0) is black."""
    disp = np.asarray(disparity)
    scale = np.clip(disp.astype(np.float64) / max(1, max_disparity - 1), 0.0, 1.0)
    pos = scale * (len(_RAMP) - 1)
    lo = np.floor(pos).astype(int)
    hi = np.minimum(lo + 1, len(_RAMP) - 1)
    frac = (pos - lo)[..., None]
    rgb = (_RAMP[lo] * (1 - frac) + _RAMP[hi] * frac).round().astype(np.uint8)
    rgb[disp == 0] = 0
    return rgb


def mask_picture(mask) -> np.ndarray:
    """(H, W) uint8: 255 where the mask is set, else 0."""
    return np.asarray(mask, dtype=bool).astype(np.uint8) * 255


def trajectory_picture(background, smoothed, flag, frac_bits: int = 8) -> np.ndarray:
    """The smoothed centroid track over a grey background: gesture frames red,
    other frames blue, the first gesture point green."""
    grey = np.asarray(background, dtype=np.uint8)
    img = Image.fromarray(np.stack([grey // 2] * 3, axis=-1))
    draw = ImageDraw.Draw(img)
    pts = np.asarray(smoothed, dtype=np.float64) / (1 << frac_bits)
    flag = np.asarray(flag, dtype=bool)
    for n in range(1, len(pts)):
        if (pts[n] == 0).all() or (pts[n - 1] == 0).all():
            continue  # no hand yet
        colour = (255, 60, 60) if flag[n] else (80, 140, 255)
        draw.line([tuple(pts[n - 1]), tuple(pts[n])], fill=colour, width=3)
    starts = np.flatnonzero(flag & ~np.concatenate([[False], flag[:-1]]))
    for n in starts:
        x, y = pts[n]
        draw.ellipse([x - 6, y - 6, x + 6, y + 6], outline=(60, 255, 60), width=3)
    return np.asarray(img)
