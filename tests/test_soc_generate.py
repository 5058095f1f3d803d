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

import dataclasses
import json
import re
import shutil
from fnmatch import fnmatchcase
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
SDC = ("create_clock", "get_ports", "get_clocks", "get_pins", "get_keepers",
       "derive_pll_clocks", "derive_clock_uncertainty", "set_clock_groups",
       "create_generated_clock", "set_max_skew", "set_net_delay", "set_input_delay",
       "set_output_delay", "set_false_path")
#: Stubs whose result is their argument (used inside [...]).
_PASS_THROUGH = ("get_ports", "get_clocks", "get_pins", "get_keepers")


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


def emitted(core, text):
    """:func:`soc.core.emit_core_verilog` faked: the core is elaborated (a second
    at 640x480), its Verilog (the slow part) is ``text``."""
    from amaranth.hdl import Fragment
    Fragment.get(core, None)
    return text


@pytest.fixture
def fast_core(monkeypatch, files):
    """Make :func:`soc.generate.generate` reuse the fixture's core Verilog."""
    import soc.core
    monkeypatch.setattr(soc.core, "emit_core_verilog",
                        lambda core: emitted(core, files[gen.CORE_FILE]))


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
    # HPS peripheral pins (DE1-SoC manual / Terasic golden top)
    assert locations["hps_io_0__sdio_inst_CLK__io"] == "A16"
    assert locations["hps_io_0__emac1_inst_TX_CLK__io"] == "H19"
    assert locations["hps_io_0__uart0_inst_TX__io"] == "C25"


def test_qsf_puts_each_pclk_on_a_global_clock(files):
    calls = run_tcl(files["stereogest.qsf"], QSF)
    promoted = {}
    for a in calls_of(calls, "set_instance_assignment"):
        name = a.index("-name")
        if a[name + 1] == "GLOBAL_SIGNAL":
            value = a[name + 2]
            promoted[a[a.index("-to") + 1]] = value
    assert promoted == {"ov5642_0__pclk__io": "GLOBAL CLOCK",
                        "ov5642_1__pclk__io": "GLOBAL CLOCK"}
    assert "not dedicated clock inputs" in (ROOT / "boards" / "README.md").read_text()


def test_qsf_and_build_script_make_the_rbf_the_hps_loads(bundle, files, tmp_path):
    """The HPS's FPGA manager configures by fast passive parallel; the .rbf's
    compression must match the MSEL switches, so both are built, and the README
    and the bring-up guide name the same files."""
    globals_ = {}
    for args in calls_of(run_tcl(files["stereogest.qsf"], QSF), "set_global_assignment"):
        globals_.setdefault(args[1], []).append(args[2])
    assert globals_["GENERATE_RBF_FILE"] == ["ON"]          # quartus_asm writes stereogest.rbf
    assert globals_["STRATIXV_CONFIGURATION_SCHEME"] == ["PASSIVE PARALLEL X16"]
    assert globals_["ON_CHIP_BITSTREAM_DECOMPRESSION"] == ["OFF"]

    # the build script with every Quartus tool replaced by one that logs its arguments
    work = tmp_path / "bundle"
    shutil.copytree(bundle.out_dir, work)
    bin_dir = tmp_path / "bin"
    bin_dir.mkdir()
    for tool in ("qsys-script", "qsys-generate", "quartus_map", "quartus_sta", "quartus_fit",
                 "quartus_asm", "quartus_cpf"):
        (bin_dir / tool).write_text('#!/bin/sh\necho "$(basename "$0") $*" >> calls.log\n')
        (bin_dir / tool).chmod(0o755)
    done = subprocess.run(["sh", gen.BUILD_SCRIPT], cwd=work, capture_output=True, text=True,
                          env={"PATH": f"{bin_dir}:/usr/bin:/bin"}, timeout=60)
    assert done.returncode == 0, done.stderr
    calls = (work / "calls.log").read_text().splitlines()
    assert calls[-1] == (f"quartus_cpf -c -o bitstream_compression=on stereogest.sof "
                         f"{gen.RBF_COMPRESSED}")
    assert calls.index("quartus_asm stereogest -c stereogest") < len(calls) - 1
    assert gen.RBF in done.stdout and gen.RBF_COMPRESSED in done.stdout
    # the handoff the preloader is built from: Quartus writes it while compiling
    assert f"warning: Quartus wrote no {gen.HANDOFF}" in done.stderr
    (bin_dir / "quartus_fit").write_text(f'#!/bin/sh\nmkdir -p {gen.HANDOFF}\n')
    done = subprocess.run(["sh", gen.BUILD_SCRIPT], cwd=work, capture_output=True, text=True,
                          env={"PATH": f"{bin_dir}:/usr/bin:/bin"}, timeout=60)
    assert done.returncode == 0 and "warning" not in done.stderr, done.stderr
    assert f"the HPS handoff for the preloader and U-Boot: {gen.HANDOFF}" in done.stdout

    readme = files["README.md"]
    guide = (ROOT / "docs" / "bring-up.md").read_text()
    for text in (readme, guide):
        for word in (gen.RBF, gen.RBF_COMPRESSED, "python3 -m sw_hps --check", "fpga load",
                     "bridge enable", "bridge_enable_handoff", "01010", "00000"):
            assert word in text, word
    assert "docs/bring-up.md" in readme and "BRINGUP.md" in readme


