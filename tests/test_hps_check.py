"""``python -m sw_hps --check``, the bridge state read from the HPS's reset and
FPGA managers (sw_hps.bridge) and the start-up preflight, against a fake
``/dev/mem``: a sparse file whose words at the HPS's physical addresses are
what the registers would read, mapped by the same code as on the board."""
from __future__ import annotations

import argparse
import io
import logging
import os
import subprocess
import sys
from pathlib import Path

import pytest

import sw_hps
from soc.hps_interface import (CONTROL, CORE_MAGIC, CORE_REVISION, CTRL_NO_GESTURE, ID,
                               LIGHTWEIGHT_BRIDGE_BASE, LONGITUD_X, LONGITUD_Y, VERSION,
                               version_word)
from sw_hps import __main__ as cli
from sw_hps import check as check_module
from sw_hps.bridge import (BRGMODRST, BRGMODRST_LWHPS2FPGA, FPGA_MANAGER_BASE, FPGAMGR_STAT,
                           RESET_MANAGER_BASE, USER_MODE, BridgeState, read_bridge_state)
from sw_hps.check import needed_span, preflight_bridge, run_check

MODEL = Path(sw_hps.__file__).parent / "models" / "thesis7.json"
#: What Terasic's images leave in brgmodrst once U-Boot released the bridges.
BRIDGES_OUT_OF_RESET = 0x0
#: stat: MSEL 01010 (FPP x32, compressed) and user mode.
STAT_USER_MODE = (0b01010 << 3) | USER_MODE
ALL_BRIDGES_IN_RESET = 0x7


class FakeDevMem:
    """A sparse file standing for /dev/mem: 32-bit words at physical addresses."""

    def __init__(self, path: Path):
        self.path = path
        with open(path, "wb") as handle:
            handle.truncate(RESET_MANAGER_BASE + 0x1000)   # the highest page used

    def poke(self, address: int, value: int) -> None:
        with open(self.path, "r+b") as handle:
            handle.seek(address)
            handle.write((value & 0xFFFFFFFF).to_bytes(4, "little"))

    def peek(self, address: int) -> int:
        with open(self.path, "rb") as handle:
            handle.seek(address)
            return int.from_bytes(handle.read(4), "little")

    def hps(self, brgmodrst: int, stat: int) -> "FakeDevMem":
        self.poke(RESET_MANAGER_BASE + BRGMODRST, brgmodrst)
        self.poke(FPGA_MANAGER_BASE + FPGAMGR_STAT, stat)
        return self

    def core(self, magic: int = CORE_MAGIC, version: int = None, control: int = CTRL_NO_GESTURE,
             lengths=(0, 0), base: int = LIGHTWEIGHT_BRIDGE_BASE) -> "FakeDevMem":
        self.poke(base + ID, magic)
        self.poke(base + VERSION, version_word() if version is None else version)
        self.poke(base + CONTROL, control)
        self.poke(base + LONGITUD_X, lengths[0])
        self.poke(base + LONGITUD_Y, lengths[1])
        return self


@pytest.fixture
def devmem(tmp_path):
    return FakeDevMem(tmp_path / "mem")


def check_args(**overrides):
    values = dict(bus="devmem", bridge_offset=0, uio="/dev/uio0", uart_offset=0x100,
                  robot_kind="none", model=None, spotting="thesis")
    values.update(overrides)
    return argparse.Namespace(**values)


def run(args, devmem=None, **kwargs):
    """(exit status, {name: value}, [problem lines], verdict) of one check."""
    out = io.StringIO()
    if devmem is not None:
        kwargs.setdefault("mem_path", str(devmem.path))
    status = run_check(args, out, window_span=cli.WINDOW_SPAN, **kwargs)
    values, problems = {}, []
    for line in out.getvalue().splitlines():
        name, _, value = line.partition(": ")
        if name == "problem":
            problems.append(value)
        else:
            assert name not in values, line
            values[name] = value
    assert "Traceback" not in out.getvalue()
    return status, values, problems, values["verdict"]


