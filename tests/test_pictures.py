"""The PNG previews of sim.pictures: disparity colours, masks, the trajectory drawing."""
import colorsys

import numpy as np
import pytest

from sim.pictures import LEGEND_HEIGHT, disparity_picture, mask_picture, trajectory_picture

RED, BLUE, GREEN = (255, 60, 60), (80, 140, 255), (60, 255, 60)


@pytest.mark.parametrize("max_disparity", [16, 48, 64])
def test_disparity_picture_colours(max_disparity):
    disp = np.tile(np.arange(max_disparity, dtype=np.uint8), (3, 1))
    pic = disparity_picture(disp, max_disparity)
    assert pic.shape == (3, max_disparity, 3) and pic.dtype == np.uint8
    assert np.array_equal(pic[0], pic[2])                    # a colour per value only
    row = pic[0].astype(int)
    assert not row[0].any()                                  # invalid (0) is black
    assert row[1:].sum(axis=1).min() > 0                     # no valid value is black
    assert len({tuple(c) for c in row[1:]}) == max_disparity - 1   # all distinct
    far, near = row[1], row[-1]
    assert far[2] > far[0]                                   # far is blue-ish ...
    assert near[0] > 2 * near[1] and near[0] > 2 * near[2]   # ... near is red
    # In between the hue turns steadily from blue through green to red.
    hues = [colorsys.rgb_to_hsv(*(c / 255))[0] for c in row[1:]]
    assert np.all(np.diff(hues) <= 1e-9)
    assert any(abs(h - 1 / 3) < 0.08 for h in hues)          # passes through green


def test_disparity_picture_same_value_same_colour_anywhere():
    rng = np.random.default_rng(1)
    disp = rng.integers(0, 48, (20, 30))
    pic = disparity_picture(disp, 48)
    lut = disparity_picture(np.arange(48)[None, :], 48)[0]
    assert np.array_equal(pic, lut[disp])


def test_mask_picture():
    mask = np.array([[True, False], [False, True]])
    pic = mask_picture(mask)
    assert pic.dtype == np.uint8 and pic.tolist() == [[255, 0], [0, 255]]
    assert mask_picture(mask.astype(np.int64)).tolist() == [[255, 0], [0, 255]]
    assert not mask_picture(np.zeros((4, 5), bool)).any()


def close_to(pixel, colour, tol=30):
    return np.all(np.abs(pixel.astype(int) - np.array(colour)) <= tol)


def test_trajectory_picture():
    background = np.full((100, 120), 200, np.uint8)
    s = 256
    #            no hand  rest      moving right, not flagged; down, then right, flagged
    points = np.array([[0, 0], [10, 20], [60, 20], [60, 80], [100, 80]]) * s
    flag = np.array([False, False, False, True, True])
    full = trajectory_picture(background, points, flag)
    assert full.shape == (100 + LEGEND_HEIGHT, 120, 3) and full.dtype == np.uint8
    pic, legend = full[:100], full[100:]
    # the legend's keys, one per row: gesture red, other frames blue, start green
    assert [tuple(legend[10 + 15 * k, 10]) for k in range(3)] == [RED, BLUE, GREEN]
    assert close_to(pic[20, 35], BLUE, 0)          # unflagged step (10, 20) -> (60, 20)
    assert close_to(pic[50, 60], RED, 0)           # flagged step (60, 20) -> (60, 80)
    assert close_to(pic[80, 85], RED, 0)           # flagged step (60, 80) -> (100, 80)
    assert close_to(pic[80, 54], GREEN, 0)         # ring round the first gesture point
    assert close_to(pic[90, 10], (100, 100, 100), 0)   # background at half brightness
    # No line from the "no hand" point (0, 0).
    assert close_to(pic[10, 5], (100, 100, 100), 0)
    red = np.all(pic == RED, axis=-1)
    blue = np.all(pic == BLUE, axis=-1)
    assert red.sum() > 100 and blue.sum() > 100
    ys, xs = np.nonzero(red)
    assert xs.min() >= 57 and ys.min() >= 17       # red only along the flagged steps
    ys, xs = np.nonzero(blue)
    assert ys.max() <= 23 and xs.min() >= 8        # blue only along the unflagged step


