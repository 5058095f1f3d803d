"""Tests for the HPS register interface: sw_hps.bus, sw_hps.fifo, sw_hps.simulated
(thesis §7.4.1, Tables 12-13)."""
import ast
import os
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

import sw_hps
from sw_hps import bus as bus_module
from sw_hps.bus import Bus, BusError, DevMemBus, SimBus, UioBus, check_offset
from sw_hps.fifo import (CONTROL, CTRL_FIFO_CLR, CTRL_FIFO_DATA, CTRL_FIFO_FULL, CTRL_GO,
                         CTRL_STREAM,
                         CTRL_NO_GESTURE, DATA_MASK, DATO_X, DATO_Y, FIFO_DEPTH, LONGITUD_X,
                         LONGITUD_Y, REGISTER_SPAN, RESERVED, FifoPeripheral, FifoStatus,
                         from_fixed, to_fixed)
from sw_hps.simulated import SimulatedFifoPeripheral, read_trajectory_csv

SW_HPS = Path(sw_hps.__file__).parent


# ---- register map ---------------------------------------------------------------------
def test_register_map_constants():
    assert (DATO_X, DATO_Y, RESERVED, CONTROL, LONGITUD_X, LONGITUD_Y) == \
        (0x00, 0x04, 0x08, 0x0C, 0x10, 0x14)
    assert (CTRL_GO, CTRL_FIFO_DATA, CTRL_NO_GESTURE, CTRL_FIFO_CLR, CTRL_FIFO_FULL) == \
        (1, 2, 4, 8, 16)
    assert REGISTER_SPAN == 0x18 and DATA_MASK == 0x3FFFF and FIFO_DEPTH == 512


def test_fixed_point_conversions():
    assert to_fixed(1.5) == 384 and from_fixed(384) == 1.5
    assert to_fixed(-3) == 0 and to_fixed(5000) == DATA_MASK
    assert from_fixed(0xFFFC0000 | 256) == 1.0          # bits above 17 ignored
    for pixels in (0.0, 12.3456, 639.99609375):
        assert abs(from_fixed(to_fixed(pixels)) - pixels) <= 1 / 512


# ---- offset checks and SimBus ------------------------------------------------------------
@pytest.mark.parametrize("offset", [-4, 2, 0x1000, 0xFFE, 1.0, True, "0"])
def test_check_offset_rejects(offset):
    with pytest.raises(ValueError, match="offset"):
        check_offset(offset, 0x1000)


def test_check_offset_accepts_last_word():
    assert check_offset(0xFFC, 0x1000) == 0xFFC


def test_simbus_decodes_attached_devices():
    fifo = SimulatedFifoPeripheral()
    bus = SimBus(fifo, span=0x200)
    assert isinstance(bus, Bus)
    other = SimulatedFifoPeripheral()
    bus.attach(0x100, other)
    bus.write32(0x100 + CONTROL, CTRL_GO)
    assert other.go and not fifo.go
    assert bus.read32(0x80) == 0                      # decoded by nobody
    bus.write32(0x80, 5)                              # ignored
    with pytest.raises(ValueError, match="overlaps"):
        bus.attach(0x10, SimulatedFifoPeripheral())
    with pytest.raises(ValueError, match="does not fit"):
        bus.attach(0x1F0, SimulatedFifoPeripheral())
    for bad in (0x201, 0x200, 3):
        with pytest.raises(ValueError):
            bus.read32(bad)
    for value in (-1, 1 << 32, 1.5):
        with pytest.raises(ValueError, match="value"):
            bus.write32(0, value)
    bus.close()
    with pytest.raises(BusError):
        bus.read32(0)


# ---- mmap backends on a temporary file --------------------------------------------------
@pytest.fixture
def memfile(tmp_path):
    path = tmp_path / "mem"
    path.write_bytes(bytes(0x3000))
    return path


def test_devmem_bus_maps_an_unaligned_window(memfile):
    bus = DevMemBus(base=0x1000, offset=0x104, span=0x100, path=str(memfile))
    bus.write32(0, 0xDEADBEEF)
    bus.write32(0xFC, 0x01020304)
    data = memfile.read_bytes()
    assert data[0x1104:0x1108] == bytes.fromhex("efbeadde")    # little-endian word
    assert data[0x1200:0x1204] == bytes.fromhex("04030201")
    # A write from outside the mapping is seen by the next read.
    with open(memfile, "r+b") as handle:
        handle.seek(0x1108)
        handle.write((0x12345678).to_bytes(4, "little"))
    assert bus.read32(4) == 0x12345678 and bus.read32(0) == 0xDEADBEEF
    for bad in (0x100, 2, -4):
        with pytest.raises(ValueError, match="offset"):
            bus.read32(bad)
    with pytest.raises(ValueError, match="value"):
        bus.write32(0, 1 << 32)
    bus.close()
    bus.close()                                       # twice is harmless
    with pytest.raises(BusError, match="closed"):
        bus.read32(0)


