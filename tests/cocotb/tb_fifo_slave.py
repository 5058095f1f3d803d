"""cocotb testbench of :class:`soc.fifo_slave.FifoSlave` (thesis §7.4.1,
Tables 12-13), driven through cocotbext-avalon's Avalon-MM master.

Run by ``tests/test_soc_fifo_slave.py`` (``verif.cocotb_run.run_cocotb``); the
environment gives the build's parameters: ``FIFO_DEPTH``, ``DATA_BITS``,
``FRAME_WIDTH`` and ``FRAME_HEIGHT`` (reported by Version) and the seed of the
randomized test ``TB_SEED``.

The golden model is :class:`sw_hps.simulated.SimulatedFifoPeripheral`; a bus
access and a push in the same clock cycle are applied to it as ``read32`` /
``write32`` first, then ``push_frame`` (the order the slave documents).
"""
from __future__ import annotations

import os
import random

import cocotb
from cocotb.clock import Clock
from cocotb.triggers import ClockCycles, ReadOnly, RisingEdge
from cocotbext.avalon import AvalonMMBus, AvalonMMMasterBFM

from soc.avalon import READ_LATENCY
from sw_hps.fifo import (CONTROL, CORE_MAGIC, CTRL_FIFO_CLR, CTRL_FIFO_DATA, CTRL_FIFO_FULL,
                         CTRL_GO, CTRL_NO_GESTURE, CTRL_STREAM, DATO_X, DATO_Y, ID, LONGITUD_X,
                         LONGITUD_Y, REGISTER_SPAN, RESERVED, VERSION, CoreIdentity)
from sw_hps.simulated import SimulatedFifoPeripheral

DEPTH = int(os.environ.get("FIFO_DEPTH", "8"))
DATA_BITS = int(os.environ.get("DATA_BITS", "18"))
FRAME = dict(frame_width=int(os.environ.get("FRAME_WIDTH", "640")),
             frame_height=int(os.environ.get("FRAME_HEIGHT", "480")))
SEED = int(os.environ.get("TB_SEED", "7413"))
DATA_MASK = (1 << DATA_BITS) - 1
#: Byte offsets the 3-bit word address reaches: the whole map, ID and Version
#: at 0x18 and 0x1C included.
ALL_OFFSETS = tuple(range(0, REGISTER_SPAN, 4))
#: Words that read constants: ID and Version.
CONSTANT_WORDS = {ID: CORE_MAGIC, VERSION: SimulatedFifoPeripheral(DEPTH, **FRAME).version}

#: Edges the master waits after the edge that took the read before sampling
#: readdata (the slave has no readdatavalid). Right after ``await RisingEdge``
#: cocotb sees the values from before that edge, so the slave's readdata,
#: registered at the accepting edge, is sampled one edge later: 1, the
#: slave's READ_LATENCY. With 0 every read returns the previous cycle's data
#: and register_map fails at its first read.
READ_RESPONSE_LATENCY = READ_LATENCY


