"""Binary erosion and dilation (thesis §6.4, Figs. 63-69).

A :class:`~hdl.window.WindowGenerator` of one-bit pixels gives the k x k
neighbourhood of each pixel; the element's taps go through a pipelined AND tree
(Figs. 64 and 69). The D/E select of Fig. 69 is the ``dilate`` input: by De
Morgan, a dilation is the inverted AND of inverted taps, so both operations share
the tree; each leaf is ``(pixel XOR dilate) OR outside`` (a tap outside the
frame counts 1 for the erosion and 0 for the dilation, as the golden model and
OpenCV), and the root is XORed with ``dilate`` again. Fan-in
:data:`FANIN` = 6 per level (one 6-input LUT), one register per level.
"""
from __future__ import annotations

import numpy as np
from amaranth.hdl import Cat, Module, Signal
from amaranth.lib import wiring
from amaranth.lib.wiring import In, Out

from sim.model.morphology import resolve_element

from ._util import check_geometry, delay
from .stage import StageTiming
from .streams import pixel_signature
from .window import WindowGenerator, window_memory_bits, window_timing

__all__ = ["BinaryMorphology", "FANIN", "morphology_timing", "morphology_memory_bits"]

FANIN = 6


def _tree_levels(taps: int) -> int:
    """Levels of the AND/OR tree over ``taps`` inputs, :data:`FANIN` per gate."""
    levels = 0
    while taps > 1:
        taps = -(-taps // FANIN)
        levels += 1
    return levels


def morphology_timing(width: int, element) -> StageTiming:
    """The window's look-ahead; its cycles, the tap register, the tree and the
    output register (``element`` as :func:`sim.model.morphology.resolve_element`
    gives it)."""
    window = window_timing(width, len(element))
    return StageTiming(lag=window.lag,
                       cycles=window.cycles + 1 + _tree_levels(int(element.sum())) + 1)


def morphology_memory_bits(width: int, element) -> int:
    """The row buffers of the element's window, one bit per pixel (``element``
    as for :func:`morphology_timing`)."""
    return window_memory_bits(width, window=len(element), pixel_bits=1)


class BinaryMorphology(wiring.Component):
    """Erosion or dilation of a binary pixel stream by a structuring element.

    Parameters
    ----------
    width : int in [max(8, k + 2), 4096]
    height : int in [2, 4096]
    element : {"cross", "square", "diamond"} or (k, k) bool array, k odd in [1, 63]
        A name (:func:`sim.model.morphology.structuring_element` at ``size``;
        the thesis uses an 11 x 11 cross, Fig. 100) or an explicit element with
        at least one tap, anchored at its centre and not reflected.
    size : odd int in [3, 63]
        Side k of a named element (not used for an array).

    Ports
    -----
    dilate : In(1), the D/E select of Fig. 69: 0 erosion (AND of the taps),
        1 dilation (OR). Sampled with each pixel as it leaves the window
        generator; change it between frames.
    i_stream : payload ``{first, pixel: 1}``
    o_stream : payload ``{first, real, pixel: 1}``, ``lag`` = r * width + r
        raster positions behind the input (r = k // 2), ``cycles`` = window
        generator 2 + leaves 1 + ``tree_levels`` + output 1.

    Attributes
    ----------
    element : (k, k) bool array
    size : int, k
    taps : int, taps of the element
    tree_levels : int, levels of the AND tree (ceil(log6(taps)))
    lag, cycles, memory_bits : int
    """

    def __init__(self, width: int, height: int, element="cross", size: int = 11):
        self.element = resolve_element(element, size if isinstance(element, str) else None)
        self.size = self.element.shape[0]
        self.width, self.height = check_geometry(width, height, min_width=self.size + 2)
        self.taps = int(self.element.sum())
        self.tree_levels = _tree_levels(self.taps)
        self.lag, self.cycles = morphology_timing(self.width, self.element)
        self.memory_bits = morphology_memory_bits(self.width, self.element)
        super().__init__({
            "dilate": In(1),
            "i_stream": In(pixel_signature(1)),
            "o_stream": Out(pixel_signature(1, real=True)),
        })

    def elaborate(self, platform):
        m = Module()
        m.submodules.window = win = WindowGenerator(self.width, self.height, pixel_bits=1,
                                                    window=self.size)
        wiring.connect(m, wiring.flipped(self.i_stream), win.i_stream)
        wp = win.o_stream.payload

        # Leaves: one register per tap, 1 where the tap does not veto the AND.
        values = []
        for i, j in np.argwhere(self.element):
            i, j = int(i), int(j)
            leaf = Signal(name=f"leaf_{i}_{j}", reset_less=True)
            outside = ~(wp.rows1[i] & wp.cols[j])
            m.d.sync += leaf.eq((wp.v1[i][j] ^ self.dilate) | outside)
            values.append(leaf)
        for level in range(self.tree_levels):
            nxt = []
            for g in range(0, len(values), FANIN):
                node = Signal(name=f"and_l{level}_{g // FANIN}", reset_less=True)
                m.d.sync += node.eq(Cat(*values[g:g + FANIN]).all())
                nxt.append(node)
            values = nxt
        stages = 1 + self.tree_levels
        out = self.o_stream.payload
        m.d.sync += [
            out.pixel.eq(values[0] ^ delay(m, self.dilate, stages, "select")),
            out.first.eq(delay(m, wp.first, stages, "first")),
            out.real.eq(delay(m, wp.real, stages, "real")),
            self.o_stream.valid.eq(delay(m, win.o_stream.valid, stages, "valid")),
        ]
        return m