def test_devmem_bus_drives_the_fifo_registers(memfile):
    with DevMemBus(base=0x2000, span=0x1000, path=str(memfile)) as bus:
        fifo = FifoPeripheral(bus)
        fifo.clear()
        assert bus.read32(CONTROL) == CTRL_GO | CTRL_FIFO_CLR   # a file does not self-clear
        bus.write32(DATO_X, to_fixed(100.5))
        bus.write32(DATO_Y, to_fixed(20.25) | 0xFFFC0000)
        assert fifo.pop() == (100.5, 20.25)


def test_uio_bus(memfile):
    with UioBus(str(memfile), span=0x20) as bus:
        bus.write32(0x1C, 7)
        assert bus.read32(0x1C) == 7
        with pytest.raises(ValueError):
            bus.read32(0x20)
    assert memfile.read_bytes()[0x1C] == 7


def test_mmap_bus_errors_name_the_path(tmp_path, monkeypatch):
    missing = tmp_path / "no-such-mem"
    with pytest.raises(BusError, match="no-such-mem"):
        DevMemBus(path=str(missing))
    with pytest.raises(BusError, match="uio7"):
        UioBus(str(tmp_path / "uio7"))

    def denied(path, flags, *args):
        raise PermissionError(13, "Permission denied", path)
    monkeypatch.setattr(bus_module.os, "open", denied)
    with pytest.raises(BusError, match=r"/dev/mem: permission denied"):
        DevMemBus()


@pytest.mark.parametrize("kwargs,name", [({"base": 2}, "base"), ({"offset": -4}, "offset"),
                                          ({"span": 6}, "span"), ({"span": 0}, "span")])
def test_devmem_bus_rejects_bad_parameters(memfile, kwargs, name):
    with pytest.raises(ValueError, match=name):
        DevMemBus(path=str(memfile), **{"base": 0, **kwargs})


# ---- simulated peripheral: the semantics of Table 13 -------------------------------------
def make_fifo(**kwargs):
    peripheral = SimulatedFifoPeripheral(**kwargs)
    return peripheral, FifoPeripheral(SimBus(peripheral))


def test_reset_state_and_go():
    peripheral, fifo = make_fifo()
    assert fifo.control() == CTRL_NO_GESTURE
    peripheral.push_frame(100, 200, 1)                 # GO = 0: nothing captured
    assert fifo.status() == FifoStatus.decode(CTRL_NO_GESTURE, 0, 0)
    fifo.start()
    # The spotting flag runs regardless of GO; GO gates the gesture bit and the pushes.
    assert fifo.control() == CTRL_GO
    assert fifo.status().length_x == 0
    peripheral.push_frame(100, 200, 1)
    status = fifo.status()
    assert status.go and status.data and status.gesture_active and not status.full
    assert (status.length_x, status.length_y, status.pairs_available) == (1, 1, 1)
    fifo.stop()
    assert fifo.control() == CTRL_FIFO_DATA | CTRL_NO_GESTURE


def test_push_pop_and_lengths():
    peripheral, fifo = make_fifo()
    fifo.start()
    points = [(to_fixed(10 + n), to_fixed(20.5 + n)) for n in range(5)]
    for x, y in points:
        peripheral.push_frame(x, y, True)
    peripheral.push_frame(7, 7, False)                 # not flagged: not pushed
    status = fifo.status()
    assert (status.length_x, status.length_y) == (5, 5) and status.no_gesture and status.data
    assert fifo.pop_raw() == points[0]
    assert fifo.pop() == (11.0, 21.5)
    # Popping only X desynchronises the lengths; FIFO data needs both.
    for _ in range(3):
        peripheral.read32(DATO_X)
    assert (peripheral.read32(LONGITUD_X), peripheral.read32(LONGITUD_Y)) == (0, 3)
    assert not fifo.status().data and fifo.status().pairs_available == 0
    assert peripheral.read32(DATO_X) == 0              # empty reads 0
    assert peripheral.read32(RESERVED) == 0


def test_overflow_sets_sticky_full_and_drops_the_pair():
    peripheral, fifo = make_fifo(depth=3)
    fifo.start()
    for n in range(5):
        peripheral.push_frame(n, n, 1)
    status = fifo.status()
    assert status.full and (status.length_x, status.length_y) == (3, 3)
    assert peripheral.dropped == 2
    assert [fifo.pop_raw() for _ in range(3)] == [(0, 0), (1, 1), (2, 2)]
    assert fifo.status().full                          # sticky until FIFO-CLR
    peripheral.push_frame(9, 9, 1)
    fifo.clear()
    status = fifo.status()
    assert not status.full and status.length_x == 0 and status.go
    assert fifo.control() & CTRL_FIFO_CLR == 0         # self-clearing


def test_writes_to_read_only_bits_and_registers_are_ignored():
    peripheral, fifo = make_fifo()
    peripheral.write32(CONTROL, 0xFFFFFFFF & ~CTRL_FIFO_CLR)
    assert fifo.control() == CTRL_GO | CTRL_NO_GESTURE | CTRL_STREAM
    for offset in (DATO_X, DATO_Y, RESERVED, LONGITUD_X, LONGITUD_Y):
        peripheral.write32(offset, 123)
    assert fifo.status().length_x == 0