class Harness:
    """Clock, reset, the Avalon-MM master on ``bus__*`` and a driver of ``i_stream``."""

    def __init__(self, dut):
        self.dut = dut
        # from_prefix looks up "<prefix>_<signal>"; Amaranth joins with "__".
        bus = AvalonMMBus.from_prefix(dut, "bus_")
        assert bus.waitrequest is None and bus.readdatavalid is None
        # No readdatavalid: the master samples readdata read_response_latency
        # edges after the edge that took the read (fixed latency, see the note).
        self.master = AvalonMMMasterBFM(bus, dut.clk, dut.rst,
                                        read_response_latency=READ_RESPONSE_LATENCY)

    async def start(self):
        dut = self.dut
        Clock(dut.clk, 10, unit="ns").start()
        self.master.start()
        dut.i_stream__valid.value = 0
        dut.i_stream__payload.value = 0
        dut.rst.value = 1
        await ClockCycles(dut.clk, 3)
        dut.rst.value = 0
        await RisingEdge(dut.clk)

    async def read(self, offset: int) -> int:
        return await self.master.read(offset // 4)

    async def write(self, offset: int, value: int) -> None:
        await self.master.write(offset // 4, value & 0xFFFFFFFF)

    async def push(self, x: int, y: int, flag: bool, present: bool = True) -> None:
        """One i_stream beat (one video frame), taken at the second edge: the
        same edge at which a bus access started together with it is taken."""
        dut = self.dut
        await RisingEdge(dut.clk)
        dut.i_stream__payload.value = (x & DATA_MASK) | ((y & DATA_MASK) << DATA_BITS) \
            | (int(bool(flag)) << (2 * DATA_BITS)) | (int(bool(present)) << (2 * DATA_BITS + 1))
        dut.i_stream__valid.value = 1
        await RisingEdge(dut.clk)
        dut.i_stream__valid.value = 0

    async def together(self, bus_access, frame):
        """A bus access (coroutine) and a push of ``frame`` in the same cycle."""
        task = cocotb.start_soon(self.push(*frame))
        result = await bus_access
        await task
        return result

    async def outputs(self) -> tuple[int, int, int]:
        """go, gesture, full once the last edge's updates have settled."""
        dut = self.dut
        await ReadOnly()
        return int(dut.go.value), int(dut.gesture.value), int(dut.full.value)



def model_outputs(model: SimulatedFifoPeripheral) -> tuple[int, int, int]:
    return int(model.go), int(model.go and model.flag), int(model.full)


@cocotb.test(timeout_time=1, timeout_unit="ms")
async def register_map(dut):
    """Every register, reserved words, RO bits, FIFO-CLR, FIFO-FULL, gesture polarity."""
    h = Harness(dut)
    await h.start()
    assert DEPTH <= 64, "this test fills the FIFO; build it with a small depth"

    # After reset: GO 0, gesture bit 1 (no gesture), ID and Version their
    # constants, everything else 0.
    assert await h.read(CONTROL) == CTRL_NO_GESTURE
    for offset in ALL_OFFSETS:
        if offset != CONTROL:
            assert await h.read(offset) == CONSTANT_WORDS.get(offset, 0), \
                f"offset {offset:#x} after reset"
    assert await h.outputs() == (0, 0, 0)
    # The driver's reading of them: this build's parameters.
    identity = CoreIdentity.decode(await h.read(ID), await h.read(VERSION))
    assert identity.supported and (identity.fifo_depth, identity.frame_width,
                                   identity.frame_height) == \
        (DEPTH, -(-FRAME["frame_width"] // 8) * 8, -(-FRAME["frame_height"] // 8) * 8)

    # GO and STREAM are R/W; FIFO-CLR reads 0; RO bits and bits 31:6 ignore writes.
    await h.write(CONTROL, CTRL_GO)
    assert await h.read(CONTROL) == CTRL_GO | CTRL_NO_GESTURE
    assert await h.outputs() == (1, 0, 0)
    await h.write(CONTROL, 0xFFFFFFFF)
    assert await h.read(CONTROL) == CTRL_GO | CTRL_NO_GESTURE | CTRL_STREAM
    await h.write(CONTROL, 0xFFFFFFFF & ~CTRL_GO)
    assert await h.read(CONTROL) == CTRL_NO_GESTURE | CTRL_STREAM
    assert await h.outputs() == (0, 0, 0)
    await h.write(CONTROL, 0)

    # GO 0: a flagged frame is not pushed and the gesture bit stays 1.
    await h.push(0x100, 0x200, True)
    assert await h.read(LONGITUD_X) == 0 and await h.read(LONGITUD_Y) == 0
    assert await h.read(CONTROL) == CTRL_NO_GESTURE
    # Setting GO during a gesture (latest flag 1) shows it at once: bit 2 reads 0.
    await h.write(CONTROL, CTRL_GO)
    assert await h.read(CONTROL) == CTRL_GO
    assert await h.outputs() == (1, 1, 0)
    await h.push(0, 0, False)
    assert await h.read(CONTROL) == CTRL_GO | CTRL_NO_GESTURE
    assert await h.read(LONGITUD_X) == 0

    # A push: 18-bit data in bits 17:0, bits 31:18 read 0.
    await h.push(DATA_MASK, 0x12345 & DATA_MASK, True)
    assert await h.read(LONGITUD_X) == 1 and await h.read(LONGITUD_Y) == 1
    assert await h.read(CONTROL) == CTRL_GO | CTRL_FIFO_DATA
    assert await h.outputs() == (1, 1, 0)
    # Writes to Dato_*, Longitud_*, reserved, ID and Version are ignored.
    for offset in ALL_OFFSETS:
        if offset != CONTROL:
            await h.write(offset, 0xFFFFFFFF)
    assert await h.read(RESERVED) == 0
    for offset, value in CONSTANT_WORDS.items():
        assert await h.read(offset) == value, f"offset {offset:#x} after a write"
    assert await h.read(LONGITUD_X) == 1 and await h.read(LONGITUD_Y) == 1
    # Pops are independent; an empty FIFO reads 0 and pops nothing.
    assert await h.read(DATO_X) == DATA_MASK
    assert await h.read(LONGITUD_X) == 0 and await h.read(LONGITUD_Y) == 1
    assert await h.read(CONTROL) == CTRL_GO  # FIFO data 0: X is empty
    assert await h.read(DATO_X) == 0
    assert await h.read(LONGITUD_Y) == 1
    assert await h.read(DATO_Y) == 0x12345 & DATA_MASK
    assert await h.read(DATO_Y) == 0
    assert await h.read(LONGITUD_X) == 0 and await h.read(LONGITUD_Y) == 0

    # Fill to depth: FIFO-FULL stays 0; the next pair is dropped from both.
    for n in range(DEPTH):
        await h.push(n + 1, 1000 + n, True)
    assert await h.read(LONGITUD_X) == DEPTH and await h.read(LONGITUD_Y) == DEPTH
    assert not await h.read(CONTROL) & CTRL_FIFO_FULL
    await h.push(77, 77, True)
    assert await h.read(CONTROL) == CTRL_GO | CTRL_FIFO_DATA | CTRL_FIFO_FULL
    assert await h.outputs() == (1, 1, 1)
    assert await h.read(LONGITUD_X) == DEPTH and await h.read(LONGITUD_Y) == DEPTH
    # X has room but Y is full: still dropped from both (they stay aligned).
    assert await h.read(DATO_X) == 1
    await h.push(78, 78, True)
    assert await h.read(LONGITUD_X) == DEPTH - 1 and await h.read(LONGITUD_Y) == DEPTH
    assert await h.read(DATO_Y) == 1000
    xs = [await h.read(DATO_X) for _ in range(DEPTH - 1)]
    ys = [await h.read(DATO_Y) for _ in range(DEPTH - 1)]
    assert xs == [n + 1 for n in range(1, DEPTH)]
    assert ys == [1000 + n for n in range(1, DEPTH)]
    # The last frame was flagged: gesture in progress; an idle frame ends it.
    assert await h.read(CONTROL) == CTRL_GO | CTRL_FIFO_FULL
    await h.push(0, 0, False)
    # FIFO-FULL is sticky while the FIFOs drain and GO toggles ...
    await h.write(CONTROL, 0)
    await h.write(CONTROL, CTRL_GO)
    assert await h.read(CONTROL) == CTRL_GO | CTRL_NO_GESTURE | CTRL_FIFO_FULL
    # ... until FIFO-CLR, which self-clears (reads 0) and leaves GO as written.
    await h.write(CONTROL, CTRL_FIFO_CLR | CTRL_GO)
    assert await h.read(CONTROL) == CTRL_GO | CTRL_NO_GESTURE
    assert await h.outputs() == (1, 0, 0)

    # FIFO-CLR empties both FIFOs.
    for n in range(3):
        await h.push(10 + n, 20 + n, True)
    await h.read(DATO_Y)
    assert await h.read(LONGITUD_X) == 3 and await h.read(LONGITUD_Y) == 2
    await h.write(CONTROL, CTRL_FIFO_CLR)
    assert await h.read(CONTROL) == CTRL_NO_GESTURE  # GO cleared by the same write
    assert await h.read(LONGITUD_X) == 0 and await h.read(LONGITUD_Y) == 0
    assert await h.read(DATO_X) == 0 and await h.read(DATO_Y) == 0
    # The FIFOs work after a clear (pointers restart consistently).
    await h.write(CONTROL, CTRL_GO)
    await h.push(5, 6, True)
    assert (await h.read(DATO_X), await h.read(DATO_Y)) == (5, 6)

    # Streaming mode: every frame pushed, FLAG above Dato_X's data, PRESENT
    # above Dato_Y's; the thesis mode stores neither bit.
    await h.write(CONTROL, CTRL_GO | CTRL_STREAM)
    for frame in ((7, 8, False, False), (9, 10, False, True), (11, 12, True, True),
                  (13, 14, True, False)):
        await h.push(*frame)
    await h.write(CONTROL, CTRL_GO)
    await h.push(15, 16, True, True)
    await h.push(17, 18, False, True)
    words = [(await h.read(DATO_X), await h.read(DATO_Y)) for _ in range(5)]
    flag, present = 1 << DATA_BITS, 1 << DATA_BITS
    assert words == [(7, 8), (9, 10 | present), (11 | flag, 12 | present), (13 | flag, 14),
                     (15, 16)]
    assert await h.read(LONGITUD_X) == 0


@cocotb.test(timeout_time=1, timeout_unit="ms")
async def same_cycle(dut):
    """A bus access and a push in one cycle: both take effect, the access first."""
    h = Harness(dut)
    await h.start()
    model = SimulatedFifoPeripheral(depth=DEPTH, **FRAME)

    async def check(bus_access, model_access, frame):
        got = await h.together(bus_access, frame)
        expected = model_access()
        model.push_frame(*frame)
        if got is not None:
            assert got == expected, f"read returned {got:#x}, model {expected:#x}"
        for offset in (CONTROL, LONGITUD_X, LONGITUD_Y):
            assert await h.read(offset) == model.read32(offset), f"offset {offset:#x}"
        assert await h.outputs() == model_outputs(model)

    # Writing GO gates the push of the same cycle (set: pushed; clear: not).
    await check(h.write(CONTROL, CTRL_GO), lambda: model.write32(CONTROL, CTRL_GO), (1, 2, 1))
    assert model.read32(LONGITUD_X) == 1
    await check(h.write(CONTROL, 0), lambda: model.write32(CONTROL, 0), (3, 4, 1))
    assert model.read32(LONGITUD_X) == 1
    await h.write(CONTROL, CTRL_GO)
    model.write32(CONTROL, CTRL_GO)
    # FIFO-CLR then the push: one entry left.
    await check(h.write(CONTROL, CTRL_GO | CTRL_FIFO_CLR),
                lambda: model.write32(CONTROL, CTRL_GO | CTRL_FIFO_CLR), (5, 6, 1))
    assert model.read32(LONGITUD_Y) == 1
    # Popping the last entry while a pair arrives returns the old one.
    await check(h.read(DATO_X), lambda: model.read32(DATO_X), (7, 8, 1))
    assert await h.read(DATO_X) == model.read32(DATO_X) == 7
    # An empty FIFO reads 0 even if a pair is pushed in that cycle.
    await check(h.read(DATO_X), lambda: model.read32(DATO_X), (9, 10, 1))
    assert model.read32(LONGITUD_X) == 1
    # Fill; a pop of the full FIFO makes room for the pair of the same cycle.
    while len(model.fifo_y) < DEPTH:
        frame = (len(model.fifo_y), 100 + len(model.fifo_y), 1)
        await h.push(*frame)
        model.push_frame(*frame)
    await check(h.read(DATO_Y), lambda: model.read32(DATO_Y), (11, 12, 1))
    assert not model.full and len(model.fifo_y) == DEPTH
    await check(h.read(CONTROL), lambda: model.read32(CONTROL), (13, 14, 1))
    assert model.full
    # Control read in the push cycle shows the state before the push.
    await check(h.read(CONTROL), lambda: model.read32(CONTROL), (0, 0, 0))
    await check(h.read(CONTROL), lambda: model.read32(CONTROL), (0, 0, 1))
    # Drain and compare every value.
    while model.fifo_x or model.fifo_y:
        for offset in (DATO_X, DATO_Y):
            assert await h.read(offset) == model.read32(offset)


@cocotb.test(timeout_time=1, timeout_unit="ms")
async def random_against_model(dut):
    """Random pushes, reads and writes, read for read against the software model."""
    h = Harness(dut)
    await h.start()
    rng = random.Random(SEED)
    dut._log.info("seed %d, depth %d", SEED, DEPTH)
    model = SimulatedFifoPeripheral(depth=DEPTH, **FRAME)
    reads = pushes = drops = together = 0

    def random_frame():
        # Flag mostly set while GO is 1 so the FIFOs fill up and overflow.
        # (random Control words set STREAM half the time: every frame pushed)
        return (rng.getrandbits(DATA_BITS), rng.getrandbits(DATA_BITS), rng.random() < 0.7,
                rng.random() < 0.8)

    def random_control():
        value = rng.getrandbits(32)
        value = (value & ~CTRL_FIFO_CLR) | (CTRL_FIFO_CLR if rng.random() < 0.15 else 0)
        return (value & ~CTRL_GO) | (CTRL_GO if rng.random() < 0.85 else 0)

    for step in range(1500):
        kind = rng.random()
        frame = random_frame() if rng.random() < 0.2 else None
        if kind < 0.3:
            frame = random_frame()
            await h.push(*frame)
            access, expected = None, None
        elif kind < 0.8:
            # Pops dominate the reads so the FIFOs drain as often as they fill.
            offset = rng.choice((DATO_X, DATO_Y, DATO_X, DATO_Y) + ALL_OFFSETS)
            access = h.read(offset)
            expected = lambda offset=offset: model.read32(offset)  # noqa: E731
        else:
            offset = CONTROL if rng.random() < 0.7 else rng.choice(ALL_OFFSETS)
            value = random_control() if offset == CONTROL else rng.getrandbits(32)
            access = h.write(offset, value)
            expected = lambda offset=offset, value=value: model.write32(offset, value)  # noqa: E731
        if access is not None:
            if frame is not None:
                got = await h.together(access, frame)
                together += 1
            else:
                got = await access
            want = expected()
            if got is not None:
                reads += 1
                assert got == want, (f"step {step}: read {offset:#x} = {got:#x}, "
                                     f"model {want:#x}")
        if frame is not None:
            before = model.dropped
            model.push_frame(*frame)
            pushes += 1
            drops += model.dropped - before
        assert await h.outputs() == model_outputs(model), f"step {step}: go/gesture/full"
    # Final state, register by register.
    for offset in ALL_OFFSETS:
        if offset not in (DATO_X, DATO_Y):
            assert await h.read(offset) == model.read32(offset)
    dut._log.info("%d reads compared, %d frames (%d with a bus access in the same cycle), "
                  "%d pairs dropped, %d FIFO-CLR", reads, pushes, together, drops, model.clears)
    assert drops > 0 and model.clears > 0 and together > 50, "sequence too tame"

