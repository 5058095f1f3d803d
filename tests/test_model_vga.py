"""sim/model/vga.py: the VGA debug view's golden model (thesis Table 22):
sync positions of the 640x480 mode, grey replication, half resolution, bad
arguments."""
import numpy as np
import pytest

from soc.vga_timing import VGA_640x480_60
from sim.model.vga import grey_levels, stored_size, vga_frame
from tests.test_soc_vga_timing import BLANK_N, HSYNC, TEST_MODE, VSYNC


def test_model_640x480_sync_positions():
    image = np.arange(640 * 480, dtype=np.int64).reshape(480, 640) % 256
    frame = vga_frame(image.astype(np.uint8), VGA_640x480_60, 4)
    assert frame.shape == (525, 800, 6)
    assert (np.flatnonzero(frame[0, :, HSYNC] == 0) == np.arange(656, 752)).all()
    assert (np.flatnonzero(frame[:, 0, VSYNC] == 0) == np.arange(490, 492)).all()
    assert (frame[:, :, VSYNC] == frame[:, :1, VSYNC]).all()  # whole lines
    assert frame[:, :, BLANK_N].sum() == 640 * 480
    assert frame[:480, :640, BLANK_N].all()
    assert (frame[:480, :640, 0] == ((image >> 4) * 17)).all()


def test_model_grey_replication():
    pixels = np.array([0, 0xA7, 0x80, 0x7F, 255])
    assert list(grey_levels(pixels, 4)) == [0, 0xAA, 0x88, 0x77, 255]
    assert list(grey_levels(pixels, 3)) == [0, 0b10110110, 0b10010010, 0b01101101, 255]
    assert list(grey_levels(pixels, 1)) == [0, 255, 255, 0, 255]
    assert list(grey_levels(pixels, 8)) == list(pixels)
    levels = grey_levels(np.arange(256), 5)
    assert (np.diff(levels.astype(int)) >= 0).all() and len(set(levels)) == 32


def test_model_half_resolution_shows_even_pixels_as_blocks():
    """scale 2: the pixel at (2i, 2j) fills (2i..2i+1, 2j..2j+1), written out by
    hand on a 5x3 image (odd: the last column and row are shown once)."""
    image = np.array([[0x10, 0x20, 0x30, 0x40, 0x50],
                      [0x60, 0x70, 0x80, 0x90, 0xA0],
                      [0xB0, 0xC0, 0xD0, 0xE0, 0xF0]], np.uint8)
    shown = np.array([[0x11, 0x11, 0x33, 0x33, 0x55],
                      [0x11, 0x11, 0x33, 0x33, 0x55],
                      [0xBB, 0xBB, 0xDD, 0xDD, 0xFF]])
    frame = vga_frame(image, TEST_MODE, 4, scale=2)
    for channel in range(3):
        assert (frame[:3, :5, channel] == shown).all()
        assert not frame[3:, :, channel].any() and not frame[:, 5:, channel].any()
    full = vga_frame(image, TEST_MODE, 4, scale=1)
    assert (full[..., 3:] == frame[..., 3:]).all()          # syncs and blanking alike
    assert (full[:3, :5, 0] == (image >> 4) * 17).all()
    assert (vga_frame(image, TEST_MODE, 4) == full).all()   # scale 1 unless asked
    assert stored_size(5, 3, 2) == (3, 2) and stored_size(640, 480, 2) == (320, 240)
    assert stored_size(5, 3, 1) == (5, 3)


def test_model_rejects_bad_arguments():
    with pytest.raises(ValueError, match="pixel_bits"):
        vga_frame(np.zeros((8, 16), np.uint8), TEST_MODE, 9)
    with pytest.raises(ValueError, match="width"):
        vga_frame(np.zeros((8, 17), np.uint8), TEST_MODE, 4)
    with pytest.raises(ValueError, match="height"):
        vga_frame(np.zeros((9, 16), np.uint8), TEST_MODE, 4)
    for scale in (0, 3, 4):
        with pytest.raises(ValueError, match=r"scale must be in \[1, 2\]"):
            vga_frame(np.zeros((8, 16), np.uint8), TEST_MODE, 4, scale=scale)
    with pytest.raises(ValueError, match="scale must be an integer"):
        stored_size(16, 8, 2.0)