# ---- sw_hps.bridge ---------------------------------------------------------------------------
def test_bridge_state_decodes_the_two_registers():
    ready = BridgeState(brgmodrst=BRIDGES_OUT_OF_RESET, fpga_stat=STAT_USER_MODE)
    assert ready.safe and ready.user_mode and not ready.lw_bridge_in_reset
    assert ready.problems() == [] and ready.fix() == ""
    assert ready.msel == 0b01010 and ready.scheme == (32, True, False)
    assert "FPP x32, compressed .rbf" in ready.describe_msel()
    assert "user mode" in ready.describe() and "out of reset" in ready.describe()
    # only the lightweight bridge's bit matters: the other two bridges may stay in reset
    assert BridgeState(brgmodrst=0b101, fpga_stat=STAT_USER_MODE).safe

    in_reset = BridgeState(brgmodrst=ALL_BRIDGES_IN_RESET, fpga_stat=STAT_USER_MODE)
    assert in_reset.lw_bridge_in_reset and not in_reset.safe
    [line] = in_reset.problems()
    assert "held in reset" in line and "bridge enable" in line and "; fix: " in line

    unconfigured = BridgeState(brgmodrst=ALL_BRIDGES_IN_RESET, fpga_stat=0b00000 << 3 | 1)
    assert unconfigured.fpga_mode_name == "reset phase" and not unconfigured.safe
    first, second = unconfigured.problems()
    assert first.startswith("FPGA not in user mode (reset phase, MSEL 00000 (FPP x16, "
                            "uncompressed .rbf)")
    assert "held in reset" in second
    assert unconfigured.fix().startswith("load the FPGA")       # the FPGA before the bridge


@pytest.mark.parametrize("mode,name", [(0, "powered off"), (1, "reset phase"),
                                       (2, "configuration phase"), (3, "initialization phase"),
                                       (4, "user mode"), (5, "undetermined"),
                                       (7, "reserved mode 7")])
def test_bridge_state_names_every_mode(mode, name):
    assert BridgeState(brgmodrst=0, fpga_stat=mode).fpga_mode_name == name


def test_bridge_state_msel_the_hps_cannot_use():
    state = BridgeState(brgmodrst=0, fpga_stat=(0b10010 << 3) | USER_MODE)   # AS x1
    assert state.scheme is None and "cannot load an .rbf" in state.describe_msel()


def test_read_bridge_state_maps_the_hps_registers(devmem):
    devmem.hps(brgmodrst=BRGMODRST_LWHPS2FPGA, stat=STAT_USER_MODE)
    state = read_bridge_state(str(devmem.path))
    assert state == BridgeState(brgmodrst=BRGMODRST_LWHPS2FPGA, fpga_stat=STAT_USER_MODE)


def test_read_bridge_state_reads_only_the_two_words():
    opened = []

    class Window:
        def __init__(self, address, span):
            opened.append((address, span))
            self.closed = False

        def read32(self, offset):
            assert offset == 0
            return {RESET_MANAGER_BASE + BRGMODRST: 0, FPGA_MANAGER_BASE: 4}[opened[-1][0]]

        def close(self):
            self.closed = True

    assert read_bridge_state(open_window=Window).safe
    assert opened == [(0xFFD0501C, 4), (0xFF706000, 4)]


# ---- --check against the fake /dev/mem -------------------------------------------------------
def test_check_core_ok(devmem):
    devmem.hps(BRIDGES_OUT_OF_RESET, STAT_USER_MODE).core(lengths=(3, 3))
    status, values, problems, verdict = run(check_args(), devmem)
    assert status == 0 and problems == []
    assert verdict == f"OK: stereogest core, register-map revision {CORE_REVISION}, " \
                      f"answers at 0xff200000"
    assert values["python"] == ".".join(map(str, sys.version_info[:3]))
    assert values["FPGA manager"].startswith("user mode, MSEL 01010 (FPP x32, compressed")
    assert values["lightweight bridge"] == "out of reset (brgmodrst 0x0)"
    assert values["ID"] == "0x53475354" and values["Longitud_X"] == "3"
    assert values["Control"].startswith("0x00000004 (GO 0, FIFO data 0, no gesture 1,")
    assert "revision 2" in values["core"] and "640x480" in values["core"]


def test_check_reads_no_register_that_pops():
    """Dato_X/Dato_Y are never read and nothing is written: the check runs beside
    the application."""
    from sw_hps.bus import SimBus
    from sw_hps.simulated import SimulatedFifoPeripheral

    class Recorder(SimBus):
        def __init__(self):
            super().__init__(SimulatedFifoPeripheral())
            self.offsets = []

        def read32(self, offset):
            self.offsets.append(offset)
            return super().read32(offset)

        def write32(self, offset, value):
            raise AssertionError("the check writes nothing")

    bus = Recorder()
    magic, version, control, length_x, length_y = check_module._read_words(bus)
    assert sorted(set(bus.offsets)) == [CONTROL, LONGITUD_X, LONGITUD_Y, ID, VERSION]
    assert (magic, version, control) == (CORE_MAGIC, version_word(), CTRL_NO_GESTURE)


