"""Row buffer: a bank of delay lines of ``length`` beats on one
``lib.memory.Memory`` (the line buffers of the moving-window generators,
thesis §6.2, Fig. 53).

A circular buffer of depth ``length`` and width ``lanes * pixel_bits``: on a beat
the word at the pointer is read (synchronous read port) and passes a register,
so ``o_data`` is valid two cycles after the beat; the new lane inputs, sampled in
that cycle, pass a register too and are written over the word a cycle later;
then the pointer has advanced. A value written on a beat is therefore read back
exactly ``length`` beats later, whatever idle cycles lie between. A simple
dual-port RAM of ``length * lanes * pixel_bits`` bits, one read and one write
per beat, whose ports meet only registers: its output register can sit next
to the block and its write port is fed from registers (the routed limit of the
whole pipeline had been a block's output net and a write port fed through a
LUT). Lines shorter than :data:`MEMORY_MIN_LENGTH` are registers with the same
timing. The lines run across frame boundaries (the window generator masks
whatever lies outside the frame).
"""
from __future__ import annotations

from amaranth.hdl import Module, Mux, Signal
from amaranth.lib import data, memory, wiring
from amaranth.lib.wiring import In, Out

from ._util import NO_RW_COLLISION, PIXEL_BITS_RANGE, check_int, delay, registered_read

__all__ = ["RowBuffer", "MEMORY_MIN_LENGTH"]

#: From this length on a line is a memory: its word is written three cycles after
#: the beat that read it, before the next read of that word (``length`` beats on).
MEMORY_MIN_LENGTH = 4


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
        True (default): the read port and its register are enabled by the
        beat, so ``o_data`` holds its value until the next beat's word
        arrives. False: they run every cycle and ``o_data`` is valid only two
        cycles after a beat, so the beat reaches no block-RAM enable: on a
        window generator's wide row buffers the beat's net spanned the RAM
        columns (routed on an ECP5: 10 ns of routing for the census's beat).

    Ports
    -----
    beat : In, one advance of every line.
    o_data : Out, ``o_data[i]``: the value lane i received ``length`` beats
        before the last beat; valid from the second cycle after that beat
        (with ``hold_output=False`` in that cycle only).
    i_data : In, ``i_data[i]``: sampled in the second cycle after a beat (the
        cycle ``o_data`` is valid), so a lane may take another lane's output.
    """

    cycles = 2  #: o_data is valid two clock cycles after the beat (read, register)

    def __init__(self, length: int, lanes: int, pixel_bits: int, hold_output: bool = True):
        self.length = check_int("length", length, 2, 65536)
        self.lanes = check_int("lanes", lanes, 1, 256)
        self.pixel_bits = check_int("pixel_bits", pixel_bits, *PIXEL_BITS_RANGE)
        self.hold_output = bool(hold_output)
        self.uses_memory = self.length >= MEMORY_MIN_LENGTH
        self.memory_bits = self.length * self.lanes * self.pixel_bits * self.uses_memory
        lanes_layout = data.ArrayLayout(pixel_bits, lanes)
        super().__init__({
            "beat": In(1),
            "i_data": In(lanes_layout),
            "o_data": Out(lanes_layout),
        })

    def elaborate(self, platform):
        m = Module()
        n = self.length
        width = self.lanes * self.pixel_bits
        # the cycle the inputs are sampled (and the outputs valid)
        sample = delay(m, self.beat, self.cycles, "sample")
        if not self.uses_memory:
            line = self.i_data.as_value()
            for k in range(n):
                reg = Signal(width, name=f"line_{k}", reset_less=True)
                with m.If(sample):
                    m.d.sync += reg.eq(line)
                line = reg
            m.d.comb += self.o_data.as_value().eq(line)
            return m
        # a word is written three cycles after its read, read again `length` >= 4
        # beats after that read: the ports never meet on a word
        m.submodules.mem = mem = memory.Memory(shape=width, depth=n, init=[],
                                               attrs=NO_RW_COLLISION)
        wr = mem.write_port()
        ptr = Signal(range(n))
        with m.If(self.beat):
            m.d.sync += ptr.eq(Mux(ptr == n - 1, 0, ptr + 1))
        # the block's read register, then one more next to the block's consumers
        word = registered_read(m, mem, ptr, "read_word",
                               en=self.beat if self.hold_output else None)
        out = Signal(width, name="read_reg", reset_less=True)
        read = delay(m, self.beat, 1, "read")
        with m.If(read if self.hold_output else 1):
            m.d.sync += out.eq(word)
        write_data = delay(m, self.i_data.as_value(), 1, "wdata", reset_less=True)
        m.d.comb += [
            wr.addr.eq(delay(m, ptr, self.cycles + 1, "waddr", reset_less=True)),
            wr.en.eq(delay(m, sample, 1, "wen")),
            wr.data.eq(write_data),
            self.o_data.as_value().eq(out),
        ]
        return m