def test_push_frame_validates_values():
    peripheral = SimulatedFifoPeripheral()
    for bad in (-1, DATA_MASK + 1, 1.5, True):
        with pytest.raises(ValueError, match="x_fixed"):
            peripheral.push_frame(bad, 0, 1)
    with pytest.raises(ValueError, match="depth"):
        SimulatedFifoPeripheral(depth=0)
    with pytest.raises(ValueError, match="reads_per_frame"):
        SimulatedFifoPeripheral(reads_per_frame=0)


def test_trajectory_queue_step_and_reads_per_frame():
    peripheral, fifo = make_fifo(reads_per_frame=2)
    peripheral.write32(CONTROL, CTRL_GO)
    peripheral.queue_trajectory([1.0, 2.0, 3.0], [4.0, 5.0, 6.0], [0, 1, 1], pixels=True)
    assert peripheral.frames_pending == 3
    assert fifo.control() & CTRL_NO_GESTURE            # 1st read: no frame yet
    fifo.control()                                     # 2nd read: frame 0 (flag 0)
    assert peripheral.frames == 1 and not peripheral.fifo_x
    fifo.control()
    assert fifo.control() & CTRL_NO_GESTURE == 0       # frame 1 (flag 1)
    assert peripheral.step() == 1 and peripheral.step(3) == 0
    assert peripheral.frames == 6 and not peripheral.flag
    assert [fifo.pop() for _ in range(2)] == [(2.0, 5.0), (3.0, 6.0)]
    with pytest.raises(ValueError, match="same length"):
        peripheral.queue_trajectory([1], [1, 2], [0])


def test_read_trajectory_csv(tmp_path):
    path = tmp_path / "trajectory.csv"
    path.write_text("frame,x,y,flag,symbol\n0,320.0000,240.5000,0,-1\n1,321.2500,240.0,1,0\n\n")
    x, y, flag = read_trajectory_csv(path)
    assert x.tolist() == [320.0, 321.25] and y.tolist() == [240.5, 240.0]
    assert flag.tolist() == [False, True]
    for text, match in [("frame,x,flag\n", "missing"), ("frame,x,y,flag\n0,1,a,0\n", "line 2"),
                        ("frame,x,y,flag\n0,1,2,3\n", "flag must be"), ("", "empty")]:
        path.write_text(text)
        with pytest.raises(ValueError, match=match):
            read_trajectory_csv(path)
    with pytest.raises(ValueError, match="cannot read"):
        read_trajectory_csv(tmp_path / "missing.csv")


# ---- deployability ------------------------------------------------------------------------
def test_sw_hps_imports_only_stdlib_numpy_and_itself():
    """And the shared interface (soc/hps_interface.py, shipped with it), which
    imports the standard library alone."""
    allowed = set(sys.stdlib_module_names) | {"numpy", "sw_hps"}
    files = [(path, allowed) for path in sorted(SW_HPS.glob("*.py"))]
    files.append((SW_HPS.parent / "soc" / "hps_interface.py", set(sys.stdlib_module_names)))
    for path, modules in files:
        for node in ast.walk(ast.parse(path.read_text())):
            if isinstance(node, ast.Import):
                names = [alias.name for alias in node.names]
            elif isinstance(node, ast.ImportFrom) and node.level == 0:
                names = [node.module]
            else:
                continue
            for name in names:
                assert name.split(".")[0] in modules or (
                    path.parent == SW_HPS and name == "soc.hps_interface"), \
                    f"{path.name} imports {name}"


def test_sw_hps_runs_from_a_copy_without_the_project(tmp_path):
    import shutil
    from sw_hps.bundle import SHARED
    shutil.copytree(SW_HPS, tmp_path / "sw_hps", ignore=shutil.ignore_patterns("__pycache__"))
    for name in SHARED:                                   # what the bundle ships besides
        (tmp_path / name).parent.mkdir(exist_ok=True)
        shutil.copy(SW_HPS.parent / name, tmp_path / name)
    numpy_dir = str(Path(np.__file__).parent.parent)
    # -S: no site processing, so the project's editable install is not importable.
    code = ("import sys, sw_hps.app, sw_hps.__main__, sw_hps.robot\n"
            "assert not any(m.split('.')[0] in ('sim', 'stereogest', 'recognition', 'hdl',"
            " 'amaranth') for m in sys.modules), sorted(sys.modules)\n"
            "assert sw_hps.__file__.startswith(sys.argv[1])\nprint('ok')")
    done = subprocess.run([sys.executable, "-S", "-c", code, str(tmp_path)], cwd=tmp_path,
                          env={"PYTHONPATH": f"{tmp_path}{os.pathsep}{numpy_dir}"},
                          capture_output=True, text=True, timeout=60)
    assert done.returncode == 0, done.stderr
    assert done.stdout.strip() == "ok"
