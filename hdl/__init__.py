"""Amaranth components of the FPGA side, one per module, each bit for bit its
golden-model stage in :mod:`sim.model`.

Stream convention (every component of the stereo matcher follows it)
--------------------------------------------------------------------
A component sees a stream of *beats*: a cycle whose ``valid`` is high. Each beat
advances the component by one raster position; a cycle with ``valid`` low
changes no state (idle gaps may occur anywhere, inside rows and between frames).
The payload of every input beat carries ``first``, high on pixel (0, 0) of a
frame; a frame is the ``width * height`` beats that follow in raster order.
After a frame, *flush beats* (payload ignored, ``first`` low) push the frame's
last results out of the window stages; the next frame starts with the next
``first``.

Every component emits exactly one output beat per input beat, a fixed number of
clock cycles later (``cycles``), so gaps are preserved. The output beat refers to
the raster position ``lag`` beats before the input beat (``lag`` is the look-ahead
of the component's windows, e.g. ``r * width + r`` for a window of radius r); its
payload carries ``first`` (the output position is (0, 0)) and ``real`` (the output
position lies inside the frame, 0 <= y < height). A component therefore needs at
least ``lag`` flush beats after each frame to emit the frame's last pixel.

Internally, two kinds of registers:

* *beat-gated* state (row buffers, window shift registers, delay lines,
  accumulators) changes only on a beat;
* *free-running* pipeline registers (adder trees, comparators, sorting network)
  shift every cycle and carry their beat's ``valid`` along.

Registers that only carry data (the Hamming counts, the SHD's right codes, the
column and window sums, the best-of trees and chains, the window rows, the
sorting network and the AND trees) have no reset (``reset_less``): the
position counters and ``valid`` are reset, and every data register is written
before a beat reads it, as the row buffers' RAM is. That took 17,195
flip-flops off the pipeline clock's reset tree (routed, issue 27) and a reset
multiplexer per register off the simulation.
"""