def test_check_survives_a_bus_error(tmp_path, monkeypatch, capfd):
    """A real SIGBUS: the uio device (a file) shrinks to nothing after it was
    mapped, so the next read of the mapping faults; the check reports it."""
    device, sysfs = fake_uio(tmp_path)
    real = check_module.UioBus

    def shrinking(path, *args, **kwargs):
        bus = real(path, *args, **kwargs)
        os.truncate(path, 0)
        return bus
    monkeypatch.setattr(check_module, "UioBus", shrinking)
    status, values, [problem], verdict = run(check_args(bus="uio", uio=str(device)),
                                             mem_path=str(tmp_path / "no-mem"),
                                             sysfs=str(sysfs))
    assert status == 1 and verdict.startswith("FAIL") and "ID" not in values
    assert problem.startswith(f"reading the core's registers at 0xff200000 ({device}) "
                              f"ended in SIGBUS")
    assert "; fix: " in problem
    assert capfd.readouterr().err == ""        # the faulting child died silently


@pytest.fixture
def no_bridge_access(monkeypatch):
    """Fails the test if the check maps the lightweight bridge."""
    def refuse(*args, **kwargs):
        raise AssertionError("the bridge was mapped")
    monkeypatch.setattr(check_module, "DevMemBus", refuse)


def test_check_bridge_in_reset_reads_no_register(devmem, no_bridge_access):
    devmem.hps(ALL_BRIDGES_IN_RESET, STAT_USER_MODE).core()
    status, values, problems, verdict = run(check_args(), devmem)
    assert status == 1 and verdict == "FAIL (1 problem above)"
    [problem] = problems
    assert problem.startswith("lightweight HPS-to-FPGA bridge held in reset (brgmodrst 0x7)")
    assert "bridge enable" in problem and "bridge_enable_handoff" in problem
    assert values["core registers"].startswith("not read")
    assert "ID" not in values


@pytest.mark.parametrize("mode", [0, 1, 2, 3, 5])
def test_check_fpga_not_configured(devmem, no_bridge_access, mode):
    devmem.hps(BRIDGES_OUT_OF_RESET, (0b00000 << 3) | mode)
    status, values, problems, verdict = run(check_args(), devmem)
    assert status == 1
    [problem] = problems
    assert problem.startswith("FPGA not in user mode") and "stereogest.rbf" in problem
    assert "FPP x16, uncompressed .rbf" in problem
    assert values["FPGA manager"].startswith(BridgeState(0, mode).fpga_mode_name)


@pytest.mark.parametrize("magic,words", [
    (0x12345678, ["no stereogest core at 0xff200000", "0x12345678", "0x53475354"]),
    (0xFFFFFFFF, ["ID reads all ones at 0xff200000", "bridge"]),
    (0x00000000, ["ID reads 0 at 0xff200000", "reset"]),
])
def test_check_magic_wrong(devmem, magic, words):
    devmem.hps(BRIDGES_OUT_OF_RESET, STAT_USER_MODE).core(magic=magic, version=magic)
    status, values, problems, verdict = run(check_args(), devmem)
    assert status == 1 and verdict.startswith("FAIL")
    [problem] = problems
    for word in words:
        assert word in problem
    assert "; fix: " in problem and "core" not in values   # no decoding of a foreign word


def test_check_other_revision(devmem):
    devmem.hps(BRIDGES_OUT_OF_RESET, STAT_USER_MODE).core(
        version=version_word(revision=CORE_REVISION + 1))
    status, _, [problem], _ = run(check_args(), devmem)
    assert status == 1
    assert f"revision {CORE_REVISION + 1}" in problem and f"needs revision {CORE_REVISION}" \
        in problem


def test_check_continuous_spotting_needs_streaming(devmem):
    devmem.hps(BRIDGES_OUT_OF_RESET, STAT_USER_MODE).core(version=version_word(streaming=False))
    assert run(check_args(), devmem)[0] == 0
    status, _, [problem], _ = run(check_args(spotting="continuous"), devmem)
    assert status == 1 and "streaming" in problem


def test_check_bridge_offset(devmem):
    devmem.hps(BRIDGES_OUT_OF_RESET, STAT_USER_MODE).core(base=LIGHTWEIGHT_BRIDGE_BASE + 0x400)
    assert run(check_args(), devmem)[0] == 1          # nothing at the default offset
    status, _, _, verdict = run(check_args(bridge_offset=0x400), devmem)
    assert status == 0 and verdict.endswith("answers at 0xff200400")


