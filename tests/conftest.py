"""Scheduling of the tests on parallel workers (``make test`` runs pytest-xdist
with ``--dist loadfile``: each file on one worker, so a file's module fixtures
and Verilated or cocotb builds are made once, and no worker waits on another's
build lock).

The files with the longest runs are collected first, so that the workers take
them at the start and the short files fill the end (a long file started last
would leave the other worker idle).
"""
from __future__ import annotations

#: Longest first, as ``--durations`` ranked them in a run with a cold build cache.
SLOW_FILES = (
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


def pytest_collection_modifyitems(config, items):
    rank = {name: i for i, name in enumerate(SLOW_FILES)}
    items.sort(key=lambda item: rank.get(item.path.name, len(SLOW_FILES)))
