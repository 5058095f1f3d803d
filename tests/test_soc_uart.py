# amaranth: UnusedElaboratable=no
"""UartSlave (thesis §8.5.1): parameter checks, emitted ports, and the cocotb
testbench ``tests/cocotb/tb_uart.py`` under Verilator at the board's 100 MHz and
115200 baud, with cocotbext-avalon's master on the bus and cocotbext-uart's
UartSink / UartSource on the serial pins."""
from __future__ import annotations

import re
from pathlib import Path

import pytest
from amaranth.back import verilog

from verif.cocotb_run import run_cocotb
from soc.uart import UartSlave

TB_DIR = Path(__file__).resolve().parent / "cocotb"
TOP = "uart_slave"
PORTS = {"clk", "rst", "bus__address", "bus__read", "bus__write", "bus__writedata",
         "bus__readdata", "tx", "rx", "tx_busy", "rx_errors", "rx_overruns"}


def emit(dut: UartSlave) -> str:
    return verilog.convert(dut, name=TOP, emit_src=False)


def test_emitted_ports():
    text = emit(UartSlave())
    header = re.search(rf"module {TOP}\((.*?)\);", text, re.S).group(1)
    assert {name.strip() for name in header.split(",")} == PORTS
    assert re.search(r"input \[1:0\] bus__address;", text)


def test_board_divisor():
    dut = UartSlave(100e6, 115200)
    assert dut.divisor == 868
    assert abs(dut.baud_error) < 1e-4


def test_cocotb_100mhz_115200():
    """Telegrams via UartLink, bit period on tx, holding register, RX, framing errors."""
    dut = UartSlave(clk_freq=100e6, baudrate=115200, rx_depth=16)
    run_cocotb(emit(dut), TOP, "tb_uart", TB_DIR,
               extra_env={"CLK_FREQ": dut.clk_freq, "BAUD": dut.baudrate,
                          "RX_DEPTH": dut.rx_depth, "DIVISOR": dut.divisor})


@pytest.mark.parametrize("kwargs, name", [
    (dict(clk_freq=0), "clk_freq"),
    (dict(clk_freq=-50e6), "clk_freq"),
    (dict(clk_freq=float("nan")), "clk_freq"),
    (dict(clk_freq="100e6"), "clk_freq"),
    (dict(baudrate=0), "baudrate"),
    (dict(baudrate=True), "baudrate"),
    (dict(baudrate=float("inf")), "baudrate"),
    (dict(clk_freq=1e6, baudrate=115200), "clk_freq / baudrate"),   # 9 cycles per bit
    (dict(clk_freq=100e6, baudrate=1), "clk_freq / baudrate"),      # 1e8 cycles per bit
    (dict(clk_freq=1.9e6, baudrate=115200), "baudrate"),           # 16 cycles: +3.1 %
    (dict(rx_depth=0), "rx_depth"),
    (dict(rx_depth=257), "rx_depth"),
])
def test_bad_parameters(kwargs, name):
    with pytest.raises(ValueError, match="^" + re.escape(name)):
        UartSlave(**kwargs)


def test_parameter_limits_accepted():
    assert UartSlave(clk_freq=16e6, baudrate=1e6, rx_depth=1).divisor == 16
    assert UartSlave(clk_freq=50e6, baudrate=9600, rx_depth=256).divisor == 5208


@pytest.mark.parametrize("rate_error", [-0.03, 0.0, 0.03])
def test_rx_tolerance_at_min_divisor_amaranth_sim(rate_error):
    """At the smallest divisor (16 cycles per bit) the receiver decodes a sender
    whose bit rate is off by +-3 % (Amaranth simulator, no Verilator build), and
    its own transmitter looped back to rx."""
    import random

    from amaranth.sim import Simulator

    from soc.hps_interface import UART_RXDATA, UART_STATUS, UART_STATUS_RX_VALID, UART_TXDATA

    dut = UartSlave(clk_freq=16e6, baudrate=1e6, rx_depth=64)
    rng = random.Random(5)
    sent = bytes(rng.getrandbits(8) for _ in range(24))
    looped = bytes(rng.getrandbits(8) for _ in range(6))
    bit = dut.divisor * (1 + rate_error)  # sender's bit length in clock cycles
    levels = []
    for byte in sent:  # 8N1 frames back to back, one cycle per level
        frame = [0] + [(byte >> k) & 1 for k in range(8)] + [1]
        start = len(levels)
        while len(levels) - start < 10 * bit:
            levels.append(frame[int((len(levels) - start) / bit)])
    received = {}

    async def bus_read(ctx, offset):
        ctx.set(dut.bus.address, offset // 4)
        ctx.set(dut.bus.read, 1)
        await ctx.tick()
        ctx.set(dut.bus.read, 0)
        return ctx.get(dut.bus.readdata)

    async def drain(ctx):
        out = bytearray()
        while await bus_read(ctx, UART_STATUS) & UART_STATUS_RX_VALID:
            out.append(await bus_read(ctx, UART_RXDATA))
        return bytes(out)

    async def testbench(ctx):
        for level in levels + [1] * 40:
            ctx.set(dut.rx, level)
            await ctx.tick()
        received["rx"] = await drain(ctx)
        received["errors"] = ctx.get(dut.rx_errors)
        for byte in looped:  # loopback: tx -> rx every cycle
            ctx.set(dut.bus.address, UART_TXDATA // 4)
            ctx.set(dut.bus.writedata, byte)
            ctx.set(dut.bus.write, 1)
            await ctx.tick()
            ctx.set(dut.bus.write, 0)
            for _ in range(10 * dut.divisor + 2):
                ctx.set(dut.rx, ctx.get(dut.tx))
                await ctx.tick()
        for _ in range(40):
            ctx.set(dut.rx, ctx.get(dut.tx))
            await ctx.tick()
        received["loop"] = await drain(ctx)

    sim = Simulator(dut)
    sim.add_clock(1 / 16e6)
    sim.add_testbench(testbench)
    sim.run()
    assert received["rx"] == sent and received["errors"] == 0
    assert received["loop"] == looped
