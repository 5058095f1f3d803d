# amaranth: UnusedElaboratable=no
"""hdl/synthesis.py: the ports of a component, the logic-depth figure of a mapped
netlist on hand-made netlists whose answer is known, and the real Yosys run
(the frame buffer's memory with its initialiser mapped to M10K)."""
from amaranth.hdl import Const
from amaranth.lib import stream, wiring
from amaranth.lib.wiring import In, Out

from hdl.synthesis import (ARITH_CI_CO_PS, ARITH_CI_SO_PS, ARITH_DATA_PS, CELL_DELAY_PS,
                           FF_CLOCK_TO_OUT_PS, M10K_CLOCK_TO_OUT_PS, WIRE_PS,
                           component_ports, critical_path)
from soc.frame_buffer import FrameBuffer


def _cell(kind, **ports):
    """A yosys JSON cell: ``ports`` maps a port name to (direction, bits)."""
    return {"type": kind, "connections": {p: bits for p, (_, bits) in ports.items()},
            "port_directions": {p: d for p, (d, _) in ports.items()}}


def _netlist(cells):
    return {"modules": {"top": {"cells": cells, "netnames": {
        "q": {"bits": [2]}, "a": {"bits": [3]}, "b": {"bits": [4]}}}}}


def test_critical_path_of_two_luts_between_flip_flops():
    # FF(q=2) -> LUT4(3) -> LUT6(4) -> FF.D, and a short path FF -> FF
    cells = {
        "ff0": _cell("MISTRAL_FF", CLK=("input", [1]), D=("input", [9]), Q=("output", [2])),
        "l1": _cell("MISTRAL_ALUT4", A=("input", [2]), Q=("output", [3])),
        "l2": _cell("MISTRAL_ALUT6", A=("input", [3]), B=("input", [2]), Q=("output", [4])),
        "ff1": _cell("MISTRAL_FF", CLK=("input", [1]), D=("input", [4]), Q=("output", [5])),
        "ff2": _cell("MISTRAL_FF", CLK=("input", [1]), D=("input", [5]), Q=("output", [9])),
    }
    report = critical_path(_netlist(cells), "top")
    ps = FF_CLOCK_TO_OUT_PS + 3 * WIRE_PS + CELL_DELAY_PS["MISTRAL_ALUT4"] \
        + CELL_DELAY_PS["MISTRAL_ALUT6"]
    assert report["depth_ns"] == round(ps / 1000, 2)
    assert report["levels"] == 2 and report["carry_cells"] == 0
    assert [p.split()[0] for p in report["path"]] == ["q", "a", "b"]


def test_critical_path_through_a_carry_chain_from_a_memory():
    # M10K(2) -> ARITH(data -> CO 3) -> ARITH(CI -> SO 4) -> FF
    cells = {
        "ram": _cell("MISTRAL_M10K", CLK1=("input", [1]), B1DATA=("output", [2])),
        "c0": _cell("MISTRAL_ALUT_ARITH", A=("input", [2]), CO=("output", [3])),
        "c1": _cell("MISTRAL_ALUT_ARITH", CI=("input", [3]), SO=("output", [4])),
        "ff": _cell("MISTRAL_FF", CLK=("input", [1]), D=("input", [4]), Q=("output", [5])),
    }
    report = critical_path(_netlist(cells), "top")
    ps = M10K_CLOCK_TO_OUT_PS + WIRE_PS + ARITH_DATA_PS + ARITH_CI_SO_PS + WIRE_PS
    assert report["depth_ns"] == round(ps / 1000, 2)
    assert report["carry_cells"] == 2 and report["levels"] == 1
    assert ARITH_CI_CO_PS < ARITH_CI_SO_PS      # the chain is cheap, its exit is not


def test_component_ports_leave_out_constants():
    class Dut(wiring.Component):
        def __init__(self):
            super().__init__({"i_stream": In(stream.Signature(8, always_ready=True)),
                              "flag": Out(1)})

        def elaborate(self, platform):
            raise NotImplementedError

    dut = Dut()
    ports = component_ports(dut)
    assert [p.name for p in ports] == ["i_stream__payload", "i_stream__valid", "flag"]
    assert not any(isinstance(p, Const) for p in ports)


def test_synthesize_maps_an_initialised_frame_buffer_to_m10k():
    """The real tool on a small frame buffer (one clock, as the estimate runs
    it): the 2048 x 4 memory with its initialiser becomes M10K, not logic."""
    from amaranth.hdl import DomainRenamer

    from hdl.synthesis import find_yosys, synthesize
    reports = []
    for autoname in (True, False):            # the estimate skips autoname
        fb = DomainRenamer({"vga": "sync"})(FrameBuffer(64, 32))
        report = synthesize(fb, "frame_buffer", find_yosys(), autoname=autoname)
        assert report["m10k"] == 1            # 8192 bits: one block (2048 x 5 mode)
        assert 0 < report["ffs"] < 200 and 0 < report["luts"] < 400
        reports.append({k: report[k] for k in ("luts", "ffs", "m10k", "mlab", "levels")})
    assert reports[0] == reports[1]