def test_check_devmem_missing_or_denied(tmp_path, monkeypatch):
    status, _, [problem], _ = run(check_args(), mem_path=str(tmp_path / "mem"))
    assert status == 1 and "no such device" in problem and "--bus uio" in problem

    def denied(path, flags, *args):
        raise PermissionError(13, "Permission denied", path)
    monkeypatch.setattr(os, "open", denied)
    status, _, [problem], _ = run(check_args(), mem_path=str(tmp_path / "mem"))
    assert status == 1 and "permission denied" in problem and "root" in problem


def test_check_validates_a_model_file_when_given(devmem, tmp_path):
    devmem.hps(BRIDGES_OUT_OF_RESET, STAT_USER_MODE).core()
    status, values, _, _ = run(check_args(model=str(MODEL)), devmem)
    assert status == 0 and "7 classes" in values["model"]
    bad = tmp_path / "bad.json"
    bad.write_text("{")
    status, _, [problem], _ = run(check_args(model=str(bad)), devmem)
    assert status == 1 and problem.startswith("model file: ") and "bad.json" in problem


def test_check_sim_bus():
    status, values, problems, verdict = run(check_args(bus="sim"))
    assert status == 0 and problems == [] and verdict.endswith("the simulated bus")


# ---- --check on a uio device: a plain file and a fake sysfs tree -----------------------------
def fake_uio(tmp_path, size=0x1000, name="stereogest", addr=LIGHTWEIGHT_BRIDGE_BASE):
    sysfs = tmp_path / "sys"
    maps = sysfs / "uio3" / "maps" / "map0"
    maps.mkdir(parents=True)
    (sysfs / "uio3" / "name").write_text(name + "\n")
    (maps / "addr").write_text(f"{addr:#010x}\n")
    (maps / "size").write_text(f"{size:#010x}\n")
    (maps / "offset").write_text("0x0\n")
    device = tmp_path / "uio3"
    with open(device, "wb") as handle:
        handle.truncate(0x1000)
    with open(device, "r+b") as handle:
        for offset, value in ((ID, CORE_MAGIC), (VERSION, version_word()),
                              (CONTROL, CTRL_NO_GESTURE)):
            handle.seek(offset)
            handle.write(value.to_bytes(4, "little"))
    return device, sysfs


def test_check_uio_core_ok(tmp_path):
    device, sysfs = fake_uio(tmp_path)
    status, values, problems, verdict = run(
        check_args(bus="uio", uio=str(device)), mem_path=str(tmp_path / "no-mem"),
        sysfs=str(sysfs))
    assert status == 0, problems
    assert values["bus"] == f"uio: {device} = uio3 'stereogest', map 0 at 0xff200000, " \
                            f"0x1000 bytes"
    assert values["HPS registers"].startswith("not read (")     # no root: only a note
    assert verdict.endswith(f"answers at 0xff200000 ({device})")


def test_check_uio_map_too_small_for_the_uart(tmp_path):
    device, sysfs = fake_uio(tmp_path, size=0x20)
    args = check_args(bus="uio", uio=str(device))
    assert run(args, mem_path=str(tmp_path / "no-mem"), sysfs=str(sysfs))[0] == 0
    status, _, [problem], _ = run(check_args(bus="uio", uio=str(device), robot_kind="uart"),
                                  mem_path=str(tmp_path / "no-mem"), sysfs=str(sysfs))
    assert status == 1
    assert "is 0x20 bytes" in problem and "needs 0x10c" in problem
    assert "reg = <0xff200000 0x1000>" in problem


def test_check_uio_not_a_uio_device(tmp_path):
    status, _, [problem], _ = run(check_args(bus="uio", uio=str(tmp_path / "uio3")),
                                  sysfs=str(tmp_path / "sys"))
    assert status == 1 and "not a UIO device" in problem and "generic-uio" in problem


def test_check_uio_bridge_in_reset_when_readable(tmp_path, devmem):
    device, sysfs = fake_uio(tmp_path)
    devmem.hps(ALL_BRIDGES_IN_RESET, STAT_USER_MODE)
    status, values, [problem], _ = run(check_args(bus="uio", uio=str(device)), devmem,
                                       sysfs=str(sysfs))
    assert status == 1 and "held in reset" in problem and "ID" not in values


def test_preflight_bridge(devmem, tmp_path):
    devmem.hps(BRIDGES_OUT_OF_RESET, STAT_USER_MODE)
    assert preflight_bridge(str(devmem.path)) is None
    devmem.hps(ALL_BRIDGES_IN_RESET, 2)
    line = preflight_bridge(str(devmem.path))
    assert line.startswith("lightweight bridge not usable: FPGA not in user mode "
                           "(configuration phase") and "\n" not in line
    line = preflight_bridge(str(tmp_path / "none"))
    assert line.startswith("cannot read the HPS's reset and FPGA managers: cannot open ")


