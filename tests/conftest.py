"""Scheduling of the tests on parallel workers (``make test`` runs pytest-xdist
with ``--dist loadfile``: each file on one worker, so a file's module fixtures
and Verilated or cocotb builds are made once, and no worker waits on another's
build lock).

The files with the longest runs are collected first, so that the workers take
them at the start and the short files fill the end (a long file started last
would leave the other worker idle).

Markers (docs/guides/ci.md gives each subset's time):

* ``simulation``: the hardware under simulation or synthesis (``test_hdl_*``,
  ``test_soc_*``, ``test_verif.py``, the cocotb benches): ``pytest -m simulation``;
* ``quick``: the rest but the files in :data:`NOT_QUICK` (benchmarks, soaks,
  the live page, the command line's end-to-end runs): ``pytest -m quick``.
"""
from __future__ import annotations

#: Longest first, as ``--durations`` ranked them in a run with a cold build cache.
SLOW_FILES = (
    "test_benchmarks.py",               # short runs of every benchmark and soak
    "test_hdl_pipeline_verilator.py",   # 640x480 pipeline build and clip, faults, stages
    "test_hdl_place_route.py",          # nextpnr routes
    "test_hdl_stereo_matcher.py",       # whole matcher in the Amaranth simulator
    "test_hdl_verilator.py",            # matcher builds, the full cones frame
    "test_soc_system.py",               # the Verilated system end to end
    "test_soc_generate.py",             # the Quartus bundle, core Verilog lint
    "test_hdl_shd.py",
    "test_hdl_morphology.py",
    "test_soc_ov5642_config.py",
    "test_hdl_gesture_pipeline.py",
)


#: Files outside the simulations that take minutes: not in ``-m quick``.
NOT_QUICK = (
    "test_benchmarks.py", "test_live.py", "test_cli.py", "test_cli_train.py",
    "test_bad_input.py", "test_footage.py", "test_shipped_models.py",
)


def is_simulation(name: str) -> bool:
    """Whether a test file runs the hardware (simulation, synthesis, place and route)."""
    return name.startswith(("test_hdl_", "test_soc_", "test_verif")) or "cocotb" in name


def pytest_configure(config):
    config.addinivalue_line("markers", "simulation: the hardware under simulation or "
                                       "synthesis (tests/conftest.py)")
    config.addinivalue_line("markers", "quick: the tests outside the simulations that take "
                                       "seconds (tests/conftest.py)")


def pytest_collection_modifyitems(config, items):
    import pytest
    for item in items:
        name = item.path.name
        if is_simulation(name) or "cocotb" in str(item.path.parent):
            item.add_marker(pytest.mark.simulation)
        elif name not in NOT_QUICK:
            item.add_marker(pytest.mark.quick)
    rank = {name: i for i, name in enumerate(SLOW_FILES)}
    items.sort(key=lambda item: rank.get(item.path.name, len(SLOW_FILES)))
