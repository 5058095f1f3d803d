# amaranth: UnusedElaboratable=no
"""The Quartus / Platform Designer bundle (``stereogest generate``), checked as
far as it can be without Quartus: the .qsf names the device and pins every
top-level port, the .sdc clocks every clock input, the ``_hw.tcl`` ports are
the core's Verilog ports, the system script puts the slaves where ``sw_hps``
looks for them, every Tcl file runs under Tcl with the Quartus commands
stubbed, and both Verilog files lint clean under Verilator.

The bundle is generated once, at the thesis size 640x480 (module fixture,
most of this file's time: the core's elaboration). Tests that need further
bundles reuse that core's Verilog instead of elaborating the core again.
"""
from __future__ import annotations

import json
import re
import shutil
import subprocess
import time
import tkinter
from pathlib import Path

import pytest

from boards.de1_soc import CAMERA_HEADERS, CAMERA_PINS, StereogestDE1SoCPlatform, \
    header_gpio_index
from soc import generate as gen
from soc.platform_designer import AVALON_ROLES, HPS_MEMORY_PORTS, core_interfaces, \
    soc_system_ports, verilog_ports
from tests.cli_helpers import assert_one_line_error, run

ROOT = Path(__file__).resolve().parent.parent

# ---- Tcl with the Quartus / Platform Designer commands stubbed ----------------------

#: Commands each kind of Tcl file may use (anything else is an invalid command).
QSYS_HW = ("set_module_property", "add_fileset", "set_fileset_property", "add_fileset_file",
           "add_interface", "set_interface_property", "add_interface_port")
QSYS_SCRIPT = ("create_system", "set_project_property", "add_instance",
               "set_instance_parameter_value", "add_connection",
               "set_connection_parameter_value", "add_interface", "set_interface_property",
               "save_system")
QSF = ("set_global_assignment", "set_location_assignment", "set_instance_assignment")
SDC = ("create_clock", "get_ports", "get_clocks", "derive_pll_clocks",
       "derive_clock_uncertainty", "set_clock_groups")
#: Stubs whose result is their argument (used inside [...]).
_PASS_THROUGH = ("get_ports", "get_clocks")


def run_tcl(text: str, commands) -> list[list[str]]:
    """Evaluate ``text`` in a fresh Tcl interpreter where only ``commands`` are
    defined (as stubs recording their calls) and ``package require qsys``
    works; return the calls, each as [command, arg, ...]."""
    tcl = tkinter.Tcl()
    tcl.eval("package provide qsys 16.1; set ::calls {}")
    for name in commands:
        result = "return [lindex $args end]" if name in _PASS_THROUGH else 'return ""'
        tcl.eval(f"proc {name} {{args}} {{ lappend ::calls [list {name} {{*}}$args]; {result} }}")
    tcl.eval(text)
    return [list(tcl.splitlist(call)) for call in tcl.splitlist(tcl.eval("set ::calls"))]


def tclsh_runs(text: str, commands) -> None:
    """The same under the system's tclsh, a second interpreter (tkinter's Tcl,
    above, is the check that always runs)."""
    if shutil.which("tclsh") is None:
        return
    stubs = "".join(f"proc {name} {{args}} {{ return [lindex $args end] }}\n"
                    for name in commands)
    script = "package provide qsys 16.1\n" + stubs + text
    result = subprocess.run(["tclsh"], input=script, capture_output=True, text=True,
                            timeout=60)
    assert result.returncode == 0, result.stderr


def calls_of(calls, name):
    return [c[1:] for c in calls if c[0] == name]


# ---- the bundle, generated once -------------------------------------------------------

@pytest.fixture(scope="module")
def bundle(tmp_path_factory):
    out = tmp_path_factory.mktemp("bundle") / "de1soc"
    start = time.perf_counter()
    info = gen.generate(out)            # thesis size, 640x480
    seconds = time.perf_counter() - start
    print(f"\ngenerate 640x480: {seconds:.1f} s")
    return info


@pytest.fixture(scope="module")
def files(bundle):
    return {p.name: p.read_text() for p in bundle.out_dir.iterdir() if p.is_file()}