def test_needed_span():
    assert needed_span("none", 0x100) == 0x20
    assert needed_span("uart", 0x100) == 0x10C
    assert needed_span("serial", 0x200) == 0x20


# ---- the command line: --check and the start-up preflight ------------------------------------
def test_cli_check_needs_no_model_or_robot(devmem, monkeypatch, capsys):
    devmem.hps(BRIDGES_OUT_OF_RESET, STAT_USER_MODE).core()
    monkeypatch.setattr(cli, "DEV_MEM", str(devmem.path))
    assert cli.main(["--check"]) == 0
    out = capsys.readouterr().out
    assert out.splitlines()[-1].startswith("verdict: OK")
    devmem.core(magic=0)
    assert cli.main(["--check", "--bus", "devmem"]) == 1
    assert capsys.readouterr().out.splitlines()[-1] == "verdict: FAIL (1 problem above)"


def test_cli_check_sim_in_a_subprocess():
    done = subprocess.run([sys.executable, "-m", "sw_hps", "--check", "--bus", "sim"],
                          capture_output=True, text=True, timeout=60)
    assert done.returncode == 0, done.stderr
    assert done.stdout.splitlines()[-1].startswith("verdict: OK") and done.stderr == ""


def test_cli_run_still_needs_model_and_robot(capsys):
    assert cli.main(["--bus", "sim"]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "--model, --robot" in err and "--check" in err


@pytest.mark.parametrize("brgmodrst,stat,words", [
    (ALL_BRIDGES_IN_RESET, STAT_USER_MODE, ["bridge", "held in reset", "fix: "]),
    (BRIDGES_OUT_OF_RESET, 1, ["FPGA not in user mode", "fix: load the FPGA"]),
])
def test_cli_preflight_refuses_an_unusable_bridge(devmem, monkeypatch, capsys, brgmodrst, stat,
                                                  words):
    devmem.hps(brgmodrst, stat).core()
    monkeypatch.setattr(cli, "DEV_MEM", str(devmem.path))
    monkeypatch.setattr(cli, "DevMemBus", lambda *a, **k: pytest.fail("bridge mapped"))
    code = cli.main(["--model", str(MODEL), "--bus", "devmem", "--robot", "none"])
    err = capsys.readouterr().err
    assert code == 1 and err.count("\n") == 1 and "Traceback" not in err
    assert err.startswith("python -m sw_hps: error: lightweight bridge not usable: ")
    for word in words:
        assert word in err


def test_cli_preflight_refuses_a_foreign_core(devmem, monkeypatch, capsys):
    devmem.hps(BRIDGES_OUT_OF_RESET, STAT_USER_MODE).core(magic=0xCAFEF00D)
    monkeypatch.setattr(cli, "DEV_MEM", str(devmem.path))
    code = cli.main(["--model", str(MODEL), "--bus", "devmem", "--robot", "none"])
    err = capsys.readouterr().err
    assert code == 1 and err.count("\n") == 1
    assert err.startswith("python -m sw_hps: error: no stereogest core at 0xff200000: ")
    assert devmem.peek(LIGHTWEIGHT_BRIDGE_BASE + CONTROL) == CTRL_NO_GESTURE   # nothing written


def test_cli_preflight_passes_a_stereogest_core(devmem, monkeypatch, caplog):
    """Past the checks the application starts (stopped here by a SIGTERM it sends itself
    once running: the loop's stop request, as a service manager would)."""
    import signal
    devmem.hps(BRIDGES_OUT_OF_RESET, STAT_USER_MODE).core()
    monkeypatch.setattr(cli, "DEV_MEM", str(devmem.path))
    real = cli.GestureApp

    class StopsAtOnce(real):
        def run(self, *args, **kwargs):
            os.kill(os.getpid(), signal.SIGTERM)
            return super().run(*args, **kwargs)
    monkeypatch.setattr(cli, "GestureApp", StopsAtOnce)
    with caplog.at_level(logging.INFO, logger="sw_hps"):
        code = cli.main(["--model", str(MODEL), "--bus", "devmem", "--robot", "none",
                         "--heartbeat", "0"])
    assert code == 0, caplog.text
    assert "core at 0xff200000: stereogest core, register map revision 2" in caplog.text
    # the application drove the core behind the fake bridge: its shutdown cleared Control
    assert devmem.peek(LIGHTWEIGHT_BRIDGE_BASE + CONTROL) == 0
