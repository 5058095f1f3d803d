# amaranth: UnusedElaboratable=no
"""hdl/posture_descriptor.py: PostureDescriptor, word for word against
sim.model.posture (posture_registers about the previous frame's
posture_reference, posture_words), in Amaranth's simulator."""
import numpy as np
import pytest
from amaranth.sim import Simulator

from hdl.posture_descriptor import PostureDescriptor, posture_cycles_after_frame
from sim.model.posture import (PostureReference, next_reference, posture_mask,
                               posture_reference, posture_registers, posture_words)
from soc.hps_interface import POSTURE_WORD_COUNT
from sim.model.centroid import counted_pixels
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
    """Each frame's words about the reference predicted from the previous two
    frames' own (none at first)."""
    h, w = masks[0].shape
    own, words = [PostureReference(0, 0, 0)] * 2, []
    for mask in masks:
        ref = next_reference(own[-1], own[-2], w, h)
        registers = posture_registers(mask, ref)
        words.append(posture_words(registers, ref))
        own.append(posture_reference(registers))
    return words


def _run(dut, masks, seed, idle=0.2, exact=False, gates=None):
    """Stream the masks (non-real beats between frames, idle cycles); the next
    frame's first beat comes ``cycles_after_frame`` after the last (``exact``)
    or later. Returns the records and the cycle of each record's first word."""
    rng = np.random.default_rng(seed)
    layout = dut.i_stream.payload.shape()
    schedule, gate_at = [], {}
    for f, mask in enumerate(masks):
        if gates is not None and gates[f] is not None:
            gate_at[len(schedule) - 5] = gates[f]    # in the gap before the frame
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
            if gates is not None:
                gate = gate_at.get(cycle)
                ctx.set(dut.i_gate.valid, int(gate is not None))
                if gate is not None:
                    ctx.set(dut.i_gate.payload.x, gate[0])
                    ctx.set(dut.i_gate.payload.y, gate[1])
                    ctx.set(dut.i_gate.payload.hand, int(gate[2] > 0))
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


def test_the_window_about_the_previous_centroid():
    """Only pixels within ``gate`` of the centroid given between the frames count
    (the whole frame without a hand), as sim.model.centroid.counted_pixels."""
    width, height, gate = 40, 30, 7
    dut = PostureDescriptor(width, height, gate=gate)
    masks = _masks(height, width, 11)
    rng = np.random.default_rng(11)
    gates = [None] + [(int(rng.integers(width)), int(rng.integers(height)),
                       int(rng.integers(0, 3))) for _ in masks[1:]]
    gates[3] = (0, height - 1, 5)            # clipped at the frame's edges
    records, _ = _run(dut, masks, 11, gates=gates)
    windowed, latest = [], None
    for mask, g in zip(masks, gates):
        latest = g if g is not None else latest
        windowed.append(counted_pixels(mask, previous=latest, track_gate=gate))
    assert any((w != m).any() for w, m in zip(windowed, masks))
    assert records == _expected(windowed)


@pytest.mark.parametrize("width, height, gate, name", [
    (7, 10, 0, "width"), (16, 1, 0, "height"), (5000, 10, 0, "width"), (16, 10, -1, "gate"),
    (16, 10, 4096, "gate")])
def test_bad_parameters_name_the_parameter(width, height, gate, name):
    with pytest.raises(ValueError, match=name):
        PostureDescriptor(width, height, gate=gate)
