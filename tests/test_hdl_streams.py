# amaranth: UnusedElaboratable=no
"""hdl/streams.py: connect_remapped wires streams whose payload fields differ."""
import pytest
from amaranth.hdl import Module
from amaranth.lib import data, stream
from amaranth.sim import Simulator

from hdl.streams import connect_remapped


def _streams(ready: bool = False):
    source = stream.Signature(data.StructLayout({"first": 1, "hand": 1, "extra": 4}),
                              always_ready=not ready).create()
    sink = stream.Signature(data.StructLayout({"first": 1, "pixel": 1}),
                            always_ready=not ready).create()
    return source, sink


def test_fields_by_name_and_by_keyword():
    source, sink = _streams(ready=True)
    m = Module()
    connect_remapped(m, source, sink, pixel=source.payload.hand)
    sim = Simulator(m)

    async def bench(ctx):
        ctx.set(source.valid, 1)
        ctx.set(source.payload, {"first": 1, "hand": 0, "extra": 9})
        ctx.set(sink.ready, 1)
        assert (ctx.get(sink.valid), ctx.get(sink.payload.first), ctx.get(sink.payload.pixel),
                ctx.get(source.ready)) == (1, 1, 0, 1)
        ctx.set(source.payload.hand, 1)
        ctx.set(sink.ready, 0)
        assert (ctx.get(sink.payload.pixel), ctx.get(source.ready)) == (1, 0)
    sim.add_testbench(bench)
    sim.run()


def test_a_field_without_a_value_or_an_unknown_keyword_is_named():
    source, sink = _streams()
    with pytest.raises(ValueError, match="field 'pixel' has no value"):
        connect_remapped(Module(), source, sink)
    with pytest.raises(ValueError, match="no field colour"):
        connect_remapped(Module(), source, sink, pixel=source.payload.hand, colour=1)
