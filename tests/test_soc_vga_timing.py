# amaranth: UnusedElaboratable=no
"""soc/vga_timing.py (thesis Table 22, SW[9:7]): the video mode figures and the
raster timing, against the golden model :func:`sim.model.vga.vga_frame` (its own
tests: tests/test_model_vga.py; the frame buffer: tests/test_soc_frame_buffer.py)."""
import numpy as np
import pytest
from amaranth.sim import Simulator

from soc.vga_timing import VGA_640x480_60, VgaMode, VgaTiming
from sim.model.vga import VGA_CHANNELS, vga_frame

VGA_PERIOD = 39.7e-9

#: 16x8 visible, 23 x 12 total: small porches, both sync polarities covered.
TEST_MODE = VgaMode(25_000_000, 16, 2, 3, 2, 8, 1, 2, 1, True, True)
TEST_MODE_POSITIVE = VgaMode(25_000_000, 16, 1, 2, 3, 8, 2, 1, 1, False, True)

HSYNC, VSYNC, BLANK_N = (VGA_CHANNELS.index(n) for n in ("hsync", "vsync", "blank_n"))


# ------------------------------------------------------------------ VgaMode


def test_vga_640x480_60_figures():
    mode = VGA_640x480_60
    assert (mode.h_total, mode.v_total) == (800, 525)
    assert round(mode.refresh_hz, 2) == 59.94
    assert (mode.h_sync_start, mode.v_sync_start) == (656, 490)
    assert mode.hsync_negative and mode.vsync_negative


@pytest.mark.parametrize("field, value", [
    ("pixel_clock", 0), ("h_active", 0), ("h_front", -1), ("h_sync", 0), ("h_back", -2),
    ("v_active", 0), ("v_front", -1), ("v_sync", 0), ("v_back", 1.5), ("h_active", 640.0),
    ("hsync_negative", 1), ("vsync_negative", None), ("h_back", 9000)])
def test_vga_mode_validation_names_the_field(field, value):
    figures = dict(pixel_clock=25_000_000, h_active=16, h_front=2, h_sync=3, h_back=2,
                   v_active=8, v_front=1, v_sync=2, v_back=1,
                   hsync_negative=True, vsync_negative=False)
    figures[field] = value
    with pytest.raises(ValueError, match=field):
        VgaMode(**figures)


def test_vga_mode_total_limit():
    with pytest.raises(ValueError, match="h_total"):
        VgaMode(1, 4000, 4000, 100, 100, 8, 1, 1, 1, True, True)


def test_vga_mode_is_frozen():
    with pytest.raises(AttributeError):
        VGA_640x480_60.h_active = 320


# ------------------------------------------------------------------ raster timing


def test_vga_timing_raster():
    mode = TEST_MODE_POSITIVE
    dut = VgaTiming(mode)
    model = vga_frame(np.zeros((1, 1), np.uint8), mode, 8)
    total = mode.h_total * mode.v_total
    seen = []

    async def testbench(ctx):
        for _ in range(2 * total + 5):
            seen.append([ctx.get(s) for s in (dut.x, dut.y, dut.active, dut.hsync,
                                              dut.vsync, dut.frame_start)])
            await ctx.tick()

    sim = Simulator(dut)
    sim.add_clock(VGA_PERIOD)
    sim.add_testbench(testbench)
    sim.run()
    seen = np.array(seen)
    k = np.arange(len(seen)) % total
    assert (seen[:, 0] == k % mode.h_total).all() and (seen[:, 1] == k // mode.h_total).all()
    flat = model.reshape(total, -1)[k]
    assert (seen[:, 2] == flat[:, BLANK_N]).all()
    assert (seen[:, 3] == flat[:, HSYNC]).all() and (seen[:, 4] == flat[:, VSYNC]).all()
    assert (np.flatnonzero(seen[:, 5]) == [0, total, 2 * total]).all()


def check_sync_pulses(frame, mode):
    """Pulse widths, positions and polarity, straight from the mode figures."""
    hsync_on = frame[:, :, HSYNC] ^ int(mode.hsync_negative)
    vsync_on = frame[:, :, VSYNC] ^ int(mode.vsync_negative)
    for row in hsync_on:
        assert (np.flatnonzero(row) == np.arange(mode.h_sync) + mode.h_sync_start).all()
    assert (vsync_on == vsync_on[:, :1]).all()
    assert (np.flatnonzero(vsync_on[:, 0]) == np.arange(mode.v_sync) + mode.v_sync_start).all()
    blank_n = frame[:, :, BLANK_N]
    assert blank_n[:mode.v_active, :mode.h_active].all() and \
        blank_n.sum() == mode.h_active * mode.v_active