@pytest.fixture(scope="module")
def core_ports(files):
    return verilog_ports(files[gen.CORE_FILE], "stereogest_core")


@pytest.fixture(scope="module")
def top_ports(files):
    return verilog_ports(files["stereogest.v"], gen.PROJECT)


@pytest.fixture
def fast_core(monkeypatch, files):
    """Make :func:`soc.generate.generate` reuse the fixture's core Verilog."""
    import soc.core
    monkeypatch.setattr(soc.core, "emit_core_verilog", lambda core: files[gen.CORE_FILE])


def test_bundle_files(bundle, files):
    expected = {"README.md", "quartus_build.sh", "soc_system.tcl", "stereogest-bundle.json",
                "stereogest.qpf", "stereogest.qsf", "stereogest.sdc", "stereogest.srf",
                "stereogest.v", "stereogest_core.v", "stereogest_core_hw.tcl"}
    assert set(files) == expected == set(bundle.files)
    marker = json.loads(files[gen.MARKER])
    assert marker["generator"] == "stereogest generate"
    assert (marker["width"], marker["height"]) == (640, 480)
    assert gen.is_bundle(bundle.out_dir)
    # nothing half-written left beside the bundle
    assert [p.name for p in bundle.out_dir.parent.iterdir()] == [bundle.out_dir.name]
    subprocess.run(["sh", "-n", str(bundle.out_dir / gen.BUILD_SCRIPT)], check=True)
    assert "python3 -m sw_hps" in files["README.md"] and "--bus devmem --robot uart" \
        in files["README.md"]


# ---- .qsf -----------------------------------------------------------------------------

def test_qsf_device_and_every_port_has_a_pin(files, top_ports):
    calls = run_tcl(files["stereogest.qsf"], QSF)
    tclsh_runs(files["stereogest.qsf"], QSF)
    globals_ = {}
    for args in calls_of(calls, "set_global_assignment"):
        assert args[0] == "-name" and len(args) == 3, args
        globals_.setdefault(args[1], []).append(args[2])
    assert globals_["DEVICE"] == ["5CSEMA5F31C6"]
    assert globals_["FAMILY"] == ["Cyclone V"]
    assert globals_["TOP_LEVEL_ENTITY"] == ["stereogest"]
    assert globals_["VERILOG_FILE"] == ["stereogest.v"]
    assert globals_["SDC_FILE"] == ["stereogest.sdc"]
    assert globals_["QIP_FILE"] == ["soc_system/synthesis/soc_system.qip"]

    locations = {}
    for args in calls_of(calls, "set_location_assignment"):
        assert args[0] == "-to" and args[2].startswith("PIN_"), args
        assert args[1] not in locations, f"{args[1]} placed twice"
        locations[args[1]] = args[2][4:]
    bits = [name if width == 1 else f"{name}[{i}]"
            for name, _, width in top_ports for i in range(width)]
    assert sorted(locations) == sorted(bits)        # every top-level bit, nothing else
    pins = list(locations.values())
    assert len(set(pins)) == len(pins), "a pin is used twice"
    standards = {a[1] for a in calls_of(calls, "set_instance_assignment")
                 if a[2] == "-name" and a[3].lower() == "io_standard"}
    assert standards == set(bits)                   # every pin has an I/O standard

    # spot checks against the DE1-SoC manual / golden-top assignments
    assert locations["clk50_0__io"] == "AF14"
    assert locations["vga_0__r__io[0]"] == "A13" and locations["vga_0__b__io[7]"] == "J14"
    assert locations["vga_0__clk__io"] == "A11" and locations["vga_0__blank_n__io"] == "F10"
    assert locations["led_4__io"] == "W17"            # LEDR[4], gesture
    assert locations["hps_ddr3_0__ck_p__io"] == "M23"
    assert locations["hps_ddr3_0__dq__io[31]"] == "W29"
    assert locations["ov5642_0__pclk__io"] == "AC18"    # right camera, GPIO_0 pin 1
    assert locations["ov5642_1__pclk__io"] == "AB17"    # left camera, GPIO_1 pin 1


