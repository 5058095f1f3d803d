"""soc/avalon.py: the Avalon-MM slave signature the bus slaves share (word
addresses, 32-bit data, read latency 1, as the ``_hw.tcl`` declares)."""
import pytest
from amaranth.lib.wiring import Flow

from soc.avalon import DATA_WIDTH, READ_LATENCY, AvalonSlaveSignature


def test_members_and_directions():
    sig = AvalonSlaveSignature(address_width=3)
    members = {name: (m.flow, m.shape) for name, m in sig.members.items()}
    assert members == {"address": (Flow.Out, 3), "read": (Flow.Out, 1),
                       "write": (Flow.Out, 1), "writedata": (Flow.Out, DATA_WIDTH),
                       "readdata": (Flow.In, DATA_WIDTH)}
    assert (DATA_WIDTH, READ_LATENCY) == (32, 1)


def test_equality_by_address_width():
    assert AvalonSlaveSignature(4) == AvalonSlaveSignature(4) != AvalonSlaveSignature(5)
    assert len({AvalonSlaveSignature(4), AvalonSlaveSignature(4)}) == 1
    assert repr(AvalonSlaveSignature(2)) == "AvalonSlaveSignature(2)"


@pytest.mark.parametrize("bad", [0, 17, True, 2.0, "3"])
def test_bad_address_width_is_named(bad):
    with pytest.raises(ValueError, match=r"address_width must be .*\[1, 16\]"):
        AvalonSlaveSignature(bad)
