"""hdl/_util.py: the helpers every block uses: bit widths, the frame-size check,
free-running delays and kept register copies."""
import pytest
from amaranth.hdl import Module, Signal
from amaranth.sim import Simulator

from hdl._util import (HEIGHT_RANGE, KEEP_REGISTER, WIDTH_RANGE, bits_for, check_geometry,
                       delay, register_input, replicate)


def test_bits_for():
    assert [bits_for(v) for v in (0, 1, 2, 3, 4, 255, 256)] == [1, 1, 2, 2, 3, 8, 9]


def test_check_geometry():
    assert check_geometry(8, 2) == (8, 2) and check_geometry(4096, 4096) == (4096, 4096)
    with pytest.raises(ValueError, match=r"width must be in \[8, 4096\], got 7"):
        check_geometry(7, 2)
    with pytest.raises(ValueError, match=r"width must be in \[30, 4096\], got 20"):
        check_geometry(20, 2, min_width=30)
    with pytest.raises(ValueError, match=r"height must be in \[2, 4096\], got 1"):
        check_geometry(8, 1)
    assert WIDTH_RANGE == (8, 4096) and HEIGHT_RANGE == (2, 4096)


def test_delay_and_replicate_are_registers():
    m = Module()
    value = Signal(4)
    late = delay(m, value, 3, "late")
    copies = replicate(m, value, 2, "copy", init=5)
    assert delay(m, value, 0) is value
    assert all(c.attrs == KEEP_REGISTER and c.init == 5 for c in copies)
    seen = []

    async def testbench(ctx):
        for k in range(8):
            ctx.set(value, k)
            await ctx.tick()
            seen.append((ctx.get(late), ctx.get(copies[0]), ctx.get(copies[1])))

    sim = Simulator(m)
    sim.add_clock(1e-8)
    sim.add_testbench(testbench)
    sim.run()
    assert [s[0] for s in seen] == [0, 0, 0, 1, 2, 3, 4, 5]
    assert [s[1] for s in seen] == [s[2] for s in seen] == list(range(8))


def test_register_input_delays_payload_and_beat_alike():
    """The registered payload and each copy of the beat describe the same beat,
    one cycle after the stream's."""
    from amaranth.lib import data, stream
    m = Module()
    port = stream.Signature(data.StructLayout({"first": 1, "pixel": 8}),
                            always_ready=True).flip().create()
    payload, beats = register_input(m, port, 3, "pixels")
    assert len(beats) == 3 and all(b.attrs == KEEP_REGISTER for b in beats)
    assert payload.shape() == port.payload.shape()
    seen = []

    async def testbench(ctx):
        for k in range(6):
            ctx.set(port.valid, k % 2)
            ctx.set(port.payload.pixel, 10 + k)
            await ctx.tick()
            # the inputs move on: what is read now was registered at the edge
            ctx.set(port.valid, 1 - k % 2)
            ctx.set(port.payload.pixel, 0)
            seen.append((ctx.get(payload.pixel), *(ctx.get(b) for b in beats)))

    sim = Simulator(m)
    sim.add_clock(1e-8)
    sim.add_testbench(testbench)
    sim.run()
    assert seen == [(10 + k, *[k % 2] * 3) for k in range(6)]
