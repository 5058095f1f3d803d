"""cocotb testbench of :class:`soc.uart.UartSlave` (thesis §8.5.1: RN-42 to the
LEGO NXT, 8N1 at 115200 baud).

Run by ``tests/test_soc_uart.py``. The bus is driven by cocotbext-avalon's
Avalon-MM master; the serial side by cocotbext-uart's ``UartSink`` (on ``tx``)
and ``UartSource`` (on ``rx``), an independent UART model. The telegrams are
sent by the board's own driver, :class:`sw_hps.robot.UartLink`, whose blocking
``read32`` / ``write32`` calls reach the master through ``cocotb.task.bridge``
and ``resume``. Environment: ``CLK_FREQ``, ``BAUD``, ``RX_DEPTH`` (the build's
parameters) and ``DIVISOR``.
"""
from __future__ import annotations

import os

import cocotb
from cocotb.clock import Clock
from cocotb.simtime import get_sim_time
from cocotb.task import bridge, resume
from cocotb.triggers import ClockCycles, Edge, RisingEdge, Timer
from cocotbext.avalon import AvalonMMBus, AvalonMMMasterBFM
from cocotbext.uart import UartSink, UartSource

from soc.avalon import READ_LATENCY
from soc.hps_interface import (GESTURE_NAMES, UART_RXDATA, UART_STATUS, UART_STATUS_RX_VALID,
                               UART_STATUS_TX_READY, UART_TXDATA)
from sw_hps.robot import UartLink
from sw_hps.telegram import telegram

CLK_FREQ = float(os.environ.get("CLK_FREQ", "100e6"))
BAUD = float(os.environ.get("BAUD", "115200"))
RX_DEPTH = int(os.environ.get("RX_DEPTH", "16"))
DIVISOR = int(os.environ.get("DIVISOR", str(round(CLK_FREQ / BAUD))))
CLOCK_PS = round(1e12 / CLK_FREQ)
BIT_NS = 1e9 / BAUD
#: Largest allowed deviation of the measured bit period from 1 / BAUD.
BIT_TOLERANCE = 0.02


#: Time an HPS register access takes besides the bus cycles: an uncached load
#: over the lightweight bridge plus the Python driver on the Cortex-A9 take a
#: microsecond or more. It also keeps UartLink's polling loop (hundreds of
#: thousands of back-to-back reads at 100 MHz) affordable in simulation;
#: tx_holding_register polls at full bus speed.
HPS_ACCESS_NS = 1000


