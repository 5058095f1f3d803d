# amaranth: UnusedElaboratable=no
"""hdl/opening.py: Opening, bit for bit against sim.model.morphology.opening."""
import pytest

from hdl.opening import Opening
from sim.model.morphology import opening
from tests.hdl_helpers import morphology_masks, run_morphology


@pytest.mark.parametrize("shape, size, w, h", [("cross", 11, 32, 16), ("square", 3, 24, 10)])
def test_opening(shape, size, w, h):
    dut = Opening(w, h, shape, size)
    r = size // 2
    assert dut.lag == 2 * (r * w + r)
    assert dut.memory_bits == 2 * ((size - 1) * (w - size))
    masks = morphology_masks(h, w, size)
    refs = [opening(mask, shape, size=size) for mask in masks]
    for ref, g in zip(refs, run_morphology(dut, masks, None, seed=2)):
        assert (g == ref).all()
    # the opening keeps some pixels and removes others
    assert all(ref.any() for ref in refs) and any((r != m_).any() for r, m_ in zip(refs, masks))


@pytest.mark.parametrize("make, name", [
    (lambda: Opening(16, 8, "diamond", 65), r"size must be in \[3, 63\]"),
])
def test_bad_parameters_name_the_parameter(make, name):
    with pytest.raises(ValueError, match=name):
        make()