# ---- .sdc -----------------------------------------------------------------------------

def test_sdc_clocks_every_clock_input(files, top_ports):
    calls = run_tcl(files["stereogest.sdc"], SDC)
    tclsh_runs(files["stereogest.sdc"], SDC)
    clocks = {}
    for args in calls_of(calls, "create_clock"):
        opts = dict(zip(args[:-1:2], args[1:-1:2]))
        clocks[opts["-name"]] = (float(opts["-period"]), args[-1])
    inputs = {name for name, direction, _ in top_ports if direction == "input"}
    assert clocks == {
        "clk50_0__io": (20.0, "clk50_0__io"),
        "ov5642_0__pclk__io": (20.0, "ov5642_0__pclk__io"),
        "ov5642_1__pclk__io": (20.0, "ov5642_1__pclk__io"),
    }
    assert {target for _, target in clocks.values()} <= inputs
    assert calls_of(calls, "derive_pll_clocks") == [[]]
    assert calls_of(calls, "derive_clock_uncertainty") == [[]]
    groups = calls_of(calls, "set_clock_groups")
    assert sorted(g[-1] for g in groups) == ["ov5642_0__pclk__io", "ov5642_1__pclk__io"]
    assert all(g[0] == "-asynchronous" for g in groups)


# ---- the _hw.tcl component ------------------------------------------------------------

def test_hw_tcl_ports_are_the_core_verilog_ports(files, core_ports):
    calls = run_tcl(files[gen.HW_TCL], QSYS_HW)
    tclsh_runs(files[gen.HW_TCL], QSYS_HW)
    directions = {"Input": "input", "Output": "output", "Bidir": "inout"}
    declared = []
    for args in calls_of(calls, "add_interface_port"):
        assert len(args) == 5, args
        iface, port, role, direction, width = args
        declared.append((port, directions[direction], int(width)))
    assert declared and sorted(declared) == sorted(core_ports)

    interfaces = {a[0]: (a[1], a[2]) for a in calls_of(calls, "add_interface")}
    props = {}
    for iface, key, *value in calls_of(calls, "set_interface_property"):
        props.setdefault(iface, {})[key] = value[0] if value else None
    assert interfaces["clock"] == ("clock", "end") and interfaces["reset"] == ("reset", "end")
    roles = {}
    for iface, port, role, *_ in calls_of(calls, "add_interface_port"):
        roles.setdefault(iface, {})[role] = port
    assert roles["clock"] == {"clk": "clk"} and roles["reset"] == {"reset": "rst"}
    for slave, address_bits in (("fifo", 3), ("uart", 2)):
        assert interfaces[slave] == ("avalon", "end")
        assert set(roles[slave]) == set(AVALON_ROLES)
        p = props[slave]
        assert (p["addressUnits"], p["readLatency"], p["readWaitTime"], p["writeWaitTime"]) \
            == ("WORDS", "1", "0", "0")
        assert (p["associatedClock"], p["associatedReset"]) == ("clock", "reset")
        assert dict((port, w) for port, _, w in core_ports)[f"{slave}__address"] \
            == address_bits
    conduits = [i for i, (kind, _) in interfaces.items() if kind == "conduit"]
    assert set(conduits) == {"board", "left", "right", "left_i2c", "right_i2c", "vga"}

    module = {a[0]: a[1] for a in calls_of(calls, "set_module_property")}
    assert module["NAME"] == "stereogest_core"
    assert calls_of(calls, "add_fileset_file") == \
        [["stereogest_core.v", "VERILOG", "PATH", "stereogest_core.v", "TOP_LEVEL_FILE"]]
    assert ["QUARTUS_SYNTH", "TOP_LEVEL", "stereogest_core"] in \
        calls_of(calls, "set_fileset_property")
    assert re.search(r"^module stereogest_core\b", files[gen.CORE_FILE], re.M)


# ---- the system script ----------------------------------------------------------------

