"""Centroid FIFO peripheral: an Avalon-MM slave on the lightweight HPS-to-FPGA
bridge (thesis §7.4.1, Tables 12 and 13).

The register map is :data:`soc.hps_interface.FIFO_REGISTERS` (the driver,
:mod:`sw_hps.fifo`, takes it from there too);
:class:`sw_hps.simulated.SimulatedFifoPeripheral` is its software model and the
golden model of the tests.
"""
from __future__ import annotations

from amaranth.hdl import Cat, Module, Mux, Signal
from amaranth.lib import data, memory, stream, wiring
from amaranth.lib.wiring import In, Out

from sim.model.validation import check_int, check_power_of_two
from .hps_interface import (CONTROL, CORE_MAGIC, CTRL_FIFO_CLR, CTRL_GO, CTRL_STREAM, DATA_BITS,
                            DATO_X, DATO_Y, FIFO_DEPTH, FIFO_REGISTERS, FRAME_HEIGHT,
                            FRAME_WIDTH, ID, LONGITUD_X, LONGITUD_Y, VERSION, version_word)

from .avalon import DATA_WIDTH, AvalonSlaveSignature

__all__ = ["FifoSlave", "ADDRESS_WIDTH", "DATA_BITS_RANGE", "DEPTH_RANGE"]

#: Word-address bits: eight registers (0x00..0x1C) -> word addresses 0..7.
ADDRESS_WIDTH = FIFO_REGISTERS.address_width
#: (one bit above the data carries the streaming mode's FLAG / PRESENT)
DATA_BITS_RANGE = (1, DATA_WIDTH - 1)
#: Powers of two only (the pointers wrap by overflowing).
DEPTH_RANGE = (2, 65536)

_GO_BIT = CTRL_GO.bit_length() - 1
_CLR_BIT = CTRL_FIFO_CLR.bit_length() - 1
_STREAM_BIT = CTRL_STREAM.bit_length() - 1


