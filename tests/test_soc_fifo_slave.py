# amaranth: UnusedElaboratable=no
"""FifoSlave (thesis §7.4.1, Tables 12-13): parameter checks, emitted ports, and
the cocotb testbench ``tests/cocotb/tb_fifo_slave.py`` under Verilator, with
cocotbext-avalon's master on the bus and ``SimulatedFifoPeripheral`` as the
golden model."""
from __future__ import annotations

import re
from pathlib import Path

import pytest
from amaranth.back import verilog
from amaranth.sim import Simulator

from verif.cocotb_run import run_cocotb
from soc.fifo_slave import FifoSlave
from soc.hps_interface import decode_version
from sw_hps.fifo import (CONTROL, CORE_MAGIC, CTRL_FIFO_DATA, CTRL_FIFO_FULL, CTRL_GO,
                         CTRL_NO_GESTURE, DATA_MASK, DATO_X, DATO_Y, FIFO_DEPTH, ID, LONGITUD_X,
                         LONGITUD_Y, REGISTER_SPAN, RESERVED, VERSION)
from sw_hps.simulated import SimulatedFifoPeripheral

TB_DIR = Path(__file__).resolve().parent / "cocotb"
TOP = "fifo_slave"
PORTS = {"clk", "rst", "bus__address", "bus__read", "bus__write", "bus__writedata",
         "bus__readdata", "i_stream__valid", "i_stream__payload", "go", "gesture", "full"}


def emit(depth: int, data_bits: int = 18, **frame) -> str:
    dut = FifoSlave(data_bits=data_bits, depth=depth, **frame)
    return verilog.convert(dut, name=TOP, ports=dut.ports(), emit_src=False)


def port_names(text: str, top: str) -> set[str]:
    header = re.search(rf"module {top}\((.*?)\);", text, re.S).group(1)
    return {name.strip() for name in header.split(",")}


def test_emitted_ports():
    text = emit(8)
    assert port_names(text, TOP) == PORTS
    assert re.search(r"input \[37:0\] i_stream__payload;", text)
    assert re.search(r"input \[2:0\] bus__address;", text)


def test_small_depth_cocotb():
    """Register map, same-cycle access and push, 1500 random steps vs the model
    (built at a frame size other than the default, which Version reports)."""
    run_cocotb(emit(8, frame_width=96, frame_height=64), TOP, "tb_fifo_slave", TB_DIR,
               extra_env={"FIFO_DEPTH": 8, "DATA_BITS": 18, "FRAME_WIDTH": 96,
                          "FRAME_HEIGHT": 64},
               testcase=["register_map", "same_cycle", "random_against_model"])