def test_system_tcl_puts_the_slaves_where_sw_hps_looks(files, core_ports, top_ports):
    from sw_hps.fifo import LIGHTWEIGHT_BRIDGE_BASE
    calls = run_tcl(files[gen.SYSTEM_TCL], QSYS_SCRIPT)
    tclsh_runs(files[gen.SYSTEM_TCL], QSYS_SCRIPT)
    assert calls[0] == ["create_system", "soc_system"]
    assert calls[-1] == ["save_system", "soc_system.qsys"]
    assert ["DEVICE", "5CSEMA5F31C6"] in calls_of(calls, "set_project_property")
    instances = {a[0]: a[1] for a in calls_of(calls, "add_instance")}
    assert instances == {"clk_0": "clock_source", "hps_0": "altera_hps",
                         "stereogest_core_0": "stereogest_core"}
    params = {(a[0], a[1]): a[2] for a in calls_of(calls, "set_instance_parameter_value")}
    assert params["hps_0", "LWH2F_Enable"] == "true"
    assert params["hps_0", "F2S_Width"] == params["hps_0", "S2F_Width"] == "0"
    assert params["hps_0", "SDIO_PinMuxing"] == "Unused"       # no hps_io conduit
    assert params["hps_0", "HPS_PROTOCOL"] == "DDR3"
    assert params["hps_0", "MEM_DQ_WIDTH"] == "32"      # 2 x16 chips, 1 GB
    assert params["hps_0", "MEM_ROW_ADDR_WIDTH"] == "15"
    assert float(params["clk_0", "clockFrequency"]) == 100e6

    connections = [tuple(a) for a in calls_of(calls, "add_connection")]
    assert ("clk_0.clk", "hps_0.h2f_lw_axi_clock") in connections
    assert ("clk_0.clk", "stereogest_core_0.clock") in connections
    assert ("clk_0.clk_reset", "stereogest_core_0.reset") in connections
    bases = {}
    for conn, key, value in calls_of(calls, "set_connection_parameter_value"):
        assert key == "baseAddress"
        master, slave = conn.split("/")
        assert master == "hps_0.h2f_lw_axi_master" and (master, slave) in connections
        bases[slave] = int(value, 16)
    assert bases == {"stereogest_core_0.fifo": 0x0000, "stereogest_core_0.uart": 0x0100}
    # sw_hps: FIFO at the bridge base (default --bridge-offset 0), UART 0x100 above it
    assert LIGHTWEIGHT_BRIDGE_BASE + bases["stereogest_core_0.fifo"] == 0xFF200000
    assert run_default_uart_offset() == bases["stereogest_core_0.uart"]

    # every core conduit is exported, and the ports the board top connects on
    # soc_system are exactly those the exports will produce
    exports = {a[0]: a[2] for a in calls_of(calls, "set_interface_property")
               if a[1] == "EXPORT_OF"}
    conduits = {i.name for i in core_interfaces(core_ports) if i.kind == "conduit"}
    assert exports == {"clk": "clk_0.clk_in", "reset": "clk_0.clk_in_reset",
                       "memory": "hps_0.memory",
                       **{f"core_{c}": f"stereogest_core_0.{c}" for c in conduits}}
    instance = re.search(r"^\s*soc_system\s+\S+\s*\((.*?)\);", files["stereogest.v"],
                         re.M | re.S)
    connected = set(re.findall(r"\.(\w+)\s*\(", instance[1]))
    predicted = {name for name, _, _ in soc_system_ports(core_ports)}
    assert connected == predicted
    assert {name for name, _, _ in HPS_MEMORY_PORTS} <= connected


def run_default_uart_offset() -> int:
    """``python -m sw_hps``'s default ``--uart-offset`` (from the FIFO's base)."""
    from sw_hps.__main__ import build_parser
    args = build_parser().parse_args(["--model", "m.json", "--bus", "devmem",
                                      "--robot", "uart"])
    assert args.bridge_offset == 0
    return args.uart_offset


# ---- Verilator lint -------------------------------------------------------------------

