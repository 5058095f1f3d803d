# amaranth: UnusedElaboratable=no
"""VGA debug view (thesis Table 22, SW[9:7]): the video mode figures, the raster
timing, and the dual-clock frame buffer in the Amaranth simulator, bit for bit
against the golden model :func:`sim.model.vga.vga_frame` on a small test mode,
the pipeline clock (10 ns) and the pixel clock (39.7 ns) unrelated."""
import re

import numpy as np
import pytest
from amaranth.sim import Simulator

from soc.frame_buffer import READ_LATENCY, FrameBuffer
from soc.vga_timing import VGA_640x480_60, VgaMode, VgaTiming
from sim.model.vga import VGA_CHANNELS, grey_levels, vga_frame

SYNC_PERIOD = 10e-9
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


# ------------------------------------------------------------------ golden model


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


# ------------------------------------------------------------------ frame buffer


def _run_frame_buffer(dut, images, seed, extra_beats=20, idle=0.3):
    """Write each image through ``i_stream`` (random idle cycles, junk beats
    before the first frame and after each), and capture the first whole VGA
    frame that starts after the write. The next image is written only once that
    frame is captured (the single buffer would tear otherwise). An image
    ``None`` sends only junk beats (no ``first``). Returns one
    (v_total, h_total, 6) array per image."""
    mode = dut.mode
    total = mode.h_total * mode.v_total
    rng = np.random.default_rng(seed)
    state = {"written": 0}
    frames = []

    async def send(ctx, first, pixel):
        while rng.random() < idle:
            ctx.set(dut.i_stream.valid, 0)
            await ctx.tick()
        ctx.set(dut.i_stream.valid, 1)
        ctx.set(dut.i_stream.payload.first, first)
        ctx.set(dut.i_stream.payload.pixel, int(pixel))
        await ctx.tick()

    async def writer(ctx):
        for _ in range(extra_beats):
            await send(ctx, 0, rng.integers(0, 256))
        for index, image in enumerate(images):
            while len(frames) < index:
                ctx.set(dut.i_stream.valid, 0)
                await ctx.tick()
            for k, pixel in enumerate([] if image is None else image.ravel()):
                await send(ctx, int(k == 0), pixel)
            for _ in range(extra_beats):  # past width * height: dropped
                await send(ctx, 0, rng.integers(0, 256))
            ctx.set(dut.i_stream.valid, 0)
            state["written"] += 1

    async def reader(ctx):
        vga = dut.vga
        outputs = (vga.r, vga.g, vga.b, vga.hsync, vga.vsync, vga.blank_n)
        ticks = 0  # pixel clocks since reset: the counters are at ticks % total
        for index in range(len(images)):
            # outputs after `ticks` clocks show raster position ticks - latency
            while state["written"] <= index or (ticks - dut.latency) % total:
                await ctx.tick("vga")
                ticks += 1
            samples = []
            for _ in range(total):
                samples.append([ctx.get(s) for s in outputs])
                await ctx.tick("vga")
                ticks += 1
            frames.append(np.array(samples, dtype=np.uint8).reshape(
                mode.v_total, mode.h_total, len(outputs)))

    sim = Simulator(dut)
    sim.add_clock(SYNC_PERIOD, domain="sync")
    sim.add_clock(VGA_PERIOD, domain="vga")
    sim.add_testbench(writer)
    sim.add_testbench(reader)
    sim.run()
    return frames


def _check_sync_pulses(frame, mode):
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


@pytest.mark.parametrize("width, height, pixel_bits, mode", [
    (12, 6, 4, TEST_MODE), (16, 8, 4, TEST_MODE), (16, 8, 3, TEST_MODE_POSITIVE),
    (12, 6, 8, TEST_MODE_POSITIVE), (16, 8, 1, TEST_MODE), (1, 1, 5, TEST_MODE)])
def test_frame_buffer_equals_model(width, height, pixel_bits, mode):
    rng = np.random.default_rng(width * 100 + pixel_bits)
    images = [rng.integers(0, 256, (height, width)).astype(np.uint8) for _ in range(2)]
    images[1][0, 0] = 255 - images[0][0, 0]  # the second frame must change pixel 0
    dut = FrameBuffer(width, height, mode, pixel_bits)
    assert dut.latency == READ_LATENCY
    assert dut.memory_bits == width * height * pixel_bits
    got = _run_frame_buffer(dut, images, seed=width + pixel_bits)
    for image, frame in zip(images, got):
        _check_sync_pulses(frame, mode)
        expected = vga_frame(image, mode, pixel_bits)
        for channel, name in enumerate(VGA_CHANNELS):
            assert (frame[:, :, channel] == expected[:, :, channel]).all(), name
    assert (got[0][:, :, 0] != got[1][:, :, 0]).any()  # the second frame overwrote


def test_frame_buffer_ignores_pixels_before_the_first_frame():
    """Beats before the first ``first`` (e.g. the tail of a frame when the
    pipeline starts) leave the buffer black; the next frame is shown whole."""
    mode = TEST_MODE
    image = np.random.default_rng(7).integers(1, 256, (8, 16)).astype(np.uint8)
    dut = FrameBuffer(16, 8, mode, 4)
    got = _run_frame_buffer(dut, [None, image], seed=3, extra_beats=40)
    assert (got[0] == vga_frame(np.zeros((8, 16), np.uint8), mode, 4)).all()
    assert (got[1] == vga_frame(image, mode, 4)).all()


@pytest.mark.parametrize("kwargs, name", [
    (dict(width=641), "width"), (dict(width=0), "width"), (dict(height=481), "height"),
    (dict(height=0), "height"), (dict(pixel_bits=0), "pixel_bits"),
    (dict(pixel_bits=9), "pixel_bits"), (dict(mode=(640, 480)), "mode")])
def test_frame_buffer_validation(kwargs, name):
    with pytest.raises(ValueError, match=name):
        FrameBuffer(**kwargs)


def test_frame_buffer_elaborates_at_board_size():
    """640x480x4: one memory of 307,200 x 4 bits, written on the pipeline clock
    and read on the pixel clock only; the ports of VgaOutputSignature."""
    from amaranth.back import rtlil

    from hdl.synthesis import component_ports
    dut = FrameBuffer()
    assert dut.memory_bits == 1_228_800 == 150 * 2048 * 4
    assert [path for path, _, _ in dut.vga.signature.flatten(dut.vga)] == [
        ("r",), ("g",), ("b",), ("hsync",), ("vsync",), ("blank_n",)]
    text = rtlil.convert(dut, ports=component_ports(dut))
    assert re.search(r"memory width 4 size 307200 ", text)
    cells = text.split("\n  cell ")
    write_clocks = {c for cell in cells if cell.startswith("$memwr")
                    for c in re.findall(r"connect \\CLK \\(\S+)", cell)}
    read_clocks = {c for cell in cells if cell.startswith("$memrd")
                   for c in re.findall(r"connect \\CLK \\(\S+)", cell)}
    assert write_clocks == {"clk"} and read_clocks == {"vga_clk"}