# ---- .sdc -----------------------------------------------------------------------------

def port_bits(ports):
    return {(name if width == 1 else f"{name}[{i}]"): direction
            for name, direction, width in ports for i in range(width)}


def run_sdc(text, top_ports):
    """Evaluate the .sdc with collection commands that match their patterns
    (Tcl ``string match``) against the top's port bits and the clocks defined
    so far; a pattern that matches nothing is an error. Returns the calls with
    each collection replaced by its members."""
    tcl = tkinter.Tcl()
    tcl.eval("set ::calls {}; set ::clocks {}")
    tcl.eval("set ::ports {" + " ".join(port_bits(top_ports)) + "}")
    tcl.eval("""
    proc match_all {what names patterns} {
        set out {}
        foreach p $patterns {
            set hit [lsearch -all -inline -glob $names $p]
            if {$hit eq {}} { error "$what: $p matches nothing" }
            lappend out {*}$hit
        }
        return $out
    }
    proc get_ports {patterns} { return [list PORTS {*}[match_all port $::ports $patterns]] }
    proc get_clocks {patterns} { return [list CLOCKS {*}[match_all clock $::clocks $patterns]] }
    proc get_pins {patterns} { return [list PINS {*}$patterns] }
    proc get_keepers {patterns} { return [list KEEPERS {*}$patterns] }
    proc record {name args} { lappend ::calls [list $name {*}$args] }
    proc create_clock {args} {
        record create_clock {*}$args
        lappend ::clocks [lindex $args [expr {[lsearch $args -name] + 1}]]
    }
    proc create_generated_clock {args} {
        record create_generated_clock {*}$args
        lappend ::clocks [lindex $args [expr {[lsearch $args -name] + 1}]]
    }
    # Quartus names each PLL output clock after its counter's output pin
    proc derive_pll_clocks {args} {
        record derive_pll_clocks {*}$args
        foreach n {0 1 2} { lappend ::clocks "pll|general\\[$n\\].gpll~PLL_OUTPUT_COUNTER|divclk" }
    }
    """)
    for name in SDC:
        if not tcl.eval(f"info procs {name}"):
            tcl.eval(f"proc {name} {{args}} {{ record {name} {{*}}$args }}")
    tcl.eval(text)
    calls = [list(tcl.splitlist(c)) for c in tcl.splitlist(tcl.eval("set ::calls"))]
    return calls, list(tcl.splitlist(tcl.eval("set ::clocks")))


_TCL = tkinter.Tcl()


def members(arg, kind):
    items = list(_TCL.splitlist(arg))
    assert items and items[0] == kind, arg
    return items[1:]


