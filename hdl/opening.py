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
from amaranth.lib.wiring import In, Out

from sim.model.morphology import resolve_element

from ._util import check_geometry
from .morphology import BinaryMorphology, morphology_memory_bits, morphology_timing
from .stage import StageTiming
from .streams import pixel_signature

__all__ = ["Opening", "opening_timing", "opening_memory_bits"]


def opening_timing(width: int, element) -> StageTiming:
    """An erosion then a dilation with the same element."""
    one = morphology_timing(width, element)
    return StageTiming(lag=2 * one.lag, cycles=2 * one.cycles)


def opening_memory_bits(width: int, element) -> int:
    """The row buffers of the erosion and the dilation."""
    return 2 * morphology_memory_bits(width, element)


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
        # the checks of BinaryMorphology, in its order
        self.element = resolve_element(element, size if isinstance(element, str) else None)
        self.size = self.element.shape[0]
        self.width, self.height = check_geometry(width, height, min_width=self.size + 2)
        self.lag, self.cycles = opening_timing(self.width, self.element)
        self.memory_bits = opening_memory_bits(self.width, self.element)
        # the mask streams of the two stages it chains
        super().__init__({
            "i_stream": In(pixel_signature(1)),
            "o_stream": Out(pixel_signature(1, real=True)),
        })

    def elaborate(self, platform):
        m = Module()
        m.submodules.erosion = ero = BinaryMorphology(self.width, self.height,
                                                      element=self.element)
        m.submodules.dilation = dil = BinaryMorphology(self.width, self.height,
                                                       element=self.element)
        m.d.comb += [ero.dilate.eq(0), dil.dilate.eq(1)]
        wiring.connect(m, wiring.flipped(self.i_stream), ero.i_stream)
        m.d.comb += [
            dil.i_stream.valid.eq(ero.o_stream.valid),
            dil.i_stream.payload.first.eq(ero.o_stream.payload.first),
            dil.i_stream.payload.pixel.eq(ero.o_stream.payload.pixel),
        ]
        wiring.connect(m, dil.o_stream, wiring.flipped(self.o_stream))
        return m