#: Stand-ins for the Intel primitives Amaranth's Intel platform instantiates and
#: the PLL; each declares every parameter the top passes (Verilator checks them).
PRIMITIVES = """
/* verilator lint_off UNUSEDSIGNAL */
/* verilator lint_off UNUSEDPARAM */
module altiobuf_in #(parameter enable_bus_hold = "FALSE", parameter number_of_channels = 1,
                     parameter use_differential_mode = "FALSE")
  (input [number_of_channels-1:0] datain, output [number_of_channels-1:0] dataout);
  assign dataout = datain;
endmodule
module altiobuf_out #(parameter enable_bus_hold = "FALSE", parameter number_of_channels = 1,
                      parameter use_differential_mode = "FALSE", parameter use_oe = "FALSE")
  (input [number_of_channels-1:0] datain, input [number_of_channels-1:0] oe,
   output [number_of_channels-1:0] dataout);
  assign dataout = datain;
endmodule
module altiobuf_bidir #(parameter enable_bus_hold = "FALSE", parameter number_of_channels = 1,
                        parameter use_differential_mode = "FALSE")
  (input [number_of_channels-1:0] datain, input [number_of_channels-1:0] oe,
   inout [number_of_channels-1:0] dataio, output [number_of_channels-1:0] dataout);
  genvar i;
  generate for (i = 0; i < number_of_channels; i = i + 1) begin : g
    assign dataio[i] = oe[i] ? datain[i] : 1'bz;
  end endgenerate
  assign dataout = dataio;
endmodule
module altddio_out #(parameter width = 1)
  (input [width-1:0] datain_h, input [width-1:0] datain_l, input outclock,
   output [width-1:0] dataout);
  assign dataout = outclock ? datain_h : datain_l;
endmodule
module altera_std_synchronizer #(parameter depth = 3)
  (input clk, input reset_n, input din, output reg dout);
  always @(posedge clk or negedge reset_n) dout <= !reset_n ? 1'b0 : din;
endmodule
module altera_std_synchronizer_bundle #(parameter width = 1, parameter depth = 3)
  (input clk, input reset_n, input [width-1:0] din, output reg [width-1:0] dout);
  always @(posedge clk or negedge reset_n) dout <= !reset_n ? {width{1'b0}} : din;
endmodule
module altera_pll #(parameter fractional_vco_multiplier = "false",
    parameter reference_clock_frequency = "", parameter operation_mode = "",
    parameter number_of_clocks = 1,
    parameter output_clock_frequency0 = "", parameter phase_shift0 = "",
    parameter duty_cycle0 = 50,
    parameter output_clock_frequency1 = "", parameter phase_shift1 = "",
    parameter duty_cycle1 = 50,
    parameter output_clock_frequency2 = "", parameter phase_shift2 = "",
    parameter duty_cycle2 = 50,
    parameter pll_type = "", parameter pll_subtype = "")
  (input refclk, input rst, input fbclk, output [number_of_clocks-1:0] outclk,
   output locked, output fboutclk);
  assign outclk = {number_of_clocks{refclk}};
  assign locked = !rst;
  assign fboutclk = fbclk;
endmodule
"""

#: Lint flags. -Wall, minus what Amaranth's Verilog style always shows: named
#: wires for signals the netlist no longer reads (UNUSEDSIGNAL), module names
#: with dots that match no file name (DECLFILENAME), ``reg x = init;``
#: declarations assigned in always blocks (PROCASSINIT, Amaranth's reset values)
#: and FSM ``casez`` without the state encodings that never occur
#: (CASEINCOMPLETE).
LINT_FLAGS = ["--lint-only", "-Wall", "-Wno-WIDTH", "-Wno-UNUSEDSIGNAL", "-Wno-DECLFILENAME",
              "-Wno-PROCASSINIT", "-Wno-CASEINCOMPLETE"]


def soc_system_stub(core_ports) -> str:
    """A ``soc_system`` with the ports qsys-generate will give it (no logic)."""
    decls = [f"  {d} wire {f'[{w - 1}:0] ' if w > 1 else ''}{n}"
             for n, d, w in soc_system_ports(core_ports)]
    return ("/* verilator lint_off UNUSEDSIGNAL */\n/* verilator lint_off UNDRIVEN */\n"
            "module soc_system(\n" + ",\n".join(decls) + "\n);\nendmodule\n")