def test_trajectory_picture_frac_bits_and_no_gesture():
    background = np.zeros((40, 40), np.uint8)
    points = np.array([[5, 5], [30, 5]]) * 16
    pic = trajectory_picture(background, points, [False, False], frac_bits=4)[:40]
    assert close_to(pic[5, 20], BLUE, 0)
    assert not np.all(pic == GREEN, axis=-1).any() and not np.all(pic == RED, axis=-1).any()


def test_colour_bar_runs_from_far_to_near_with_its_labels():
    from sim.pictures import colour_bar
    bar = colour_bar(200, 48)
    assert bar.shape == (200, 70, 3) and bar.dtype == np.uint8
    ramp = bar[18:167, 10].astype(int)           # the ramp column, top to bottom
    top, bottom = ramp[0], ramp[-1]
    assert top[0] > 2 * top[2]                   # the largest disparity (near) is red
    assert bottom[2] > bottom[0]                 # small disparities (far) are blue
    assert (bar[:, 27:] > 200).any()             # white tick labels to the right


def test_disparity_preview_puts_the_bar_beside_the_map():
    from sim.pictures import disparity_preview
    disp = np.tile(np.arange(64) % 48, (150, 1)).astype(np.uint16)
    pic = disparity_preview(disp, 48)
    assert pic.shape == (150, 64 + 70, 3)
    assert np.array_equal(pic[:, :64], disparity_picture(disp, 48))


def test_stage_sheet_labels_every_panel_and_marks_the_centroid():
    from sim.pictures import stage_sheet
    grey = np.full((40, 60), 90, np.uint8)
    panels = {"left camera": grey, "right camera": grey, "disparity": np.full((40, 60), 20),
              "skin": np.zeros((40, 60), bool), "band": np.zeros((40, 60), bool),
              "opening": np.zeros((40, 60), bool)}
    flagged = stage_sheet(7, panels, centroid=(30.0, 20.0), flag=True)
    still = stage_sheet(7, panels, centroid=(30.0, 20.0), flag=False)
    empty = stage_sheet(7, panels, centroid=None)
    assert flagged.shape == still.shape == empty.shape and flagged.shape[2] == 3
    # the centroid cross is red on a flagged frame, green otherwise, absent without a hand
    assert (flagged == RED).all(axis=-1).sum() > 20
    assert (still == GREEN).all(axis=-1).sum() > 20
    assert not (empty == RED).all(axis=-1).any() and not (empty == GREEN).all(axis=-1).any()
    # title and captions are drawn (white text on the dark background)
    assert (flagged[:30] > 200).all(axis=-1).any()


def test_trajectory_labels_never_overlap():
    """A hand held still puts every tenth frame on one spot: at most four
    numbers fit around it, the others are left out; spread points are all
    numbered; no two numbers overlap and none leaves the picture."""
    from PIL import Image, ImageDraw

    from sim.pictures import _font, place_labels
    draw = ImageDraw.Draw(Image.new("RGB", (160, 120)))
    font = _font(11)
    still = place_labels(draw, [((80, 60), str(n)) for n in range(0, 100, 10)], font, (160, 120))
    assert 1 <= len(still) <= 4
    spread = place_labels(draw, [((20 + 40 * k, 60), str(10 * k)) for k in range(4)], font,
                          (160, 120))
    assert [text for _, text in spread] == ["0", "10", "20", "30"]
    for labels in (still, spread):
        boxes = [draw.textbbox(xy, text, font=font, stroke_width=2) for xy, text in labels]
        for i, a in enumerate(boxes):
            assert 0 <= a[0] and 0 <= a[1] and a[2] <= 160 and a[3] <= 120
            for b in boxes[i + 1:]:
                assert not (a[0] < b[2] and b[0] < a[2] and a[1] < b[3] and b[1] < a[3])