class FifoSlave(wiring.Component):
    """Two FIFOs (smoothed centroid x and y) read by the HPS through the register
    map :data:`soc.hps_interface.FIFO_REGISTERS` (thesis §7.4.1, Table 12: registers; Table 13:
    Control bits).

    Parameters
    ----------
    data_bits : int in [1, 31]
        Width of Dato_X / Dato_Y (thesis 10.8 fixed point: 18). Bit
        ``data_bits`` is the streaming mode's FLAG (Dato_X) / PRESENT (Dato_Y);
        the bits above read 0.
    depth : int, power of two in [2, 65536]
        Entries per FIFO (:data:`soc.hps_interface.FIFO_DEPTH` = 512: one M10K block of
        512 x 18 bits per FIFO). Longitud_X / Longitud_Y count 0..depth.
    frame_width, frame_height : int in [1, 2040]
        Size of the frames whose centroids are pushed (the core passes the size
        it is built at; default the board's 640 x 480): only reported, in the
        Version register, with the depth, the streaming mode and
        :data:`~soc.hps_interface.CORE_REVISION`
        (:func:`soc.hps_interface.version_word`).

    Ports
    -----
    bus : ``In(AvalonSlaveSignature(3))``
        Word addresses (byte offset / 4), read latency 1, no wait states. Each
        cycle with ``read`` high is one transfer: a read of Dato_X pops once.
    i_stream : payload ``{x, y: data_bits, flag: 1, present: 1}`` (always ready)
        One beat per video frame: the smoothed centroid, the gesture-spotting
        flag of that frame and whether it saw a hand. While GO is 1 a beat with
        ``flag`` set pushes (x, y) (thesis mode), or every beat pushes
        (x | flag << data_bits, y | present << data_bits) (STREAM = 1: streaming
        mode); if either FIFO is full the pair is dropped from both and
        FIFO-FULL is set. Every beat updates the latest flag (the gesture bit
        follows it).
    go : Out(1)
        Control.GO.
    gesture : Out(1)
        GO AND latest flag: a gesture is in progress (LEDR[4]); Control bit 2
        reads its complement (thesis polarity).
    full : Out(1)
        Control.FIFO-FULL (sticky until a FIFO-CLR write).

    Notes
    -----
    Same-cycle bus access and push: both take effect, the bus access first. A
    read returns the state at the start of the cycle (a pop of an empty FIFO
    returns 0 even if a pair is pushed in that cycle); the push then sees the
    state after the access: a write of GO or STREAM rules that cycle's push, a FIFO-CLR
    empties the FIFOs before the pair is pushed, and a pop of a full FIFO makes
    room for it. This is the order ``read32`` / ``write32`` then ``push_frame``
    of :class:`~sw_hps.simulated.SimulatedFifoPeripheral`. ID (word 6) reads
    :data:`~soc.hps_interface.CORE_MAGIC` and Version (word 7) :attr:`version`,
    constants; writes other than Control are ignored.

    Attributes
    ----------
    version : int
        What the Version register reads.
    """

    def __init__(self, data_bits: int = DATA_BITS, depth: int = FIFO_DEPTH, *,
                 frame_width: int = FRAME_WIDTH, frame_height: int = FRAME_HEIGHT):
        self.data_bits = check_int("data_bits", data_bits, *DATA_BITS_RANGE)
        self.depth = check_power_of_two("depth", depth, *DEPTH_RANGE)
        # validates the frame size (the message names the parameter)
        self.version = version_word(fifo_depth=self.depth, streaming=True,
                                    frame_width=frame_width, frame_height=frame_height)
        self.frame_width, self.frame_height = frame_width, frame_height
        super().__init__({
            "bus": In(AvalonSlaveSignature(ADDRESS_WIDTH)),
            "i_stream": In(stream.Signature(data.StructLayout(
                {"x": self.data_bits, "y": self.data_bits, "flag": 1, "present": 1}),
                always_ready=True)),
            "go": Out(1),
            "gesture": Out(1),
            "full": Out(1),
        })

    def ports(self) -> list:
        """Port signals for ``amaranth.back.verilog.convert(..., ports=...)``: the
        signature's members minus the constant ``i_stream.ready`` (always ready),
        which ``convert`` cannot take as a port. Verilog names join the member
        path with ``__`` (``bus__address``, ``i_stream__payload``, ...)."""
        ports = []
        for _path, _flow, value in self.signature.flatten(self):
            value = value.as_value() if isinstance(value, data.View) else value
            if isinstance(value, Signal):
                ports.append(value)
        return ports

    def elaborate(self, platform):
        m = Module()
        bus, beat = self.bus, self.i_stream
        depth = self.depth
        ptr_bits = depth.bit_length() - 1

        go = Signal()
        streaming = Signal()
        flag = Signal()
        full = Signal()
        wp = Signal(ptr_bits)  # one write pointer: pushes always go to both FIFOs

        ctrl_write = bus.write & (bus.address == CONTROL // 4)
        clr = ctrl_write & bus.writedata[_CLR_BIT]
        go_next = Mux(ctrl_write, bus.writedata[_GO_BIT], go)
        streaming_next = Mux(ctrl_write, bus.writedata[_STREAM_BIT], streaming)
        m.d.sync += [go.eq(go_next), streaming.eq(streaming_next)]
        with m.If(beat.valid):
            m.d.sync += flag.eq(beat.payload.flag)
        push = beat.valid & (beat.payload.flag | streaming_next) & go_next
        wp_base = Mux(clr, 0, wp)

        fifos = {}
        for axis, offset, mark in (("x", DATO_X, beat.payload.flag),
                                   ("y", DATO_Y, beat.payload.present)):
            mem = memory.Memory(shape=self.data_bits + 1, depth=depth, init=[])
            m.submodules[f"mem_{axis}"] = mem
            wport = mem.write_port()
            rport = mem.read_port()  # not transparent: a full FIFO's oldest entry
            #                          survives a push to the same address
            rp = Signal(ptr_bits, name=f"rp_{axis}")
            count = Signal(range(depth + 1), name=f"count_{axis}")
            pop = Signal(name=f"pop_{axis}")
            after = Signal.like(count, name=f"count_{axis}_after_bus")
            m.d.comb += [
                pop.eq(bus.read & (bus.address == offset // 4) & (count != 0)),
                after.eq(Mux(clr, 0, count - pop)),
                rport.addr.eq(rp),
                wport.addr.eq(wp_base),
                wport.data.eq(Cat(getattr(beat.payload, axis), mark & streaming_next)),
            ]
            m.d.sync += rp.eq(Mux(clr, 0, rp + pop))
            fifos[axis] = dict(wport=wport, rport=rport, count=count, after=after, pop=pop)

        room = (fifos["x"]["after"] != depth) & (fifos["y"]["after"] != depth)
        accept = push & room
        for f in fifos.values():
            m.d.comb += f["wport"].en.eq(accept)
            m.d.sync += f["count"].eq(f["after"] + accept)
        m.d.sync += [
            wp.eq(wp_base + accept),
            full.eq((full & ~clr) | (push & ~room)),
        ]

        # Read path: registers are sampled in the read cycle; Dato_* come from
        # the RAM's registered output, so both are ready one cycle later.
        count_x, count_y = fifos["x"]["count"], fifos["y"]["count"]
        control = Cat(go, (count_x != 0) & (count_y != 0), ~(go & flag), 0, full, streaming)
        reg_data = Signal(DATA_WIDTH)
        from_x = Signal()
        from_y = Signal()
        m.d.sync += [from_x.eq(fifos["x"]["pop"]), from_y.eq(fifos["y"]["pop"]),
                     reg_data.eq(0)]
        with m.If(bus.read):
            with m.Switch(bus.address):
                with m.Case(CONTROL // 4):
                    m.d.sync += reg_data.eq(control)
                with m.Case(LONGITUD_X // 4):
                    m.d.sync += reg_data.eq(count_x)
                with m.Case(LONGITUD_Y // 4):
                    m.d.sync += reg_data.eq(count_y)
                with m.Case(ID // 4):
                    m.d.sync += reg_data.eq(CORE_MAGIC)
                with m.Case(VERSION // 4):
                    m.d.sync += reg_data.eq(self.version)
        m.d.comb += bus.readdata.eq(Mux(from_x, fifos["x"]["rport"].data,
                                        Mux(from_y, fifos["y"]["rport"].data, reg_data)))

        m.d.comb += [self.go.eq(go), self.gesture.eq(go & flag), self.full.eq(full)]
        return m
