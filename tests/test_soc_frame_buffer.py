# amaranth: UnusedElaboratable=no
"""soc/frame_buffer.py: the dual-clock frame buffer of the VGA debug view in the
Amaranth simulator, bit for bit against the golden model
:func:`sim.model.vga.vga_frame` on a small test mode, at full and half
resolution, the pipeline clock (10 ns) and the pixel clock (39.7 ns) unrelated."""
import re

import numpy as np
import pytest
from amaranth.sim import Simulator

from soc.frame_buffer import READ_LATENCY, VGA_SCALE, FrameBuffer
from sim.model.vga import VGA_CHANNELS, vga_frame
from tests.test_soc_vga_timing import (TEST_MODE, TEST_MODE_POSITIVE, VGA_PERIOD,
                                       check_sync_pulses)

SYNC_PERIOD = 10e-9


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


@pytest.mark.parametrize("width, height, pixel_bits, mode, scale", [
    (12, 6, 4, TEST_MODE, 1), (16, 8, 4, TEST_MODE, 1), (16, 8, 3, TEST_MODE_POSITIVE, 1),
    (12, 6, 8, TEST_MODE_POSITIVE, 1), (16, 8, 1, TEST_MODE, 1), (1, 1, 5, TEST_MODE, 1),
    # half resolution: even and odd sizes (the last column / row stored once), one
    # column, one row, one pixel
    (16, 8, 4, TEST_MODE, 2), (13, 7, 3, TEST_MODE_POSITIVE, 2), (12, 5, 8, TEST_MODE, 2),
    (1, 8, 4, TEST_MODE_POSITIVE, 2), (16, 1, 2, TEST_MODE, 2), (1, 1, 5, TEST_MODE, 2)])
def test_frame_buffer_equals_model(width, height, pixel_bits, mode, scale):
    rng = np.random.default_rng(width * 100 + pixel_bits * 10 + scale)
    images = [rng.integers(0, 256, (height, width)).astype(np.uint8) for _ in range(2)]
    images[1][0, 0] = 255 - images[0][0, 0]  # the second frame must change pixel 0
    dut = FrameBuffer(width, height, mode, pixel_bits, scale=scale)
    assert dut.latency == READ_LATENCY
    assert dut.memory_bits == -(-width // scale) * -(-height // scale) * pixel_bits
    got = _run_frame_buffer(dut, images, seed=width + pixel_bits + scale)
    for image, frame in zip(images, got):
        check_sync_pulses(frame, mode)
        expected = vga_frame(image, mode, pixel_bits, scale=scale)
        for channel, name in enumerate(VGA_CHANNELS):
            assert (frame[:, :, channel] == expected[:, :, channel]).all(), name
        if scale == 2 and width > 1:    # the check tells the two scales apart
            assert (frame[:, :, 0] != vga_frame(image, mode, pixel_bits)[:, :, 0]).any()
    assert (got[0][:, :, 0] != got[1][:, :, 0]).any()  # the second frame overwrote


@pytest.mark.parametrize("scale", [1, 2])
def test_frame_buffer_ignores_pixels_before_the_first_frame(scale):
    """Beats before the first ``first`` (e.g. the tail of a frame when the
    pipeline starts) leave the buffer black; the next frame is shown whole."""
    mode = TEST_MODE
    image = np.random.default_rng(7).integers(1, 256, (8, 16)).astype(np.uint8)
    dut = FrameBuffer(16, 8, mode, 4, scale=scale)
    got = _run_frame_buffer(dut, [None, image], seed=3, extra_beats=40)
    assert (got[0] == vga_frame(np.zeros((8, 16), np.uint8), mode, 4, scale=scale)).all()
    assert (got[1] == vga_frame(image, mode, 4, scale=scale)).all()


@pytest.mark.parametrize("kwargs, match", [
    (dict(width=641), "width"), (dict(width=0), "width"), (dict(height=481), "height"),
    (dict(height=0), "height"), (dict(pixel_bits=0), "pixel_bits"),
    (dict(pixel_bits=9), "pixel_bits"), (dict(mode=(640, 480)), "mode"),
    (dict(scale=0), r"scale must be in \[1, 2\], got 0"),
    (dict(scale=3), r"scale must be in \[1, 2\], got 3"),
    (dict(scale=1.5), r"scale must be an integer in \[1, 2\]")])
def test_frame_buffer_validation(kwargs, match):
    with pytest.raises(ValueError, match=match):
        FrameBuffer(**kwargs)


@pytest.mark.parametrize("scale, words", [(1, 640 * 480), (2, 320 * 240)])
def test_frame_buffer_elaborates_at_board_size(scale, words):
    """640x480x4: one memory of 4-bit words (307,200 at full resolution, 150
    M10K; 76,800 at half), written on the pipeline clock and read on the pixel
    clock only; the ports of VgaOutputSignature. Half resolution is the default."""
    from amaranth.back import rtlil

    from hdl.synthesis import component_ports
    assert VGA_SCALE == FrameBuffer().scale == 2
    dut = FrameBuffer(scale=scale)
    assert dut.memory_bits == words * 4
    if scale == 1:
        assert dut.memory_bits == 150 * 2048 * 4      # 150 M10K in 2K x 4 mode
    assert [path for path, _, _ in dut.vga.signature.flatten(dut.vga)] == [
        ("r",), ("g",), ("b",), ("hsync",), ("vsync",), ("blank_n",)]
    text = rtlil.convert(dut, ports=component_ports(dut))
    assert re.search(rf"memory width 4 size {words} ", text)
    cells = text.split("\n  cell ")
    write_clocks = {c for cell in cells if cell.startswith("$memwr")
                    for c in re.findall(r"connect \\CLK \\(\S+)", cell)}
    read_clocks = {c for cell in cells if cell.startswith("$memrd")
                   for c in re.findall(r"connect \\CLK \\(\S+)", cell)}
    assert write_clocks == {"clk"} and read_clocks == {"vga_clk"}