def test_sdc_clocks(files, top_ports):
    calls, clocks = run_sdc(files["stereogest.sdc"], top_ports)
    tclsh_runs(files["stereogest.sdc"], SDC)
    created = {}
    for args in calls_of(calls, "create_clock"):
        opts = dict(zip(args[:-1:2], args[1:-1:2]))
        created[opts["-name"]] = (float(opts["-period"]), members(args[-1], "PORTS"))
    assert created == {
        "clk50_0__io": (20.0, ["clk50_0__io"]),
        "ov5642_0__pclk__io": (20.0, ["ov5642_0__pclk__io"]),
        "ov5642_1__pclk__io": (20.0, ["ov5642_1__pclk__io"]),
    }
    assert calls_of(calls, "derive_pll_clocks") == [[]]
    assert calls_of(calls, "derive_clock_uncertainty") == [[]]
    # the DAC clock: the inverted VGA PLL output on the VGA_CLK pin
    (dac,) = calls_of(calls, "create_generated_clock")
    assert "-invert" in dac and members(dac[-1], "PORTS") == ["vga_0__clk__io"]
    assert members(dac[dac.index("-source") + 1], "PINS") == [gen.pll_clock_name("vga")]


def test_every_pair_of_clocks_is_asynchronous_or_related(files, top_ports):
    calls, clocks = run_sdc(files["stereogest.sdc"], top_ports)
    assert len(clocks) == 7          # oscillator, 2 PCLKs, 3 PLL outputs, DAC clock
    (groups_call,) = calls_of(calls, "set_clock_groups")
    assert groups_call[0] == "-asynchronous"
    groups = [members(groups_call[i + 1], "CLOCKS") for i, a in enumerate(groups_call)
              if a == "-group"]
    owner = {}
    for n, group in enumerate(groups):
        for clock in group:
            assert clock not in owner, f"{clock} in two groups"
            owner[clock] = n
    assert set(owner) == set(clocks), "a clock in no group"
    # related (same group) only where one is generated from the other
    related = {frozenset(g) for g in groups if len(g) > 1}
    assert related == {frozenset({"pll|general[1].gpll~PLL_OUTPUT_COUNTER|divclk",
                                  "vga_dac_clk"})}
    assert len(groups) == 6          # config, sync, vga (+DAC), xclk, both cameras


def test_every_top_level_port_is_constrained(files, top_ports):
    calls, _ = run_sdc(files["stereogest.sdc"], top_ports)
    clocks = set()
    for name in ("create_clock", "create_generated_clock"):
        for args in calls_of(calls, name):
            clocks |= set(members(args[-1], "PORTS"))
    delayed_in = {p for a in calls_of(calls, "set_input_delay") for p in members(a[-1], "PORTS")}
    delayed_out = {p for a in calls_of(calls, "set_output_delay")
                   for p in members(a[-1], "PORTS")}
    false_from, false_to = set(), set()
    for args in calls_of(calls, "set_false_path"):
        opts = dict(zip(args[::2], args[1::2]))
        false_from |= set(members(opts["-from"], "PORTS")) if "-from" in opts else set()
        false_to |= set(members(opts["-to"], "PORTS")) if "-to" in opts else set()
    # the DDR3 pins belong to the SDRAM interface's own SDC (qsys-generate)
    ddr = {p for p in port_bits(top_ports) if p.startswith("hps_ddr3_0__")}
    assert len(ddr) == sum(w for _, _, w in HPS_MEMORY_PORTS)
    assert "hps_sdram_p0.sdc" in files["stereogest.sdc"]
    for port, direction in port_bits(top_ports).items():
        if port in clocks or port in ddr:
            continue
        if direction in ("input", "inout"):
            assert port in delayed_in | false_from, f"{port}: input not constrained"
        if direction in ("output", "inout"):
            assert port in delayed_out | false_to, f"{port}: output not constrained"
    # camera data against PCLK (falling-edge launch), VGA data against the DAC clock
    for number in (0, 1):
        cam = [a for a in calls_of(calls, "set_input_delay")
               if members(a[a.index("-clock") + 1], "CLOCKS") == [f"ov5642_{number}__pclk__io"]]
        assert {a[a.index("-clock") + 3] for a in cam} == {"-max", "-min"}
        assert all("-clock_fall" in a for a in cam)
        assert f"ov5642_{number}__data__io[7]" in members(cam[0][-1], "PORTS")
    out = calls_of(calls, "set_output_delay")
    assert {float(a[-2]) for a in out} == {gen.ADV7123["setup"], -gen.ADV7123["hold"]}
    # nothing is false-pathed that has a delay
    assert not (delayed_in & false_from) and not (delayed_out & false_to)
    with pytest.raises(ValueError, match="mystery"):
        gen.sdc_constraints([*top_ports, ("mystery", "input", 1)], [])


