# amaranth: UnusedElaboratable=no
"""Morphological opening of the hand mask (thesis §6.4, Fig. 100): an erosion
then a dilation by the same, unreflected element, two
:class:`~hdl.morphology.BinaryMorphology` with constant D/E selects, as
:func:`sim.model.morphology.opening`.

The dilation runs on the erosion's output beats, including those outside the
frame (before it and during the flush): its own position counter masks them.
"""
from __future__ import annotations

from amaranth.hdl import Module
from amaranth.lib import wiring

from .morphology import BinaryMorphology, morphology_timing
from .stage import StageTiming

__all__ = ["Opening", "opening_timing"]


def opening_timing(width: int, element) -> StageTiming:
    """An erosion then a dilation with the same element."""
    one = morphology_timing(width, element)
    return StageTiming(lag=2 * one.lag, cycles=2 * one.cycles)


class Opening(wiring.Component):
    """Opening of a binary pixel stream.

    Parameters
    ----------
    width : int in [max(8, k + 2), 4096]
    height : int in [2, 4096]
    element, size : as :class:`~hdl.morphology.BinaryMorphology` (default the
        thesis' 11 x 11 cross)

    Ports
    -----
    i_stream : payload ``{first, pixel: 1}``
    o_stream : payload ``{first, real, pixel: 1}``, ``lag`` = 2 (r * width + r)
        raster positions behind the input, ``cycles`` = the two stages' sum.

    Attributes
    ----------
    lag, cycles, memory_bits : int, sums over the erosion and the dilation
    element : (k, k) bool array
    """

    def __init__(self, width: int, height: int, element="cross", size: int = 11):
        self._erosion = BinaryMorphology(width, height, element=element, size=size)
        self._dilation = BinaryMorphology(width, height, element=element, size=size)
        self.width, self.height = self._erosion.width, self._erosion.height
        self.element = self._erosion.element
        self.size = self._erosion.size
        self.lag, self.cycles = opening_timing(self.width, self.element)
        self.memory_bits = self._erosion.memory_bits + self._dilation.memory_bits
        # the mask streams of the two stages it chains
        stage = self._erosion.signature.members
        super().__init__({"i_stream": stage["i_stream"], "o_stream": stage["o_stream"]})

    def elaborate(self, platform):
        m = Module()
        m.submodules.erosion = ero = self._erosion
        m.submodules.dilation = dil = self._dilation
        m.d.comb += [ero.dilate.eq(0), dil.dilate.eq(1)]
        wiring.connect(m, wiring.flipped(self.i_stream), ero.i_stream)
        m.d.comb += [
            dil.i_stream.valid.eq(ero.o_stream.valid),
            dil.i_stream.payload.first.eq(ero.o_stream.payload.first),
            dil.i_stream.payload.pixel.eq(ero.o_stream.payload.pixel),
        ]
        wiring.connect(m, dil.o_stream, wiring.flipped(self.o_stream))
        return m
