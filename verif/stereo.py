"""The StereoMatcher's Verilog under Verilator with the C++ harness
``verif/cpp/stereo_harness.cpp``: whole frames, no Python per cycle (cached
builds: :mod:`verif.verilator`).
"""
from __future__ import annotations

import hashlib
import json
import subprocess
import tempfile
from pathlib import Path

import numpy as np

from .verilator import (CPP, EMISSIONS, build_root, check_emission, simulation_verilog,
                        sources_digest, verilate)

__all__ = ["matcher_verilog", "build_matcher", "run_matcher", "HARNESS"]

HARNESS = CPP / "stereo_harness.cpp"
TOP = "stereo_matcher"


def matcher_ports(dut):
    return [dut.i_stream.valid, dut.i_stream.ready, dut.i_stream.payload.as_value(),
            dut.o_stream.valid, dut.o_stream.payload.as_value(), dut.threshold]


def matcher_verilog(dut, name: str = TOP, emission: str = EMISSIONS[0]) -> str:
    """Verilog text of a StereoMatcher for Verilator (:func:`simulation_verilog`)."""
    return simulation_verilog(dut, name, matcher_ports(dut), emission)


def _wrapper(dut, core: str) -> str:
    """A top module with plain port names (Verilator mangles Amaranth's ``__``)."""
    pb, db, tb = dut.pixel_bits, dut.disparity_bits, len(dut.threshold)
    return f"""
module {TOP}(input clk, input rst, input in_valid, output in_ready,
             input [{pb - 1}:0] in_left, input [{pb - 1}:0] in_right,
             input [{tb - 1}:0] threshold, output out_valid, output [{db - 1}:0] out_disparity);
  {core} core(.clk(clk), .rst(rst), .i_stream__valid(in_valid), .i_stream__ready(in_ready),
    .i_stream__payload({{in_right, in_left}}), .threshold(threshold),
    .o_stream__valid(out_valid), .o_stream__payload(out_disparity));
endmodule
"""


def _source_digest() -> str:
    return sources_digest(["hdl"], [HARNESS])


def build_matcher(jobs: int | None = None, log=None, emission: str = EMISSIONS[0],
                  **params) -> Path:
    """Build (or reuse) the Verilated harness of ``StereoMatcher(**params)``, its
    Verilog written as ``emission`` says; returns the executable's path."""
    from hdl.stereo_matcher import StereoMatcher
    # the parameters as given (numpy scalars as Python's): the matcher is built
    # for a new build only
    spec = {name: value.item() if isinstance(value, np.generic) else value
            for name, value in params.items()}
    spec["emission"] = check_emission(emission)
    key = hashlib.sha256(json.dumps(spec, sort_keys=True).encode()).hexdigest()[:12]
    folder = build_root() / f"{key}-{_source_digest()}"
    exe = folder / "obj_dir" / "stereo_harness"
    if exe.exists():
        return exe
    dut = StereoMatcher(**params)
    core = TOP + "_core"
    verilate(folder, f"{TOP}.v", matcher_verilog(dut, core, emission) + _wrapper(dut, core), spec,
             TOP, "stereo_harness", HARNESS, jobs=jobs, cflags="-O1", log=log)
    return exe


def run_matcher(pairs, *, threshold: int, idle_percent: int = 0, seed: int = 1,
                jobs: int | None = None, emission: str = EMISSIONS[0],
                **params) -> tuple[list[np.ndarray], dict]:
    """Disparity maps of ``pairs`` [(left, right), ...] (equal-sized 2-D arrays)
    through the Verilated matcher; returns the maps and the harness's statistics
    (cycles, outputs, seconds, cycles_per_second)."""
    h, w = np.shape(pairs[0][0])
    exe = build_matcher(jobs=jobs, emission=emission, width=w, height=h, **params)
    data = np.stack([np.stack([np.asarray(l), np.asarray(r)], axis=-1) for l, r in pairs])
    with tempfile.TemporaryDirectory() as tmp:
        src, dst = Path(tmp) / "in.bin", Path(tmp) / "out.bin"
        data.astype("<u2").tofile(src)
        proc = subprocess.run([str(exe), str(src), str(dst), str(len(pairs)), str(w * h),
                               str(threshold), str(idle_percent), str(seed)],
                              capture_output=True, text=True)
        if proc.returncode != 0:
            raise RuntimeError(f"harness failed ({proc.returncode}): {proc.stderr}{proc.stdout}")
        stats = json.loads(proc.stdout.strip().splitlines()[-1])
        out = np.fromfile(dst, dtype="<u2").astype(np.uint8)  # disparities < D <= 256
    maps = [out[k * w * h:(k + 1) * w * h].reshape(h, w) for k in range(len(pairs))]
    stats["exe"] = str(exe)
    return maps, stats