def quartus_names(path, reg, bits):
    """The names Quartus may give a register of the core, with and without
    entity names in the hierarchy."""
    levels = ["soc", "stereogest_core_0", *path]
    with_entity = ["soc_system:soc", "stereogest_core:stereogest_core_0"] + [
        f"stereogest_core.{'.'.join(path[:i + 1])}:{p}" for i, p in enumerate(path)]
    return [f"{'|'.join(h)}|{reg}[{b}]" for h in (levels, with_entity) for b in range(bits)]


def test_every_async_fifo_gray_pointer_is_constrained(files, top_ports):
    core_v = files[gen.CORE_FILE]
    # the crossings, found here independently: every produce_cdc / consume_cdc
    fifos = re.findall(r"^module \\stereogest_core\.(\S+)\.(produce|consume)_cdc \(", core_v,
                       re.M)
    assert len(fifos) == 4, fifos            # two camera FIFOs, both pointers
    calls, _ = run_sdc(files["stereogest.sdc"], top_ports)
    periods = {"sync": 10.0, "cam_left": 20.0, "cam_right": 20.0}
    crossings = {(c.path, c.pointer): c for c in gen.async_fifo_crossings(core_v)}
    for path, pointer in fifos:
        path = tuple(path.split("."))
        c = crossings[path, pointer]
        assert {c.source, c.dest} in ({"sync", "cam_left"}, {"sync", "cam_right"})
        source = "produce_w_gry" if pointer == "produce" else "consume_r_gry"
        width = int(re.search(r"reg \[(\d+):0\] " + source, core_v)[1]) + 1
        src_names = quartus_names(path, source, width)
        dst_names = quartus_names((*path, f"{pointer}_cdc"), "stage0", width)
        for command, limit in (("set_max_skew", periods[c.source]),
                               ("set_net_delay", periods[c.dest])):
            hits = []
            for args in calls_of(calls, command):
                opts = dict(zip(args[:-1], args[1:]))
                src = members(opts["-from"], "KEEPERS")
                dst = members(opts["-to"], "KEEPERS")
                if all(any(fnmatchcase(n, p) for p in src) for n in src_names) and \
                        all(any(fnmatchcase(n, p) for p in dst) for n in dst_names):
                    hits.append(float(args[-1]))
            assert len(hits) == 1, (command, path, pointer)
            assert 0 < hits[0] < limit
    # the patterns are specific: none reaches the other FIFO or the other pointer
    sources = {(p, ptr): quartus_names(tuple(p.split(".")), "produce_w_gry" if ptr == "produce"
                                       else "consume_r_gry", 1) for p, ptr in fifos}
    for args in calls_of(calls, "set_max_skew"):
        (src,) = members(args[args.index("-from") + 1], "KEEPERS")
        assert sum(any(fnmatchcase(n, src) for n in names) for names in sources.values()) == 1


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
    assert set(conduits) == {"board", "left", "right", "left_i2c", "right_i2c",
                             "left_power", "right_power", "vga"}

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
    assert bases == {"stereogest_core_0.fifo": 0x0000, "stereogest_core_0.uart": 0x0100,
                     "stereogest_core_0.posture": 0x0200}
    # sw_hps: FIFO at the bridge base (default --bridge-offset 0), UART 0x100 above it
    assert LIGHTWEIGHT_BRIDGE_BASE + bases["stereogest_core_0.fifo"] == 0xFF200000
    assert run_default_uart_offset() == bases["stereogest_core_0.uart"]

    # every core conduit is exported, and the ports the board top connects on
    # soc_system are exactly those the exports will produce
    exports = {a[0]: a[2] for a in calls_of(calls, "set_interface_property")
               if a[1] == "EXPORT_OF"}
    conduits = {i.name for i in core_interfaces(core_ports) if i.kind == "conduit"}
    assert exports == {"clk": "clk_0.clk_in", "reset": "clk_0.clk_in_reset",
                       "memory": "hps_0.memory", "hps_io": "hps_0.hps_io",
                       "h2f_reset": "hps_0.h2f_reset",
                       **{f"core_{c}": f"stereogest_core_0.{c}" for c in conduits}}
    instance = re.search(r"^\s*soc_system\s+\S+\s*\((.*?)\);", files["stereogest.v"],
                         re.M | re.S)
    connected = set(re.findall(r"\.(\w+)\s*\(", instance[1]))
    predicted = {name for name, _, _ in soc_system_ports(core_ports)}
    assert connected == predicted
    assert {name for name, _, _ in HPS_MEMORY_PORTS} <= connected


