"""Drive a stream component in the Amaranth simulator (used by the tests and the
``--backend amaranth`` option of ``stereogest stereo``).

Payloads travel as packed integers (one ``ctx.set`` / ``ctx.get`` per cycle);
:func:`pack` and :func:`field` convert between dicts/arrays and those integers
using the component's ``StructLayout``.
"""
from __future__ import annotations

import numpy as np
from amaranth.hdl import Shape
from amaranth.lib import data
from amaranth.sim import Simulator

__all__ = ["pack", "field", "gap_pattern", "frame_beats", "run_stream", "split_frames"]


def _offset_width(layout, name):
    f = layout[name]
    shape = f.shape
    return f.offset, _width(shape), shape


def _width(shape):
    return shape.size if isinstance(shape, data.Layout) else Shape.cast(shape).width


def pack(layout: data.StructLayout, values: dict) -> int:
    """Pack ``{field: int or flat sequence}`` into the integer of ``layout``."""
    word = 0
    for name, value in values.items():
        off, width, shape = _offset_width(layout, name)
        if isinstance(shape, data.ArrayLayout):
            elem = width // shape.length
            flat = np.ravel(value)
            v = 0
            for i, e in enumerate(flat):
                v |= (int(e) & ((1 << elem) - 1)) << (i * elem)
        else:
            v = int(value) & ((1 << width) - 1)
        word |= v << off
    return word


def field(layout: data.StructLayout, words, name: str, count: int | None = None):
    """Field ``name`` of packed ``words`` (a sequence of ints) as a numpy array;
    an array field of ``count`` elements gives shape (len(words), count)."""
    off, width, shape = _offset_width(layout, name)
    mask = (1 << width) - 1
    vals = [(w >> off) & mask for w in words]
    if count is None:
        return np.array(vals, dtype=np.int64)
    elem = width // count
    emask = (1 << elem) - 1
    return np.array([[(v >> (i * elem)) & emask for i in range(count)] for v in vals],
                    dtype=np.int64).reshape(len(vals), count)


def gap_pattern(n_cycles: int, idle: float, seed: int) -> np.ndarray:
    """Deterministic idle pattern: True where a cycle is idle (valid low)."""
    if idle <= 0:
        return np.zeros(n_cycles, dtype=bool)
    rng = np.random.default_rng(seed)
    return rng.random(n_cycles) < idle


def frame_beats(layout, frames: list[list[dict]], flush: int,
                flush_values: list[list[dict]] | None = None) -> list[int]:
    """Packed input beats: every frame's pixels (``first`` on the first) then
    ``flush`` flush beats (payload 0, or ``flush_values[frame][k]``)."""
    beats = []
    for f, frame in enumerate(frames):
        for k, values in enumerate(frame):
            beats.append(pack(layout, dict(values, first=int(k == 0))))
        for k in range(flush):
            extra = flush_values[f][k] if flush_values is not None else None
            beats.append(pack(layout, extra) if extra else 0)
    return beats


def run_stream(dut, beats: list[int], *, idle: float = 0.0, seed: int = 0,
               extra_cycles: int = 64, setup=None, use_ready: bool = False,
               stop_after: int | None = None, out_cycles: list | None = None,
               stats: dict | None = None) -> list[int]:
    """Feed ``beats`` to ``dut.i_stream`` (idle cycles inserted with probability
    ``idle``) and return the payload words of every output beat.

    ``use_ready``: honour ``i_stream.ready``. ``stop_after``: stop once that many
    output beats were collected. ``setup(ctx)`` runs first (e.g. set a threshold).
    ``out_cycles``: a list that receives the clock cycle (from 0) of each output beat.
    ``stats``: a dict that receives ``cycles`` and ``seconds`` (simulation only,
    without elaboration).
    """
    i, o = dut.i_stream, dut.o_stream
    out: list[int] = []
    idle_at = gap_pattern(4 * len(beats) + 16, idle, seed)

    async def testbench(ctx):
        import time
        start = time.perf_counter()
        if setup is not None:
            setup(ctx)
        pos = 0
        cycle = 0
        tail = 0
        in_payload = i.payload.as_value()
        out_payload = o.payload.as_value()
        while True:
            present = pos < len(beats) and not idle_at[cycle % len(idle_at)]
            ctx.set(i.valid, int(present))
            if present:
                ctx.set(in_payload, beats[pos])
            accepted = present and (not use_ready or ctx.get(i.ready))
            if ctx.get(o.valid):
                out.append(ctx.get(out_payload))
                if out_cycles is not None:
                    out_cycles.append(cycle)
            await ctx.tick()
            cycle += 1
            if accepted:
                pos += 1
            if stop_after is not None and len(out) >= stop_after:
                break
            if pos >= len(beats):
                tail += 1
                if tail > extra_cycles:
                    break
        if stats is not None:
            stats.update(cycles=cycle, seconds=time.perf_counter() - start)

    sim = Simulator(dut)
    sim.add_clock(1e-8)
    sim.add_testbench(testbench)
    sim.run()
    return out


def split_frames(layout, words: list[int], width: int, height: int, nframes: int):
    """Group the real output beats into frames; checks ``first`` marks each frame start."""
    real = field(layout, words, "real") if "real" in layout.members else np.ones(len(words), int)
    first = field(layout, words, "first")
    idx = np.nonzero(real)[0]
    n = width * height
    if len(idx) < n * nframes:
        raise AssertionError(f"only {len(idx)} real output beats, expected {n * nframes}")
    frames = []
    for f in range(nframes):
        sel = idx[f * n:(f + 1) * n]
        if not first[sel[0]] or first[sel[1:]].any():
            raise AssertionError(f"frame {f}: 'first' flag not on the frame's first pixel only")
        frames.append(sel)
    return frames
