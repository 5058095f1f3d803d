"""Posture record peripheral: an Avalon-MM slave on the lightweight HPS-to-FPGA
bridge that holds the latest frame's posture record (thesis §10.1, future
work; the register map :data:`soc.hps_interface.POSTURE_REGISTERS` is ours).

The pipeline's descriptor (:class:`hdl.posture_descriptor.PostureDescriptor`)
sends each frame's record a word a clock; the slave writes it into one of two
banks of a block RAM while the HPS reads the other (the latest complete one),
so a read of a whole record (a write of Index, then ``POSTURE_WORD_COUNT``
reads of Data) is never torn unless two records complete meanwhile, which
Status.SEQ tells. :class:`sw_hps.simulated.SimulatedPostureSlave` is its
software model.
"""
from __future__ import annotations

from amaranth.hdl import Cat, Module, Mux, Signal
from amaranth.lib import data, memory, stream, wiring
from amaranth.lib.wiring import In

from hdl._util import bits_for
from .avalon import DATA_WIDTH, AvalonSlaveSignature
from .hps_interface import (POSTURE_DATA, POSTURE_INDEX, POSTURE_LAYOUT, POSTURE_REGISTERS,
                            POSTURE_STATUS, POSTURE_WORD_COUNT, posture_layout_word)

__all__ = ["PostureSlave", "ADDRESS_WIDTH", "BANK_WORDS"]

#: Word-address bits: four registers.
ADDRESS_WIDTH = POSTURE_REGISTERS.address_width
#: Words per bank (a power of two that holds a record: 256 x 32 bits, one M10K).
BANK_WORDS = 1 << bits_for(POSTURE_WORD_COUNT - 1)


class PostureSlave(wiring.Component):
    """The latest posture record, read by the HPS through
    :data:`soc.hps_interface.POSTURE_REGISTERS`.

    Ports
    -----
    bus : ``In(AvalonSlaveSignature(2))``
        Word addresses, read latency 1, no wait states. A read of Data is one
        transfer: it returns the word at Index and advances Index.
    i_stream : payload ``{index: 8, word: 32}`` (always ready)
        The descriptor's record, word ``index`` a beat in order; the beat of
        the last word (``POSTURE_WORD_COUNT - 1``) completes the record: the
        next Index write chooses it, and Status.SEQ counts it.

    Notes
    -----
    Same-cycle Index write and record completion: the write chooses the
    record complete before that cycle. Data reads the bank chosen by the
    last Index write (the first bank, all zero, before any).
    """

    def __init__(self):
        super().__init__({
            "bus": In(AvalonSlaveSignature(ADDRESS_WIDTH)),
            "i_stream": In(stream.Signature(data.StructLayout(
                {"index": bits_for(POSTURE_WORD_COUNT - 1), "word": DATA_WIDTH}),
                always_ready=True)),
        })

    def elaborate(self, platform):
        m = Module()
        bus, beat = self.bus, self.i_stream
        index_bits = bits_for(BANK_WORDS - 1)
        mem = memory.Memory(shape=DATA_WIDTH, depth=2 * BANK_WORDS, init=[])
        m.submodules.banks = mem
        wport, rport = mem.write_port(), mem.read_port()

        latest = Signal(name="latest_bank")     # the bank of the latest complete record
        chosen = Signal(name="chosen_bank")     # the bank Data reads
        seq = Signal(16)
        index = Signal(index_bits)
        done = beat.valid & (beat.payload.index == POSTURE_WORD_COUNT - 1)
        m.d.comb += [wport.addr.eq(Cat(beat.payload.index, ~latest)),
                     wport.data.eq(beat.payload.word), wport.en.eq(beat.valid)]
        with m.If(done):
            m.d.sync += [latest.eq(~latest), seq.eq(seq + 1)]

        write_index = bus.write & (bus.address == POSTURE_INDEX // 4)
        read_data = bus.read & (bus.address == POSTURE_DATA // 4)
        m.d.comb += rport.addr.eq(Cat(index, chosen))
        with m.If(write_index):
            m.d.sync += [index.eq(bus.writedata[:index_bits]), chosen.eq(latest)]
        with m.Elif(read_data):
            m.d.sync += index.eq(index + 1)

        reg_data = Signal(DATA_WIDTH)
        from_data = Signal()
        m.d.sync += [from_data.eq(read_data), reg_data.eq(0)]
        with m.If(bus.read):
            with m.Switch(bus.address):
                with m.Case(POSTURE_STATUS // 4):
                    m.d.sync += reg_data.eq(seq)
                with m.Case(POSTURE_INDEX // 4):
                    m.d.sync += reg_data.eq(index)
                with m.Case(POSTURE_LAYOUT // 4):
                    m.d.sync += reg_data.eq(posture_layout_word())
        m.d.comb += bus.readdata.eq(Mux(from_data, rport.data, reg_data))
        return m
