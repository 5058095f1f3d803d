"""Pictures of the pipeline stages for people (PNG previews, not bit-exact data):
colour-mapped disparity with its colour bar, labelled stage sheets, the
trajectory with a legend."""
from __future__ import annotations

from functools import lru_cache

import numpy as np
from PIL import Image, ImageDraw, ImageFont

__all__ = ["disparity_picture", "mask_picture", "trajectory_picture", "colour_bar",
           "disparity_preview", "stage_sheet", "LEGEND_HEIGHT"]

_WHITE, _GREY = (255, 255, 255), (160, 160, 160)
_GESTURE, _REST, _START = (255, 60, 60), (80, 140, 255), (60, 255, 60)


def _font(size: int = 14):
    """Pillow's own scalable font (no font file needed)."""
    return ImageFont.load_default(size=size)

# Colour ramp (far = blue ... near = red), linearly interpolated.
_RAMP = np.array([[48, 18, 59], [40, 120, 230], [30, 200, 180], [140, 230, 60],
                  [250, 190, 40], [230, 70, 20], [122, 4, 3]], dtype=np.float64)


@lru_cache(maxsize=16)
def _colours(max_disparity: int) -> np.ndarray:
    """(max_disparity, 3) uint8: the colour of each disparity, 0 black."""
    scale = np.arange(max_disparity) / max(1, max_disparity - 1)
    pos = scale * (len(_RAMP) - 1)
    lo = np.floor(pos).astype(int)
    hi = np.minimum(lo + 1, len(_RAMP) - 1)
    frac = (pos - lo)[..., None]
    lut = (_RAMP[lo] * (1 - frac) + _RAMP[hi] * frac).round().astype(np.uint8)
    lut[0] = 0
    lut.setflags(write=False)
    return lut


def disparity_picture(disparity, max_disparity: int) -> np.ndarray:
    """(H, W, 3) uint8 colour picture of a disparity map; invalid (0) is black,
    values from ``max_disparity - 1`` up the nearest colour."""
    disp = np.asarray(disparity)
    return _colours(max(1, int(max_disparity)))[np.clip(disp, 0, max(0, max_disparity - 1))
                                               .astype(np.intp)]


def mask_picture(mask) -> np.ndarray:
    """(H, W) uint8: 255 where the mask is set, else 0."""
    return np.asarray(mask, dtype=bool).astype(np.uint8) * 255


_LEGEND = [(_GESTURE, "gesture frames (flag set)"), (_REST, "other frames"),
           (_START, "gesture start"), (_WHITE, "frame number")]
#: Rows of the legend under :func:`trajectory_picture`'s picture.
LEGEND_HEIGHT = 8 + 15 * len(_LEGEND)


def place_labels(draw, labels, font, size) -> list:
    """Where to write each ``(point, text)`` label beside its point so that no
    two labels overlap and each stays inside ``size``: the first free place of
    four around the point; a label with none is left out (its point is still
    drawn). Returns ``[((x, y), text), ...]``."""
    placed, boxes = [], []
    width, height = size
    for (px, py), text in labels:
        left, top, right, bottom = draw.textbbox((0, 0), text, font=font, stroke_width=2)
        w, h = right - left, bottom - top
        for dx, dy in ((5, -h - 5), (5, 5), (-w - 5, -h - 5), (-w - 5, 5)):
            x, y = px + dx, py + dy
            box = (x + left, y + top, x + left + w, y + top + h)
            inside = box[0] >= 0 and box[1] >= 0 and box[2] <= width and box[3] <= height
            if inside and not any(box[0] < b[2] and b[0] < box[2] and box[1] < b[3]
                                  and b[1] < box[3] for b in boxes):
                boxes.append(box)
                placed.append(((x, y), text))
                break
    return placed