def verilator(args, tmp_path):
    from hdl.verilator_sim import verilator_env
    result = subprocess.run(["verilator", *LINT_FLAGS, *args], cwd=tmp_path,
                            env=verilator_env(), capture_output=True, text=True, timeout=900)
    assert result.returncode == 0, result.stderr[-6000:]
    assert "%Warning" not in result.stderr and "%Error" not in result.stderr, result.stderr


def test_top_verilog_lints_clean(bundle, core_ports, tmp_path):
    # the soc_system stub has exactly the predicted ports: a port the top
    # connects that it lacks is an error, one the top leaves open a warning
    (tmp_path / "prims.v").write_text(PRIMITIVES)
    (tmp_path / "soc_system.v").write_text(soc_system_stub(core_ports))
    verilator(["--top-module", gen.PROJECT, str(bundle.out_dir / "stereogest.v"),
               "prims.v", "soc_system.v"], tmp_path)


def test_core_verilog_lints_clean(bundle, tmp_path):
    start = time.perf_counter()
    verilator(["--top-module", "stereogest_core", str(bundle.out_dir / gen.CORE_FILE)],
              tmp_path)
    print(f"\ncore lint: {time.perf_counter() - start:.1f} s")


# ---- the out directory ----------------------------------------------------------------

def test_refuses_a_foreign_directory(tmp_path):
    foreign = tmp_path / "mine"
    foreign.mkdir()
    (foreign / "notes.txt").write_text("keep me")
    with pytest.raises(ValueError, match="not empty and not a stereogest bundle"):
        gen.generate(foreign)
    assert [p.name for p in foreign.iterdir()] == ["notes.txt"]
    a_file = tmp_path / "file"
    a_file.write_text("x")
    with pytest.raises(ValueError, match="not a directory"):
        gen.generate(a_file)
    assert sorted(p.name for p in tmp_path.iterdir()) == ["file", "mine"]


@pytest.mark.parametrize("kwargs, word", [
    (dict(width=641), "width"), (dict(width=0), "width"), (dict(height=-4), "height"),
    (dict(width="640"), "width"), (dict(sync_hz=1e9), "sync_hz"),
    (dict(xclk_hz=50e6), "xclk_hz"), (dict(vga_hz=True), "vga_hz"),
])
def test_bad_parameters_raise_and_write_nothing(tmp_path, kwargs, word):
    with pytest.raises(ValueError, match=word):
        gen.generate(tmp_path / "out", **kwargs)
    assert list(tmp_path.iterdir()) == []


def test_replaces_a_previous_bundle_and_leaves_nothing_on_error(tmp_path, fast_core,
                                                                 monkeypatch):
    out = tmp_path / "bundle"
    out.mkdir()
    (out / gen.MARKER).write_text(json.dumps({"generator": "stereogest generate"}))
    (out / "stale.txt").write_text("from an earlier bundle")
    info = gen.generate(out)
    assert "stale.txt" not in {p.name for p in out.iterdir()}
    assert sorted(p.name for p in out.iterdir()) == sorted(info.files)
    assert [p.name for p in tmp_path.iterdir()] == ["bundle"]     # no temporary left

    import soc.core

    def broken(core):
        raise RuntimeError("elaboration failed")
    monkeypatch.setattr(soc.core, "emit_core_verilog", broken)
    with pytest.raises(RuntimeError):
        gen.generate(tmp_path / "other")
    with pytest.raises(RuntimeError):
        gen.generate(out)
    assert [p.name for p in tmp_path.iterdir()] == ["bundle"]
    assert sorted(p.name for p in out.iterdir()) == sorted(info.files)   # untouched


# ---- command line ---------------------------------------------------------------------

