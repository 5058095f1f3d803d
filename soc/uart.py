"""8N1 UART as an Avalon-MM slave on the lightweight HPS-to-FPGA bridge, for the
RN-42 Bluetooth module that links the board to the LEGO NXT robot at 115200
baud (thesis §8.5.1).

The register map is :data:`soc.hps_interface.UART_REGISTERS` (driver:
:class:`sw_hps.robot.UartLink`; software model:
:class:`sw_hps.simulated.SimulatedUart`).
"""
from __future__ import annotations

import math
import numbers

from amaranth.hdl import Cat, Const, Module, Mux, Signal
from amaranth.lib import wiring
from amaranth.lib.cdc import FFSynchronizer
from amaranth.lib.fifo import SyncFIFOBuffered
from amaranth.lib.wiring import In, Out

from sim.model.validation import check_int
from .hps_interface import (UART_REGISTERS, UART_RXDATA, UART_STATUS, UART_STATUS_RX_VALID,
                            UART_STATUS_TX_READY, UART_TXDATA)

from .avalon import DATA_WIDTH, AvalonSlaveSignature

__all__ = ["UartSlave", "ADDRESS_WIDTH", "MIN_DIVISOR", "MAX_DIVISOR", "MAX_BAUD_ERROR",
           "RX_DEPTH_RANGE", "COUNTER_BITS"]

#: Word-address bits: TXDATA, STATUS, RXDATA (word 3 reads 0).
ADDRESS_WIDTH = UART_REGISTERS.address_width
#: Clock cycles per bit at least: the receiver's start-bit check and mid-bit
#: sampling are off by up to 3 cycles (synchroniser, edge detection), which
#: must stay well inside half a bit.
MIN_DIVISOR = 16
MAX_DIVISOR = 1 << 24
#: Largest relative difference between the achieved and the requested baud
#: rate (the far end's receiver tolerates a few per cent over a frame).
MAX_BAUD_ERROR = 0.02
RX_DEPTH_RANGE = (1, 256)
#: Width of the saturating error counters.
COUNTER_BITS = 8

_FRAME_BITS = 10  # start, 8 data, stop