class HpsBus:
    """:class:`sw_hps.bus.Bus` (byte offsets) on the Avalon master, for driver
    code running in a ``bridge``-d thread; each access first waits
    :data:`HPS_ACCESS_NS`."""

    def __init__(self, master: AvalonMMMasterBFM):
        self.master = master
        self._read = resume(self._read_async)
        self._write = resume(self._write_async)
        self.reads = 0

    async def _read_async(self, address: int) -> int:
        await Timer(HPS_ACCESS_NS, "ns")
        return await self.master.read(address)

    async def _write_async(self, address: int, value: int) -> None:
        await Timer(HPS_ACCESS_NS, "ns")
        await self.master.write(address, value)

    def read32(self, offset: int) -> int:
        self.reads += 1
        return self._read(offset // 4)

    def write32(self, offset: int, value: int) -> None:
        self._write(offset // 4, value)

    def close(self) -> None:
        pass


async def start(dut) -> AvalonMMMasterBFM:
    # No readdatavalid: readdata is sampled READ_LATENCY edges after the edge
    # that took the read (cocotb sees pre-edge values right after RisingEdge).
    master = AvalonMMMasterBFM(AvalonMMBus.from_prefix(dut, "bus_"), dut.clk, dut.rst,
                               read_response_latency=READ_LATENCY)
    Clock(dut.clk, CLOCK_PS, unit="ps").start()
    master.start()
    dut.rx.value = 1
    dut.rst.value = 1
    await ClockCycles(dut.clk, 3)
    dut.rst.value = 0
    await RisingEdge(dut.clk)
    return master


async def wait_bytes(sink: UartSink, count: int, frames_timeout: int = 4) -> bytes:
    """Wait until ``sink`` decoded ``count`` bytes (at most ``count +
    frames_timeout`` frame times), return them."""
    for _ in range(10 * (count + frames_timeout)):
        if sink.count() >= count:
            break
        await Timer(round(BIT_NS), "ns")
    return bytes(sink.read_nowait())


class EdgeLog:
    """Times (ns) of every change of a signal, from the waveform."""

    def __init__(self, signal):
        self.signal = signal
        self.times: list[float] = []
        self.values: list[int] = []
        self.task = cocotb.start_soon(self._run())

    async def _run(self):
        while True:
            await Edge(self.signal)
            self.times.append(get_sim_time("ns"))
            self.values.append(int(self.signal.value))


async def status(master) -> int:
    return await master.read(UART_STATUS // 4)


@cocotb.test(timeout_time=20, timeout_unit="ms")
async def telegrams_through_uartlink(dut):
    """Every NXT telegram, written by UartLink.send's poll-then-write loop, arrives intact."""
    master = await start(dut)
    sink = UartSink(dut.tx, baud=BAUD)
    bus = HpsBus(master)
    # Each poll takes >= HPS_ACCESS_NS: 1000 polls outlast a byte (87 us) tenfold,
    # and a stuck TX ready fails in 1 ms of simulated time.
    link = UartLink(bus, offset=0, spin_limit=1000)
    expected = b""
    for gesture in GESTURE_NAMES:
        message = telegram(gesture)
        assert await bridge(link.send)(message), f"UartLink.send failed for {gesture}"
        expected += message
    got = await wait_bytes(sink, len(expected))
    assert got == expected, f"sent {expected.hex(' ')}, UartSink decoded {got.hex(' ')}"
    dut._log.info("%d bytes sent through UartLink, %d STATUS/TX reads", len(expected),
                  bus.reads)
    assert int(dut.tx_busy.value) == 0 and int(dut.tx.value) == 1


@cocotb.test(timeout_time=10, timeout_unit="ms")
async def bit_period(dut):
    """Bit period measured on tx (0x55 0x55: an edge every bit) within 2 % of 1/BAUD,
    and a back-to-back byte starts right after the stop bit."""
    master = await start(dut)
    log = EdgeLog(dut.tx)
    sink = UartSink(dut.tx, baud=BAUD)
    for byte in (0x55, 0x55):
        await master.wait_set(UART_STATUS // 4, UART_STATUS_TX_READY)
        await master.write(UART_TXDATA // 4, byte)
    assert await wait_bytes(sink, 2) == b"\x55\x55"
    log.task.cancel()
    # 0x55 framed LSB first is 0 1 0 1 0 1 0 1 0 1 (start, data, stop): the
    # line toggles at every bit boundary, 10 edges per byte.
    times, values = log.times, log.values
    assert len(times) == 20 and values[0] == 0 and values[-1] == 1, values
    intervals = [b - a for a, b in zip(times, times[1:])]
    period = (times[-1] - times[0]) / (len(times) - 1)
    worst = max(abs(i - BIT_NS) / BIT_NS for i in intervals)
    dut._log.info("measured bit period %.3f ns (1/BAUD = %.3f ns, %+.4f %%), worst single "
                  "bit %.4f %%, divisor %d", period, BIT_NS, 100 * (period / BIT_NS - 1),
                  100 * worst, DIVISOR)
    assert abs(period - BIT_NS) / BIT_NS < BIT_TOLERANCE
    # Every bit, including the first byte's stop bit (interval 9, from its rising
    # edge to the second start bit), lasts one period: no idle gap between bytes.
    assert worst < BIT_TOLERANCE, intervals


@cocotb.test(timeout_time=10, timeout_unit="ms")
async def tx_holding_register(dut):
    """TX ready rises once the byte moved to the shifter; a write while TX ready is 0
    is ignored."""
    master = await start(dut)
    sink = UartSink(dut.tx, baud=BAUD)
    assert await status(master) == UART_STATUS_TX_READY
    assert int(dut.tx_busy.value) == 0
    await master.write(UART_TXDATA // 4, 0x1A5)  # bits 31:8 are not sent
    assert await status(master) == UART_STATUS_TX_READY  # already in the shifter
    assert int(dut.tx_busy.value) == 1
    await master.write(UART_TXDATA // 4, 0x3C)
    assert await status(master) == 0  # held behind the first byte
    await master.write(UART_TXDATA // 4, 0x99)  # dropped: TX ready is 0
    assert await wait_bytes(sink, 3) == b"\xa5\x3c"
    assert await status(master) == UART_STATUS_TX_READY


@cocotb.test(timeout_time=10, timeout_unit="ms")
async def receive(dut):
    """Bytes from UartSource appear in RXDATA in order with RX valid; an empty
    RXDATA reads 0; a full FIFO drops the newest bytes (rx_overruns)."""
    master = await start(dut)
    source = UartSource(dut.rx, baud=BAUD)
    message = b"CMD\r\n"
    await source.write(message)
    await source.wait()
    await ClockCycles(dut.clk, 4 * DIVISOR)  # the stop bit's second half
    assert await status(master) == UART_STATUS_TX_READY | UART_STATUS_RX_VALID
    got = bytearray()
    while await status(master) & UART_STATUS_RX_VALID:
        got.append(await master.read(UART_RXDATA // 4))
    assert bytes(got) == message
    assert await master.read(UART_RXDATA // 4) == 0
    assert await status(master) == UART_STATUS_TX_READY

    # Overrun: RX_DEPTH + 2 bytes without reading.
    data = bytes((37 * n + 11) & 0xFF for n in range(RX_DEPTH + 2))
    await source.write(data)
    await source.wait()
    await ClockCycles(dut.clk, 4 * DIVISOR)
    assert int(dut.rx_overruns.value) == 2 and int(dut.rx_errors.value) == 0
    got = bytearray()
    while await status(master) & UART_STATUS_RX_VALID:
        got.append(await master.read(UART_RXDATA // 4))
    assert bytes(got) == data[:RX_DEPTH]


async def drive_frame(dut, byte: int, stop: int, low_after: float = 0.0):
    """Bit-bang one 8N1 frame on rx with the given stop-bit level, then keep the
    line low ``low_after`` bit times (a break) before releasing it."""
    for level in [0] + [(byte >> k) & 1 for k in range(8)] + [stop]:
        dut.rx.value = level
        await Timer(round(BIT_NS), "ns")
    if low_after:
        dut.rx.value = 0
        await Timer(round(BIT_NS * low_after), "ns")
    dut.rx.value = 1
    await Timer(round(BIT_NS), "ns")


@cocotb.test(timeout_time=10, timeout_unit="ms")
async def framing_error_and_glitch(dut):
    """A frame whose stop bit is 0 is dropped and counted; a low pulse shorter than
    half a bit is no start bit; the receiver works normally afterwards."""
    master = await start(dut)
    await drive_frame(dut, 0xA5, stop=0, low_after=2.5)  # framing error + break
    assert int(dut.rx_errors.value) == 1
    assert await status(master) == UART_STATUS_TX_READY
    await drive_frame(dut, 0x00, stop=0)  # all zeros, stop 0: another error
    assert int(dut.rx_errors.value) == 2
    dut.rx.value = 0  # glitch: a third of a bit
    await Timer(round(BIT_NS / 3), "ns")
    dut.rx.value = 1
    await Timer(round(2 * BIT_NS), "ns")
    assert await status(master) == UART_STATUS_TX_READY
    source = UartSource(dut.rx, baud=BAUD)
    await source.write(b"\x3c\xff")
    await source.wait()
    await ClockCycles(dut.clk, 4 * DIVISOR)
    assert await master.read(UART_RXDATA // 4) == 0x3C
    assert await master.read(UART_RXDATA // 4) == 0xFF
    assert await status(master) == UART_STATUS_TX_READY
    assert int(dut.rx_errors.value) == 2 and int(dut.rx_overruns.value) == 0