def test_hps_peripherals_are_the_boards(files):
    """SD card, Ethernet, USB, UART, QSPI, SPI, I2C and GPIO on the HPS pins
    (Terasic's DE1-SoC reference design), each wired to a pin of the board."""
    from boards.de1_soc import HPS_IO_PINS
    calls = run_tcl(files[gen.SYSTEM_TCL], QSYS_SCRIPT)
    params = {a[1]: a[2] for a in calls_of(calls, "set_instance_parameter_value")
              if a[0] == "hps_0"}
    expected = {"SDIO": "4-bit Data", "EMAC1": "RGMII", "USB1": "SDR",
                "UART0": "No Flow Control", "QSPI": "1 SS", "SPIM1": "Single Slave Select",
                "I2C0": "I2C", "I2C1": "I2C"}
    for peripheral, mode in expected.items():
        assert params[f"{peripheral}_PinMuxing"] == "HPS I/O Set 0", peripheral
        assert params[f"{peripheral}_Mode"] == mode, peripheral
        # every enabled peripheral has pins on the board, and only those
        roles = [r for r in HPS_IO_PINS if r.startswith(f"{peripheral.lower()}_inst_")]
        assert roles, peripheral
    muxed = {k[:-len("_PinMuxing")] for k, v in params.items()
             if k.endswith("_PinMuxing") and v != "Unused"}
    assert muxed == set(expected)
    prefixes = {r.split("_inst_")[0] for r in HPS_IO_PINS}
    assert prefixes == {p.lower() for p in expected} | {"gpio"}
    gpio = params["GPIO_Enable"].split()
    assert len(gpio) == 100
    assert [i for i, v in enumerate(gpio) if v == "Yes"] == [9, 35, 40, 48, 53, 54, 61]
    assert {f"gpio_inst_GPIO{i:02d}" for i in (9, 35, 40, 48, 53, 54, 61)} <= set(HPS_IO_PINS)
    # the DE1-SoC's DDR3: two x16 chips (32 bits), 1 GB, 400 MHz, CL 11
    assert (params["MEM_DQ_WIDTH"], params["MEM_ROW_ADDR_WIDTH"], params["MEM_COL_ADDR_WIDTH"],
            params["MEM_BANKADDR_WIDTH"]) == ("32", "15", "10", "3")
    assert (params["MEM_CLK_FREQ"], params["MEM_TCL"], params["MEM_WTCL"]) == \
        ("400.0", "11", "8")
    assert params["eosc1_clk_mhz"] == "25.0"


def test_hps_io_reaches_its_pins_and_h2f_reset_the_reset_tree(files):
    top = files["stereogest.v"]
    body = top[top.index("module stereogest("):top.index("endmodule")]
    instance = re.search(r"^\s*soc_system\s+soc\s*\((.*?)\);", body, re.M | re.S)[1]
    connections = dict(re.findall(r"\.(\w+)\(([^()]*)\)", instance))
    from boards.de1_soc import HPS_IO_PINS
    for role in HPS_IO_PINS:
        assert connections[f"hps_io_hps_io_{role}"].strip() == f"hps_io_0__{role}__io", role
    # h2f_reset: follow the top module's assignments from the HPS's output
    reached = {connections["h2f_reset_reset_n"].strip()}
    assigns = re.findall(r"^\s*assign\s+(\S+)\s*=\s*(.*?);", body, re.M)
    for _ in range(len(assigns)):
        for lhs, rhs in assigns:
            if any(re.search(r"(?<![\w$])" + re.escape(n) + r"(?![\w$])", rhs) for n in reached):
                reached.add(lhs)
    assert connections["reset_reset_n"].strip() in reached      # the system's reset
    syncs = re.findall(r"^\s*\\stereogest\.(\w+)_reset_sync\s+\w+\s*\((.*?)\);", body,
                       re.M | re.S)
    assert {d for d, _ in syncs} == {"cam_left", "cam_right", "config", "vga", "xclk"}
    for domain, ports in syncs:
        (net,) = re.findall(r"\.board_reset\(([^()]*)\)", ports)
        assert net.strip() in reached, domain