class UartSlave(wiring.Component):
    """8N1 UART with the register map :data:`soc.hps_interface.UART_REGISTERS` (thesis §8.5.1:
    RN-42 Bluetooth module to the LEGO NXT, 115200 baud).

    Parameters
    ----------
    clk_freq : float > 0
        Clock of the slave in Hz (the lightweight bridge's clock domain).
    baudrate : float > 0
        Bits per second. The bit period is ``divisor = round(clk_freq /
        baudrate)`` cycles; ``divisor`` must be in [16, 2**24] and the achieved
        rate within 2 % of ``baudrate`` (100 MHz / 115200: 868 cycles, +0.006 %).
    rx_depth : int in [1, 256]
        Bytes the receive FIFO holds.

    Ports
    -----
    bus : ``In(AvalonSlaveSignature(2))``
        Word 0 TXDATA (W), 1 STATUS (R), 2 RXDATA (R, pops), 3 reads 0. Read
        latency 1, no wait states; a bus access sees the state at the start of
        its cycle.
    tx : Out(1)
        Serial output, idle high, driven by a flip-flop.
    rx : In(1)
        Serial input, asynchronous (two-flop synchroniser), idle high.
    tx_busy : Out(1)
        A byte is held or being shifted out.
    rx_errors : Out(8)
        Framing errors (stop bit sampled 0) since reset, saturating at 255.
    rx_overruns : Out(8)
        Received bytes dropped because the RX FIFO was full, saturating at 255.

    Notes
    -----
    Transmitter: a holding register (TX ready = empty) in front of a 10-bit
    shift register. The holding register moves to the shifter when the shifter
    is idle or in the last cycle of a stop bit, so TX ready rises again about
    one bit time into a byte and back-to-back bytes leave with no idle time.
    A TXDATA write while TX ready is 0 is ignored (the map's rule).

    Receiver: a falling edge of the synchronised line starts a frame; the start
    bit is checked half a bit later (a shorter low pulse is a glitch, ignored),
    then each data bit and the stop bit are sampled a whole bit apart, i.e. in
    the middle of each bit. A byte whose stop bit is 0 is a framing error: it is
    dropped, counted in ``rx_errors``, and the receiver waits for the line to go
    high before it looks for the next start bit. A good byte goes to the RX
    FIFO; if the FIFO is full the new byte is dropped (the older ones are kept)
    and counted in ``rx_overruns``. RXDATA pops the oldest byte; read while
    empty it returns 0 and pops nothing.
    """

    def __init__(self, clk_freq: float = 100e6, baudrate: float = 115200, rx_depth: int = 16):
        for name, value in (("clk_freq", clk_freq), ("baudrate", baudrate)):
            if isinstance(value, bool) or not isinstance(value, numbers.Real) \
                    or not math.isfinite(value) or value <= 0:
                raise ValueError(f"{name} must be a finite number > 0 (Hz / bit/s), "
                                 f"got {value!r}")
        divisor = round(clk_freq / baudrate)
        if not MIN_DIVISOR <= divisor <= MAX_DIVISOR:
            raise ValueError(f"clk_freq / baudrate must be in [{MIN_DIVISOR}, {MAX_DIVISOR}] "
                             f"clock cycles per bit, got clk_freq={clk_freq!r}, "
                             f"baudrate={baudrate!r} ({clk_freq / baudrate:.3f})")
        error = (clk_freq / divisor - baudrate) / baudrate
        if abs(error) > MAX_BAUD_ERROR:
            raise ValueError(f"baudrate {baudrate!r} is not reachable from clk_freq "
                             f"{clk_freq!r} within {MAX_BAUD_ERROR:.0%}: divisor {divisor} "
                             f"gives {clk_freq / divisor:.1f} bit/s ({error:+.2%})")
        self.clk_freq = clk_freq
        self.baudrate = baudrate
        self.divisor = divisor
        #: Relative error of the achieved baud rate ``clk_freq / divisor``.
        self.baud_error = error
        self.rx_depth = check_int("rx_depth", rx_depth, *RX_DEPTH_RANGE)
        super().__init__({
            "bus": In(AvalonSlaveSignature(ADDRESS_WIDTH)),
            "tx": Out(1, init=1),
            "rx": In(1, init=1),
            "tx_busy": Out(1),
            "rx_errors": Out(COUNTER_BITS),
            "rx_overruns": Out(COUNTER_BITS),
        })

    def elaborate(self, platform):
        m = Module()
        bus, div = self.bus, self.divisor

        # ---- transmitter -------------------------------------------------------
        hold = Signal(8)
        hold_full = Signal()
        shifter = Signal(_FRAME_BITS, init=(1 << _FRAME_BITS) - 1)  # idle: all ones
        bits_left = Signal(range(_FRAME_BITS + 1))
        tx_count = Signal(range(div))
        shifting = bits_left != 0
        bit_done = shifting & (tx_count == 0)
        load = hold_full & (~shifting | (bit_done & (bits_left == 1)))
        with m.If(load):
            m.d.sync += [shifter.eq(Cat(Const(0, 1), hold, Const(1, 1))),
                         bits_left.eq(_FRAME_BITS), tx_count.eq(div - 1), hold_full.eq(0)]
        with m.Elif(bit_done):
            m.d.sync += [shifter.eq(Cat(shifter[1:], Const(1, 1))),
                         bits_left.eq(bits_left - 1), tx_count.eq(div - 1)]
        with m.Elif(shifting):
            m.d.sync += tx_count.eq(tx_count - 1)
        # load needs hold_full = 1 and an accepted write hold_full = 0: never both.
        with m.If(bus.write & (bus.address == UART_TXDATA // 4) & ~hold_full):
            m.d.sync += [hold.eq(bus.writedata[:8]), hold_full.eq(1)]
        m.d.comb += [self.tx.eq(shifter[0]), self.tx_busy.eq(hold_full | shifting)]

        # ---- receiver ----------------------------------------------------------
        line = Signal(init=1)
        m.submodules.rx_sync = FFSynchronizer(self.rx, line, init=1)
        m.submodules.rx_fifo = rx_fifo = SyncFIFOBuffered(width=8, depth=self.rx_depth)
        rx_count = Signal(range(div))
        rx_bit = Signal(range(8))
        rx_byte = Signal(8)
        rx_errors = Signal(COUNTER_BITS)
        rx_overruns = Signal(COUNTER_BITS)
        with m.If(rx_count != 0):
            m.d.sync += rx_count.eq(rx_count - 1)
        with m.FSM(name="rx_fsm"):
            with m.State("IDLE"):
                with m.If(~line):
                    m.d.sync += rx_count.eq(div // 2 - 1)
                    m.next = "START"
            with m.State("START"):
                with m.If(rx_count == 0):
                    m.d.sync += [rx_count.eq(div - 1), rx_bit.eq(0)]
                    with m.If(line):
                        m.next = "IDLE"  # low for less than half a bit: a glitch
                    with m.Else():
                        m.next = "DATA"
            with m.State("DATA"):
                with m.If(rx_count == 0):
                    m.d.sync += [rx_byte.eq(Cat(rx_byte[1:], line)), rx_count.eq(div - 1),
                                 rx_bit.eq(rx_bit + 1)]
                    with m.If(rx_bit == 7):
                        m.next = "STOP"
            with m.State("STOP"):
                with m.If(rx_count == 0):
                    with m.If(line):
                        m.d.comb += rx_fifo.w_en.eq(1)
                        with m.If(~rx_fifo.w_rdy & (rx_overruns != (1 << COUNTER_BITS) - 1)):
                            m.d.sync += rx_overruns.eq(rx_overruns + 1)
                        m.next = "IDLE"
                    with m.Else():
                        with m.If(rx_errors != (1 << COUNTER_BITS) - 1):
                            m.d.sync += rx_errors.eq(rx_errors + 1)
                        m.next = "BREAK"
            with m.State("BREAK"):
                with m.If(line):  # a new start bit needs a high-to-low edge
                    m.next = "IDLE"
        m.d.comb += [rx_fifo.w_data.eq(rx_byte), self.rx_errors.eq(rx_errors),
                     self.rx_overruns.eq(rx_overruns)]

        # ---- bus read path (registered: read latency 1) --------------------------
        pop = bus.read & (bus.address == UART_RXDATA // 4) & rx_fifo.r_rdy
        m.d.comb += rx_fifo.r_en.eq(pop)
        status = Signal(DATA_WIDTH)
        m.d.comb += status.eq((UART_STATUS_TX_READY * ~hold_full)
                              | (UART_STATUS_RX_VALID * rx_fifo.r_rdy))
        m.d.sync += bus.readdata.eq(0)
        with m.If(bus.read):
            with m.Switch(bus.address):
                with m.Case(UART_STATUS // 4):
                    m.d.sync += bus.readdata.eq(status)
                with m.Case(UART_RXDATA // 4):
                    m.d.sync += bus.readdata.eq(Mux(rx_fifo.r_rdy, rx_fifo.r_data, 0))
        return m
