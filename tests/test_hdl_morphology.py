# amaranth: UnusedElaboratable=no
"""hdl/morphology.py: BinaryMorphology, bit for bit against erode and dilate of
sim.model.morphology."""
import numpy as np
import pytest

from hdl.morphology import BinaryMorphology
from sim.model.morphology import dilate, erode
from tests.hdl_helpers import morphology_masks, run_morphology


@pytest.mark.parametrize("shape", ["cross", "square", "diamond"])
@pytest.mark.parametrize("size", [3, 5, 7, 11])
@pytest.mark.parametrize("op", ["erode", "dilate"])
def test_binary_morphology(shape, size, op):
    w, h = max(12, size + 2), 9
    dut = BinaryMorphology(w, h, shape, size)
    masks = morphology_masks(h, w, size * 7 + len(shape))
    if op == "dilate":
        masks[1] = ~masks[1]  # sparse: dilation's borders matter
    got = run_morphology(dut, masks, int(op == "dilate"), seed=size)
    model = erode if op == "erode" else dilate
    for mask, g in zip(masks, got):
        ref = model(mask, shape, size=size)
        assert (g == ref).all()
    # the operation changes the masks (the comparison is not trivially equal)
    assert any((model(m_, shape, size=size) != m_).any() for m_ in masks)


def test_binary_morphology_explicit_asymmetric_element():
    # An asymmetric element catches a reflected window; 1x1 is the identity.
    element = np.array([[1, 1, 0, 0, 0], [0, 0, 0, 0, 1], [0, 0, 1, 0, 0],
                        [0, 0, 0, 0, 0], [0, 1, 0, 0, 0]], bool)
    w, h = 14, 8
    masks = morphology_masks(h, w, 3)
    for select, model in ((0, erode), (1, dilate)):
        dut = BinaryMorphology(w, h, element)
        assert dut.size == 5 and dut.taps == 5 and dut.tree_levels == 1
        for mask, g in zip(masks, run_morphology(dut, masks, select, seed=select)):
            assert (g == model(mask, element)).all()
    dut = BinaryMorphology(w, h, np.ones((1, 1), bool))
    assert dut.lag == 0
    for mask, g in zip(masks, run_morphology(dut, masks, 1, seed=5)):
        assert (g == mask).all()


@pytest.mark.parametrize("make, name", [
    (lambda: BinaryMorphology(24, 12, "disc"), r"element must be one of"),
    (lambda: BinaryMorphology(24, 12, "cross", 4), r"size must be odd in \[3, 63\]"),
    (lambda: BinaryMorphology(24, 12, np.ones((2, 2), bool)), r"element must be a square array"),
    (lambda: BinaryMorphology(24, 12, np.zeros((3, 3), bool)), r"element must contain"),
    (lambda: BinaryMorphology(12, 12, "square", 11), r"width must be in \[13, 4096\]"),
])
def test_bad_parameters_name_the_parameter(make, name):
    with pytest.raises(ValueError, match=name):
        make()