def _top_body(files):
    top = files["stereogest.v"]
    return top[top.index("module stereogest("):top.index("endmodule")]


def _instance_ports(body, name):
    """Port -> net of the instance ``name`` in the top's body."""
    inst = re.search(r"^\s*\S+\s+" + re.escape(name) + r"\s*\((.*?)\);", body, re.M | re.S)
    return {port.strip(): net.strip()
            for port, net in re.findall(r"\.(\\?\S+?)\s*\(([^()]*)\)", inst[1])}


def test_system_reset_is_declared_as_the_top_drives_it(files):
    """The system's reset input is an asynchronous OR (KEY[0], the PLL's lock,
    the HPS's h2f_reset) with no register of the pipeline clock behind it, so
    the clock source must declare its edges ``NONE``: Platform Designer then
    synchronises it for the interconnect and the core. ``DEASSERT`` (the reset
    already released in step with the clock) would add no synchroniser."""
    from soc.platform_designer import SYSTEM_RESET_EDGES
    calls = run_tcl(files[gen.SYSTEM_TCL], QSYS_SCRIPT)
    params = {(a[0], a[1]): a[2] for a in calls_of(calls, "set_instance_parameter_value")}
    assert params["clk_0", "resetSynchronousEdges"] == SYSTEM_RESET_EDGES == "NONE"

    body = _top_body(files)
    soc_ports = _instance_ports(body, "soc")
    # the backward cone of the system's reset through the top's assignments
    assigns = dict(re.findall(r"^\s*assign\s+(\S+)\s*=\s*(.*?);", body, re.M))
    cone, todo = set(), [soc_ports["reset_reset_n"]]
    while todo:
        net = todo.pop()
        if net in cone:
            continue
        cone.add(net)
        if net in assigns:
            todo += re.findall(r"\\?[\w$.]+", assigns[net])
    registers = set(re.findall(r"^\s*reg\s+(?:\[[^\]]*\]\s*)?(\S+)", body, re.M))
    assert not cone & registers, "a register in the system reset's path: not asynchronous"
    # its sources: KEY[0]'s buffer, the PLL's lock, the HPS's h2f_reset, and
    # no reset synchroniser's output
    sources = {}
    for inst in ("key0_buf", "pll"):
        sources[inst] = set(_instance_ports(body, inst).values()) & cone
    assert sources["key0_buf"] and sources["pll"], sources
    assert soc_ports["h2f_reset_reset_n"] in cone
    for domain in ("cam_left", "cam_right", "config", "vga", "xclk"):
        synced = set(_instance_ports(body, f"{domain}_reset_sync").values())
        assert not (synced - {"board_reset"}) & cone, domain


def test_camera_power_pins_come_from_the_configuration_masters(files):
    """PWDN and RESETB of each camera are the core's ``*_power`` conduit
    (its configuration master's power-up sequence), not a reset of the top."""
    body = _top_body(files)
    soc_ports = _instance_ports(body, "soc")
    for number, (side, _) in CAMERA_HEADERS.items():
        for sig in ("pwdn", "reset_n"):
            buf = _instance_ports(body, f"{side}_{sig}_buf")
            assert buf[f"ov5642_{number}__{sig}__io"] == f"ov5642_{number}__{sig}__io"
            (data,) = [net for port, net in buf.items() if not port.endswith("__io")]
            assert data == soc_ports[f"core_{side}_power_{sig}"], (side, sig)


