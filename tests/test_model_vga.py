"""sim/model/vga.py: the VGA debug view's golden model (thesis Table 22):
sync positions of the 640x480 mode, grey replication, bad arguments."""
import numpy as np
import pytest

from soc.vga_timing import VGA_640x480_60
from sim.model.vga import grey_levels, vga_frame
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


def test_model_rejects_bad_arguments():
    with pytest.raises(ValueError, match="pixel_bits"):
        vga_frame(np.zeros((8, 16), np.uint8), TEST_MODE, 9)
    with pytest.raises(ValueError, match="width"):
        vga_frame(np.zeros((8, 17), np.uint8), TEST_MODE, 4)
    with pytest.raises(ValueError, match="height"):
        vga_frame(np.zeros((9, 16), np.uint8), TEST_MODE, 4)
