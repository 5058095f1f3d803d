"""Avalon-MM slave port as Platform Designer presents it behind the lightweight
HPS-to-FPGA bridge: word addresses, 32-bit data, no byte enables, no wait
states, fixed read latency of one cycle (``readdata`` is valid the cycle after
``read``; one ``read`` cycle is one transfer, so a read can pop a FIFO).
"""
from __future__ import annotations

from amaranth.lib import wiring
from amaranth.lib.wiring import In, Out

from sim.model.validation import check_int

__all__ = ["AvalonSlaveSignature", "READ_LATENCY", "DATA_WIDTH"]

#: Cycles from ``read`` to valid ``readdata`` (the ``_hw.tcl`` declares the same).
READ_LATENCY = 1
DATA_WIDTH = 32


class AvalonSlaveSignature(wiring.Signature):
    """Avalon-MM slave signature, from the master's side (slaves use ``In(...)``).

    Parameters
    ----------
    address_width : int
        Word-address bits (1..16).
    """

    def __init__(self, address_width: int):
        self.address_width = check_int("address_width", address_width, 1, 16)
        super().__init__({
            "address": Out(address_width),
            "read": Out(1),
            "write": Out(1),
            "writedata": Out(DATA_WIDTH),
            "readdata": In(DATA_WIDTH),
        })

    def __eq__(self, other):
        return isinstance(other, AvalonSlaveSignature) and \
            other.address_width == self.address_width

    def __hash__(self):
        return hash(("AvalonSlaveSignature", self.address_width))

    def __repr__(self):
        return f"AvalonSlaveSignature({self.address_width})"