def test_qsf_weak_pull_ups_only_on_lines_that_are_read(files, top_ports):
    """The FPGA's weak pull-up on the I2C lines and the UART's input (they
    must not float), on no output (it would do nothing there)."""
    calls = run_tcl(files["stereogest.qsf"], QSF)
    pulled = {a[a.index("-to") + 1] for a in calls_of(calls, "set_instance_assignment")
              if a[a.index("-name") + 1].lower() == "weak_pull_up_resistor"
              and a[a.index("-name") + 2] == "ON"}
    assert pulled == {"ov5642_0__scl__io", "ov5642_0__sda__io", "ov5642_1__scl__io",
                      "ov5642_1__sda__io", "uart_0__rx__io"}
    directions = port_bits(top_ports)
    assert all(directions[name] in ("input", "inout") for name in pulled)


def test_readme_and_guide_give_the_steps_in_the_order_a_user_takes_them(files):
    """Generate, compile (Quartus writes the HPS handoff then), build the
    preloader and U-Boot from that handoff, then load the .rbf and release the
    bridge; the handoff is not qsys-generate's."""
    readme = files["README.md"]
    steps = [(int(n), text) for n, text in
             re.findall(r"^(\d+)\. (.*?)(?=^\d+\. |^## |\Z)", readme, re.M | re.S)]
    assert [n for n, _ in steps] == list(range(1, len(steps) + 1))

    def step_of(word):
        found = [n for n, text in steps if word in text]
        assert found, word
        return found[0]
    order = ["qsys-script", "qsys-generate", "quartus_map", "quartus_fit",
             "bsp-create-settings", "fpga load", "bridge enable"]
    assert [step_of(w) for w in order] == sorted(step_of(w) for w in order)
    # the handoff first appears with the compilation, the preloader after it
    assert step_of("quartus_fit") == step_of("hps_isw_handoff") \
        < step_of("bsp-create-settings") < step_of("fpga load")
    assert not re.search(r"handoff[^.]*qsys-generate writes", readme.replace("\n", " "))
    assert "during compilation" in readme.replace("\n", " ")

    guide = (ROOT / "docs" / "bring-up.md").read_text()
    headings = [h for h in re.findall(r"^## (.*)$", guide, re.M)]
    preloader = next(i for i, h in enumerate(headings) if "preloader" in h.lower())
    program = headings.index("Program the FPGA")
    assert preloader < program, headings
    section = guide[guide.index("## " + headings[preloader]):guide.index("## Program the FPGA")]
    assert "hps_isw_handoff" in section and "quartus_build.sh" in section


def test_core_verilog_is_compact(files):
    """The frame buffer (307,200 words) gets no initialiser: the core stays
    small enough for Quartus' analysis (12.3 MB before)."""
    core_v = files[gen.CORE_FILE]
    assert len(core_v) < 5_000_000, len(core_v)
    sizes = [len(b) for b in re.findall(r"initial begin\n.*?\n\s*end\n", core_v, re.S)]
    assert max(sizes) < 400_000, max(sizes)     # the ROMs keep theirs (270 kB)
    assert "(* stereogest_no_init = \"1\" *)" in core_v


def test_strip_zero_init_keeps_defined_contents():
    from soc.core import strip_zero_init
    zero = ('  (* stereogest_no_init = "1" *)\n  reg [3:0] mem [1:0];\n  initial begin\n'
            "    mem[0] = 4'h0;\n    mem[1] = 4'h0;\n  end\n")
    assert strip_zero_init(zero) == '  (* stereogest_no_init = "1" *)\n  reg [3:0] mem [1:0];\n'
    nonzero = zero.replace("mem[1] = 4'h0", "mem[1] = 4'h3")
    assert strip_zero_init(nonzero) == nonzero
    unmarked = zero.replace('(* stereogest_no_init = "1" *)', '(* keep = "1" *)')
    assert strip_zero_init(unmarked) == unmarked


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
    from verif.verilator import verilator_env
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
    (dict(scl_hz=0), r"scl_hz must be a number in \(0, 400000\] Hz"),
    (dict(scl_hz=1e6), "scl_hz"),
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
        emitted(core, "")
        raise RuntimeError("Verilog emission failed")
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
    marker = json.loads((tmp_path / "b" / gen.MARKER).read_text())
    assert marker["scl_hz"] == 400e3
    assert "SCL at most 400 kHz" in (tmp_path / "b" / "README.md").read_text()
    status, out, err = run(capsys, "generate", "--out", tmp_path / "c", "--width", "641")
    assert status == 2
    assert_one_line_error(err, "generate", "width")
    (tmp_path / "d").mkdir()
    (tmp_path / "d" / "x").write_text("")
    status, out, err = run(capsys, "generate", "--out", tmp_path / "d")
    assert status == 2
    assert_one_line_error(err, "generate", "not a stereogest bundle")


