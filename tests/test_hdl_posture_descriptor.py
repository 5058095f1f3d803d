# amaranth: UnusedElaboratable=no
"""hdl/posture_descriptor.py: PostureDescriptor, word for word against
sim.model.posture (posture_registers about the previous frame's
posture_reference, posture_words), in Amaranth's simulator."""
import numpy as np
import pytest
from amaranth.sim import Simulator

from hdl.posture_descriptor import PostureDescriptor, posture_cycles_after_frame
from sim.model.posture import (PostureReference, posture_mask, posture_reference,
                               posture_registers, posture_words)
from soc.hps_interface import POSTURE_WORD_COUNT
from verif.streams import pack


def _hand(h, w, rng):
    """A hand-like silhouette: a palm, up to five fingers, maybe a forearm, noise."""
    mask = np.zeros((h, w), bool)
    cy = int(rng.integers(h // 3, max(h // 3 + 1, h - 2)))
    cx = int(rng.integers(3, w - 3))
    half = int(rng.integers(2, max(3, w // 5)))
    mask[max(0, cy - half):cy + half, max(0, cx - half):cx + half] = True
    for k in range(int(rng.integers(0, 6))):
        fx = max(0, min(w - 1, cx - half + k * 2 + int(rng.integers(0, 2))))
        mask[max(0, cy - half - int(rng.integers(2, max(3, h // 2)))):cy, fx] = True
    if rng.random() < 0.5:
        mask[cy:, max(0, cx - 1):cx + 2] = True
    return mask ^ (rng.random((h, w)) < 0.03)


def _masks(h, w, seed, count=6):
    rng = np.random.default_rng(seed)
    masks = [_hand(h, w, rng) for _ in range(count)]
    empty, full = np.zeros((h, w), bool), np.ones((h, w), bool)
    corner = np.zeros((h, w), bool)
    corner[h - 1, w - 1] = True
    return masks[:2] + [empty] + masks[2:4] + [full, corner] + masks[4:] + \
        [posture_mask(rng.random((h, w)) < 0.6)]


def _expected(masks):
    """Each frame's words about the previous frame's reference (none at first)."""
    ref, words = PostureReference(0, 0, 0), []
    for mask in masks:
        registers = posture_registers(mask, ref)
        words.append(posture_words(registers, ref))
        ref = posture_reference(registers)
    return words


def _run(dut, masks, seed, idle=0.2, exact=False):
    """Stream the masks (non-real beats between frames, idle cycles); the next
    frame's first beat comes ``cycles_after_frame`` after the last (``exact``)
    or later. Returns the records and the cycle of each record's first word."""
    rng = np.random.default_rng(seed)
    layout = dut.i_stream.payload.shape()
    schedule = []
    for mask in masks:
        for k, v in enumerate(mask.ravel()):
            while rng.random() < idle:
                schedule.append(None)
            schedule.append(pack(layout, dict(pixel=int(v), real=1, first=int(k == 0))))
        gap = dut.cycles_after_frame - 1 + (0 if exact else int(rng.integers(0, 40)))
        for _ in range(gap):   # flush beats and idle cycles, as a window stage gives
            real_junk = rng.random() < 0.3
            schedule.append(pack(layout, dict(pixel=int(rng.integers(2)), real=0, first=0))
                            if real_junk else None)
    records, starts = [], []
    o = dut.o_stream

    async def tb(ctx):
        current = []
        for cycle, beat in enumerate(schedule + [None] * 8):
            ctx.set(dut.i_stream.valid, int(beat is not None))
            if beat is not None:
                ctx.set(dut.i_stream.payload.as_value(), beat)
            if ctx.get(o.valid):
                index, word = ctx.get(o.payload.index), ctx.get(o.payload.word)
                assert index == len(current)
                if not current:
                    starts.append(cycle)
                current.append(word)
                if len(current) == POSTURE_WORD_COUNT:
                    records.append(current)
                    current = []
            await ctx.tick()

    sim = Simulator(dut)
    sim.add_clock(1e-8)
    sim.add_testbench(tb)
    sim.run()
    return records, starts


@pytest.mark.parametrize("width, height, seed", [(24, 16, 1), (40, 30, 2), (8, 2, 3)])
def test_descriptor_equals_the_model_frame_after_frame(width, height, seed):
    dut = PostureDescriptor(width, height)
    masks = _masks(height, width, seed)
    records, _ = _run(dut, masks, seed)
    expected = _expected(masks)
    assert len(records) == len(masks)
    for k, (got, want) in enumerate(zip(records, expected)):
        assert got == want, (k, [i for i, (a, b) in enumerate(zip(got, want)) if a != b])


def test_next_frame_right_after_the_record_without_idle_cycles():
    width, height = 32, 20
    dut = PostureDescriptor(width, height)
    masks = _masks(height, width, 7, count=4)
    records, starts = _run(dut, masks, 7, idle=0.0, exact=True)
    assert records == _expected(masks)
    frame = dut.cycles_after_frame - 1 + width * height
    assert np.diff(starts).tolist() == [frame] * (len(masks) - 1)
    assert dut.cycles_after_frame == posture_cycles_after_frame()


@pytest.mark.parametrize("width, height, name", [(7, 10, "width"), (16, 1, "height"),
                                                  (5000, 10, "width")])
def test_bad_geometry_names_the_parameter(width, height, name):
    with pytest.raises(ValueError, match=name):
        PostureDescriptor(width, height)