def test_cli_generate(tmp_path, capsys, fast_core):
    status, out, err = run(capsys, "generate", "--out", tmp_path / "b", "--quiet")
    assert status == 0, err
    summary = json.loads(out.strip().splitlines()[-1])
    assert summary["out"] == str(tmp_path / "b")
    assert "stereogest.qsf" in summary["files"] and (tmp_path / "b" / "stereogest.qsf").exists()
    status, out, err = run(capsys, "generate", "--out", tmp_path / "c", "--width", "641")
    assert status == 2
    assert_one_line_error(err, "generate", "width")
    (tmp_path / "d").mkdir()
    (tmp_path / "d" / "x").write_text("")
    status, out, err = run(capsys, "generate", "--out", tmp_path / "d")
    assert status == 2
    assert_one_line_error(err, "generate", "not a stereogest bundle")


# ---- board, parser, top ---------------------------------------------------------------

_SIGNAL = re.compile(r"PCLK|XCLK|VSYNC|HREF|SCL|SDA|RESETB|PWDN|D[2-9]")


def _pin_rows(text: str):
    """Rows (signal, header pin, GPIO index, GPIO_0 pin, GPIO_1 pin) of a camera
    pin table, markdown or reST."""
    rows = []
    for line in text.splitlines():
        cells = line.replace("|", " ").split()
        if len(cells) == 5 and _SIGNAL.fullmatch(cells[0]):
            rows.append(cells)
    return rows


def test_camera_pin_tables_match_the_platform():
    from boards import de1_soc
    platform = StereogestDE1SoCPlatform()
    names = {"PCLK": ("pclk", 0), "XCLK": ("xclk", 0), "VSYNC": ("vsync", 0),
             "HREF": ("href", 0), "SCL": ("scl", 0), "SDA": ("sda", 0),
             "RESETB": ("reset_n", 0), "PWDN": ("pwdn", 0),
             **{f"D{d}": ("data", d - 2) for d in range(2, 10)}}
    tables = {"README": (ROOT / "boards" / "README.md").read_text(),
              "docstring": de1_soc.__doc__}
    for where, text in tables.items():
        rows = _pin_rows(text)
        assert len(rows) == len(names) and {r[0] for r in rows} == set(names), where
        for signal, pin, index, gpio0, gpio1 in rows:
            sub, bit = names[signal]
            assert header_gpio_index(int(pin)) == int(index), (where, signal)
            assert CAMERA_PINS[sub].split()[bit] == pin, (where, signal)
            for number, fpga in ((0, gpio0), (1, gpio1)):
                resource = platform.lookup("ov5642", number)
                phys = next(s for s in resource.ios if s.name == sub).ios[0]
                assert phys.map_names(platform._conn_pins, resource)[bit] == fpga, \
                    (where, signal, number)
    assert CAMERA_HEADERS == {0: ("right", 0), 1: ("left", 1)}
    with pytest.raises(ValueError):
        header_gpio_index(29)


def test_verilog_ports_parser():
    ansi = """// comment with module fake(x);
    module m #(parameter W = 4) (input wire [3:0] a, b, output reg [7:0] c,
                                 inout d /* x */, (* keep *) input \\e.f );
    endmodule
    module other(q); input q; endmodule"""
    assert verilog_ports(ansi, "m") == [("a", "input", 4), ("b", "input", 4),
                                         ("c", "output", 8), ("d", "inout", 1),
                                         ("e.f", "input", 1)]
    old = "module x(a, b, c);\n input [0:2] a;\n output b, c;\n wire [3:0] w;\nendmodule"
    assert verilog_ports(old, "x") == [("a", "input", 3), ("b", "output", 1),
                                        ("c", "output", 1)]
    with pytest.raises(ValueError, match="found 0 times"):
        verilog_ports(old, "y")
    with pytest.raises(ValueError, match="no direction"):
        verilog_ports("module z(a, b); input a; endmodule", "z")


def test_board_top_rejects_a_port_it_cannot_wire(core_ports):
    from soc.board_top import BoardTop
    platform = StereogestDE1SoCPlatform()
    with pytest.raises(ValueError, match="mystery"):
        platform.prepare(BoardTop([*core_ports, ("mystery", "input", 1)]), "top")
    with pytest.raises(ValueError, match="xclk_hz"):
        BoardTop(core_ports, xclk_hz=48e6)
    with pytest.raises(ValueError, match="clk"):
        core_interfaces([p for p in core_ports if p[0] != "clk"])