def test_cli_generate_hand_tracking_builds_the_tracking_centroid(tmp_path, capsys,
                                                                 monkeypatch, files):
    """--hand-tracking: the core gets the thesis parameters plus the centroid's
    hand tracking for its width, and the bundle's marker says so."""
    from amaranth.hdl import Fragment

    import soc.core
    from sim.model.pipeline import PipelineParams, hand_tracking_for
    cores = []

    def emit(core):
        cores.append(core)
        return emitted(core, files[gen.CORE_FILE])
    monkeypatch.setattr(soc.core, "emit_core_verilog", emit)
    for option, expected in ((["--hand-tracking"], hand_tracking_for(640)), ([], {})):
        out = tmp_path / ("t" if option else "p")
        status, _, err = run(capsys, "generate", "--out", out, "--quiet", *option)
        assert status == 0, err
        params = dataclasses.replace(PipelineParams(), **expected)
        assert cores[-1].params == params
        centroid = cores[-1].pipeline.stage("centroid")      # built alone, elaborated
        Fragment.get(centroid, None)
        assert centroid.track_gate == params.track_gate
        marker = json.loads((out / gen.MARKER).read_text())
        assert marker["hand_tracking"] == {"track_gate": params.track_gate,
                                           "hand_rows": params.hand_rows}
    assert hand_tracking_for(640)["track_gate"] > 0


def test_cli_generate_vga_scale_sets_the_frame_buffer(tmp_path, capsys, monkeypatch, files):
    """--vga-scale: the core's frame buffer at full or half resolution (half by
    default); the marker and the bundle's README say which."""
    import soc.core
    cores = []

    def emit(core):
        cores.append(core)
        return emitted(core, files[gen.CORE_FILE])
    monkeypatch.setattr(soc.core, "emit_core_verilog", emit)
    for option, scale, words in ((["--vga-scale", "1"], 1, 640 * 480),
                                 (["--vga-scale", "2"], 2, 320 * 240), ([], 2, 320 * 240)):
        out = tmp_path / f"s{len(cores)}"
        status, _, err = run(capsys, "generate", "--out", out, "--quiet", *option)
        assert status == 0, err
        assert cores[-1].frame_buffer.scale == scale
        assert cores[-1].frame_buffer.depth == words
        assert json.loads((out / gen.MARKER).read_text())["vga_scale"] == scale
        readme = (out / "README.md").read_text()
        assert ("half resolution" in readme) == (scale == 2)
        assert ("full resolution" in readme) == (scale == 1)


def test_cli_generate_scl_khz_reaches_both_configuration_masters(tmp_path, capsys,
                                                                monkeypatch, files):
    """--scl-khz 100: both cameras' I2C masters run at most 100 kHz (bit timing
    from the model's i2c_timing at 50 MHz); the marker and README say so."""
    import soc.core
    from sim.model.ov5642_config import i2c_timing
    cores = []

    def emit(core):
        cores.append(core)
        return emitted(core, files[gen.CORE_FILE])
    monkeypatch.setattr(soc.core, "emit_core_verilog", emit)
    out = tmp_path / "slow"
    status, _, err = run(capsys, "generate", "--out", out, "--quiet", "--scl-khz", "100")
    assert status == 0, err
    assert [c.timing for c in cores[-1].config] == [i2c_timing(50e6, 100e3)] * 2
    assert cores[-1].config[0].timing.period == 500
    assert json.loads((out / gen.MARKER).read_text())["scl_hz"] == 100e3
    assert "SCL at most 100 kHz" in (out / "README.md").read_text()


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