async def bus_read(ctx, bus, offset):
    """One Avalon read under Amaranth's simulator (readdata is valid the cycle
    after the read)."""
    ctx.set(bus.address, offset // 4)
    ctx.set(bus.read, 1)
    await ctx.tick()
    ctx.set(bus.read, 0)
    return ctx.get(bus.readdata)


async def bus_write(ctx, bus, offset, value):
    """One Avalon write under Amaranth's simulator."""
    ctx.set(bus.address, offset // 4)
    ctx.set(bus.writedata, value)
    ctx.set(bus.write, 1)
    await ctx.tick()
    ctx.set(bus.write, 0)


def test_full_depth_amaranth_sim():
    """The board's depth (512) under Amaranth's simulator (no second Verilator
    build): Longitud reaches 512, pair 513 is dropped and sets FIFO-FULL, the
    512 pairs read back in order."""
    dut = FifoSlave(depth=FIFO_DEPTH)
    bus, beat = dut.bus, dut.i_stream
    values = [((n * 37) & DATA_MASK, (n * 91 + 5) & DATA_MASK) for n in range(FIFO_DEPTH + 1)]
    seen = {}

    async def testbench(ctx):
        async def read(offset):
            return await bus_read(ctx, bus, offset)

        await bus_write(ctx, bus, CONTROL, CTRL_GO)
        for n, (x, y) in enumerate(values):
            ctx.set(beat.payload.x, x)
            ctx.set(beat.payload.y, y)
            ctx.set(beat.payload.flag, 1)
            ctx.set(beat.valid, 1)
            await ctx.tick()
            if n == FIFO_DEPTH - 1:
                seen["full_before_513"] = ctx.get(dut.full)
        ctx.set(beat.valid, 0)
        seen["lengths"] = (await read(LONGITUD_X), await read(LONGITUD_Y))
        seen["control"] = await read(CONTROL)
        seen["pairs"] = [(await read(DATO_X), await read(DATO_Y)) for _ in range(FIFO_DEPTH)]
        seen["after"] = (await read(LONGITUD_X), await read(DATO_X), await read(CONTROL))

    sim = Simulator(dut)
    sim.add_clock(1e-8)
    sim.add_testbench(testbench)
    sim.run()
    assert seen["full_before_513"] == 0
    assert seen["lengths"] == (FIFO_DEPTH, FIFO_DEPTH)
    assert seen["control"] == CTRL_GO | CTRL_FIFO_DATA | CTRL_FIFO_FULL
    assert seen["pairs"] == values[:FIFO_DEPTH]
    assert seen["after"] == (0, 0, CTRL_GO | CTRL_FIFO_FULL)


def read_after_writes(dut, offsets):
    """Under Amaranth's simulator: every word of ``offsets`` read after reset,
    then each written with all ones (and Control with 0 again), then read again."""
    bus = dut.bus
    seen = {}

    async def testbench(ctx):
        seen["before"] = [await bus_read(ctx, bus, offset) for offset in offsets]
        for offset in offsets:
            await bus_write(ctx, bus, offset, 0xFFFFFFFF)
            if offset == CONTROL:
                await bus_write(ctx, bus, CONTROL, 0)
        seen["after"] = [await bus_read(ctx, bus, offset) for offset in offsets]

    sim = Simulator(dut)
    sim.add_clock(1e-8)
    sim.add_testbench(testbench)
    sim.run()
    return seen["before"], seen["after"]


@pytest.mark.parametrize("kwargs", [
    dict(),
    dict(depth=8, frame_width=32, frame_height=16),
    dict(depth=65536, frame_width=1024, frame_height=1024),
    dict(depth=2, frame_width=98, frame_height=61),      # sizes round up to 8 pixels
])
def test_id_and_version_read_the_model_values(kwargs):
    """ID and Version read bit for bit what SimulatedFifoPeripheral built with
    the same parameters reads, after reset and after writes of all ones to every
    word (they ignore them); the other words read as the model's too."""
    dut = FifoSlave(**kwargs)
    model = SimulatedFifoPeripheral(**kwargs)        # the same parameter names
    offsets = list(range(0, REGISTER_SPAN, 4))
    before, after = read_after_writes(dut, offsets)
    expected = [model.read32(offset) for offset in offsets]
    assert before == expected
    for offset in offsets:
        model.write32(offset, 0xFFFFFFFF)
        if offset == CONTROL:
            model.write32(CONTROL, 0)
    assert after == [model.read32(offset) for offset in offsets] == expected
    assert before[ID // 4] == CORE_MAGIC
    assert before[CONTROL // 4] == CTRL_NO_GESTURE and before[RESERVED // 4] == 0
    decoded = decode_version(before[VERSION // 4])
    assert decoded["fifo_depth"] == dut.depth and decoded["streaming"]
    assert decoded["frame_width"] == -(-kwargs.get("frame_width", 640) // 8) * 8
    assert decoded["frame_height"] == -(-kwargs.get("frame_height", 480) // 8) * 8


@pytest.mark.parametrize("kwargs, name", [
    (dict(data_bits=0), "data_bits"),
    (dict(data_bits=32), "data_bits"),
    (dict(data_bits=18.0), "data_bits"),
    (dict(data_bits=True), "data_bits"),
    (dict(depth=1), "depth"),
    (dict(depth=131072), "depth"),
    (dict(depth=500), "depth"),
    (dict(depth="512"), "depth"),
    (dict(frame_width=0), "frame_width"),
    (dict(frame_width=2041), "frame_width"),
    (dict(frame_height=640.0), "frame_height"),
    (dict(frame_height=None), "frame_height"),
])
def test_bad_parameters(kwargs, name):
    with pytest.raises(ValueError, match=rf"^{name} must be"):
        FifoSlave(**kwargs)


def test_parameter_limits_accepted():
    for data_bits, depth in ((1, 2), (31, 65536), (18, FIFO_DEPTH)):
        dut = FifoSlave(data_bits=data_bits, depth=depth)
        assert (dut.data_bits, dut.depth) == (data_bits, depth)
