"""Row buffer: a bank of delay lines of ``length`` beats on one
``lib.memory.Memory`` (the line buffers of the moving-window generators,
thesis §6.2, Fig. 53).

A circular buffer of depth ``length`` and width ``lanes * pixel_bits``: on a beat
the word at the pointer is read (synchronous read port) and, in the next cycle,
overwritten with the new lane inputs, then the pointer advances. A value written
on a beat is therefore read back exactly ``length`` beats later, whatever idle
cycles lie between. A simple dual-port RAM of ``length * lanes * pixel_bits``
bits, one read and one write per beat. The lines run across frame boundaries
(the window generator masks whatever lies outside the frame).
"""
from __future__ import annotations

from amaranth.hdl import Module, Mux, Signal
from amaranth.lib import data, memory, wiring
from amaranth.lib.wiring import In, Out

from ._util import PIXEL_BITS_RANGE, check_int, delay

__all__ = ["RowBuffer"]


class RowBuffer(wiring.Component):
    """``lanes`` delay lines of ``length`` beats.

    Parameters
    ----------
    length : int in [2, 65536]
        Delay in beats (a row of the image is ``width`` beats; a window
        generator chains lines of ``width - window`` behind window rows).
    lanes : int in [1, 256]
    pixel_bits : int in [1, 16]
    hold_output : bool
        True (default): the read port is enabled by the beat, so ``o_data``
        holds its value until the next beat. False: the read port reads every
        cycle and ``o_data`` is valid only in the cycle after a beat, so the
        beat reaches no block-RAM enable: on a window generator's wide row
        buffers the beat's net spanned the RAM columns (routed on an ECP5:
        10 ns of routing for the census's beat).

    Ports
    -----
    beat : In, one advance of every line.
    o_data : Out, ``o_data[i]``: the value lane i received ``length`` beats
        before the last beat; valid from the cycle after that beat (with
        ``hold_output=False`` in that cycle only).
    i_data : In, ``i_data[i]``: sampled in the cycle after a beat (the
        cycle ``o_data`` is valid), so a lane may take another lane's output.
    """

    cycles = 1  #: o_data is valid one clock cycle after the beat

    def __init__(self, length: int, lanes: int, pixel_bits: int, hold_output: bool = True):
        self.length = check_int("length", length, 2, 65536)
        self.lanes = check_int("lanes", lanes, 1, 256)
        self.pixel_bits = check_int("pixel_bits", pixel_bits, *PIXEL_BITS_RANGE)
        self.hold_output = bool(hold_output)
        self.memory_bits = self.length * self.lanes * self.pixel_bits
        lanes_layout = data.ArrayLayout(pixel_bits, lanes)
        super().__init__({
            "beat": In(1),
            "i_data": In(lanes_layout),
            "o_data": Out(lanes_layout),
        })

    def elaborate(self, platform):
        m = Module()
        n = self.length
        m.submodules.mem = mem = memory.Memory(shape=self.lanes * self.pixel_bits, depth=n,
                                               init=[])
        rd = mem.read_port()
        wr = mem.write_port()
        ptr = Signal(range(n))
        with m.If(self.beat):
            m.d.sync += ptr.eq(Mux(ptr == n - 1, 0, ptr + 1))
        m.d.comb += [
            rd.addr.eq(ptr), rd.en.eq(self.beat if self.hold_output else 1),
            wr.addr.eq(delay(m, ptr, 1, "waddr")),
            wr.en.eq(delay(m, self.beat, 1, "wen")),
            wr.data.eq(self.i_data.as_value()),
            self.o_data.as_value().eq(rd.data),
        ]
        return m
