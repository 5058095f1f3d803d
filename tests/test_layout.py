"""The layout rule of README's table: a block's hardware, model and test share
one name. Every module of ``hdl/``, ``soc/`` and ``sim/model/`` has its test
file ``tests/test_{hdl,soc,model}_<module>.py``, or is listed here with the test
files that cover it (each of which must name it); a private module drops its
underscore (``hdl/_util.py``: ``tests/test_hdl_util.py``)."""
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parent.parent
PACKAGES = {"hdl": "hdl", "soc": "soc", "sim/model": "model"}

#: Modules tested elsewhere: (package, module) -> the test files that cover them.
COVERED_ELSEWHERE = {
    ("soc", "board_top"): ["test_soc_generate.py"],  # the top level of the bundle
    ("soc", "platform_designer"): ["test_soc_generate.py"],
    ("sim/model", "orientation"): ["test_hps_orientation.py"],   # re-exports sw_hps's
}


def _modules():
    for package in PACKAGES:
        for path in sorted((ROOT / package).glob("*.py")):
            if path.stem != "__init__":
                yield package, path.stem


@pytest.mark.parametrize("package, module", list(_modules()),
                         ids=[f"{p}/{m}" for p, m in _modules()])
def test_every_module_has_its_test_file(package, module):
    own = ROOT / "tests" / f"test_{PACKAGES[package]}_{module.lstrip('_')}.py"
    if (package, module) not in COVERED_ELSEWHERE:
        assert own.exists(), f"{package}/{module}.py has no {own.name}"
        return
    assert not own.exists(), f"{own.name} exists: drop the entry in COVERED_ELSEWHERE"
    dotted = f"{package.replace('/', '.')}.{module}"
    for name in COVERED_ELSEWHERE[package, module]:
        text = (ROOT / "tests" / name).read_text()
        assert dotted in text or f"from {package.replace('/', '.')} import {module}" in text, \
            f"{name} does not name {dotted}"


def test_the_exemptions_are_modules():
    modules = set(_modules())
    assert set(COVERED_ELSEWHERE) <= modules