def trajectory_picture(background, smoothed, flag, frac_bits: int = 8) -> np.ndarray:
    """The smoothed centroid track over a grey background: gesture frames red,
    other frames blue, the first gesture point green, every tenth frame
    marked and numbered where its number has room (:func:`place_labels`);
    below the picture (:data:`LEGEND_HEIGHT` rows) a legend saying so."""
    grey = np.asarray(background, dtype=np.uint8)
    img = Image.fromarray(np.stack([grey // 2] * 3, axis=-1))
    draw = ImageDraw.Draw(img)
    pts = np.asarray(smoothed, dtype=np.float64) / (1 << frac_bits)
    flag = np.asarray(flag, dtype=bool)
    for n in range(1, len(pts)):
        if (pts[n] == 0).all() or (pts[n - 1] == 0).all():
            continue  # no hand yet
        colour = _GESTURE if flag[n] else _REST
        draw.line([tuple(pts[n - 1]), tuple(pts[n])], fill=colour, width=3)
    starts = np.flatnonzero(flag & ~np.concatenate([[False], flag[:-1]]))
    for n in starts:
        x, y = pts[n]
        draw.ellipse([x - 6, y - 6, x + 6, y + 6], outline=_START, width=3)
    font = _font(11)
    numbered = [n for n in range(0, len(pts), 10) if not (pts[n] == 0).all()]
    for n in numbered:
        x, y = pts[n]
        draw.ellipse([x - 2, y - 2, x + 2, y + 2], fill=_WHITE)
    for (x, y), text in place_labels(draw, [(pts[n], str(n)) for n in numbered], font,
                                     img.size):
        draw.text((x, y), text, font=font, fill=_WHITE, stroke_width=2,
                  stroke_fill=(0, 0, 0))
    out = Image.new("RGB", (img.width, img.height + LEGEND_HEIGHT), (24, 24, 24))
    out.paste(img, (0, 0))
    draw = ImageDraw.Draw(out)
    for k, (colour, text) in enumerate(_LEGEND):
        y = img.height + 4 + 15 * k
        draw.rectangle([6, y + 2, 16, y + 10], fill=colour)
        draw.text((21, y), text, font=font, fill=_WHITE)
    return np.asarray(out)


def colour_bar(height: int, max_disparity: int, width: int = 70) -> np.ndarray:
    """(height, width, 3) uint8: the colour ramp of :func:`disparity_picture`
    from 0 (bottom) to ``max_disparity - 1`` (top), labelled in pixels of
    disparity, black (no match) at the foot."""
    bar = np.zeros((height, width, 3), np.uint8)
    top, bottom = 18, height - 34
    span = max(1, bottom - top)
    values = np.round((bottom - np.arange(top, bottom + 1)) / span
                      * (max_disparity - 1)).astype(int)
    ramp = disparity_picture(np.maximum(values, 1)[:, None], max_disparity)
    bar[top:bottom + 1, 4:20] = ramp
    img = Image.fromarray(bar)
    draw = ImageDraw.Draw(img)
    font = _font(11)
    step = max(1, int(round((max_disparity - 1) / 6 / 5)) * 5) if max_disparity > 12 else 2
    for value in list(range(0, max_disparity, step)) + [max_disparity - 1]:
        y = bottom - value / max(1, max_disparity - 1) * span
        draw.line([(20, y), (24, y)], fill=_WHITE)
        draw.text((27, y - 6), str(value), font=font, fill=_WHITE)
    draw.text((2, 2), "px", font=font, fill=_WHITE)
    draw.rectangle([4, height - 22, 19, height - 12], fill=(0, 0, 0), outline=_GREY)
    draw.text((23, height - 24), "none", font=font, fill=_WHITE)
    return np.asarray(img)


def disparity_preview(disparity, max_disparity: int) -> np.ndarray:
    """A disparity map for an image viewer: colour-mapped (near = red, far =
    blue, no match = black) with :func:`colour_bar` beside it."""
    pic = disparity_picture(disparity, max_disparity)
    bar = colour_bar(max(pic.shape[0], 120), max_disparity)
    out = np.zeros((bar.shape[0], pic.shape[1] + bar.shape[1], 3), np.uint8)
    out[:pic.shape[0], :pic.shape[1]] = pic
    out[:, pic.shape[1]:] = bar
    return out


def stage_sheet(frame: int, panels: dict, centroid=None, flag: bool = False,
                max_disparity: int = 48) -> np.ndarray:
    """One picture of a frame's stages for a person: each panel (a name and a
    grey, mask or RGB image; ``"disparity"`` is colour-mapped with its colour
    bar) captioned, two rows, a title with the frame number, the centroid
    (marked on every panel) and whether the frame is flagged as gesture."""
    pictures = {}
    for name, image in panels.items():
        image = np.asarray(image)
        if name == "disparity":
            image = disparity_preview(image, max_disparity)
        elif image.dtype == bool:
            image = mask_picture(image)
        if image.ndim == 2:
            image = np.stack([image.astype(np.uint8)] * 3, axis=-1)
        pictures[name] = image.astype(np.uint8)
    cols = -(-len(pictures) // 2)
    cell_h = max(p.shape[0] for p in pictures.values()) + 22
    cell_w = max(p.shape[1] for p in pictures.values()) + 8
    title_h = 30
    sheet = Image.new("RGB", (cols * cell_w, title_h + 2 * cell_h), (24, 24, 24))
    draw = ImageDraw.Draw(sheet)
    where = "no hand" if centroid is None else f"centroid ({centroid[0]:.1f}, {centroid[1]:.1f})"
    state = "gesture (flag set)" if flag else "no gesture"
    draw.text((8, 6), f"frame {frame}   {where}   {state}", font=_font(16), fill=_WHITE)
    for k, (name, image) in enumerate(pictures.items()):
        x0, y0 = (k % cols) * cell_w + 4, title_h + (k // cols) * cell_h
        draw.text((x0, y0 + 2), name, font=_font(13), fill=_WHITE)
        sheet.paste(Image.fromarray(image), (x0, y0 + 20))
        if centroid is not None:
            cx, cy = x0 + centroid[0], y0 + 20 + centroid[1]
            colour = _GESTURE if flag else _START
            draw.line([(cx - 7, cy), (cx + 7, cy)], fill=colour, width=2)
            draw.line([(cx, cy - 7), (cx, cy + 7)], fill=colour, width=2)
    return np.asarray(sheet)
