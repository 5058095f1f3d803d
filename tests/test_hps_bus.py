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
from sw_hps.fifo import (CONTROL, CORE_MAGIC, CORE_REVISION, CTRL_FIFO_CLR, CTRL_FIFO_DATA,
                         CTRL_FIFO_FULL, CTRL_GO, CTRL_STREAM,
                         CTRL_NO_GESTURE, DATA_MASK, DATO_X, DATO_Y, FIFO_DEPTH, ID, LONGITUD_X,
                         LONGITUD_Y, REGISTER_SPAN, RESERVED, VERSION, CoreIdentity,
                         FifoPeripheral, FifoStatus, from_fixed, to_fixed)
from sw_hps.simulated import SimulatedFifoPeripheral, read_trajectory_csv

SW_HPS = Path(sw_hps.__file__).parent


# ---- register map ---------------------------------------------------------------------
def test_register_map_constants():
    assert (DATO_X, DATO_Y, RESERVED, CONTROL, LONGITUD_X, LONGITUD_Y, ID, VERSION) == \
        (0x00, 0x04, 0x08, 0x0C, 0x10, 0x14, 0x18, 0x1C)
    assert (CTRL_GO, CTRL_FIFO_DATA, CTRL_NO_GESTURE, CTRL_FIFO_CLR, CTRL_FIFO_FULL) == \
        (1, 2, 4, 8, 16)
    assert REGISTER_SPAN == 0x20 and DATA_MASK == 0x3FFFF and FIFO_DEPTH == 512
    assert CORE_MAGIC == 0x53475354


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
    if sys.version_info >= (3, 8):      # typing.Protocol; Bus is a plain class on 3.7
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
    identity = fifo.identify()
    for offset in (DATO_X, DATO_Y, RESERVED, LONGITUD_X, LONGITUD_Y, ID, VERSION):
        peripheral.write32(offset, 123)
    assert fifo.status().length_x == 0
    assert fifo.identify() == identity and identity.present


# ---- identification: ID and Version ---------------------------------------------------
def test_identify_the_board_core():
    peripheral, fifo = make_fifo()
    identity = fifo.identify()
    assert identity == CoreIdentity(magic=0x53475354, version_word=0x3C502900 | CORE_REVISION,
                                    present=True, revision=CORE_REVISION, fifo_depth=512,
                                    streaming=True, frame_width=640, frame_height=480)
    assert identity.supported
    assert identity.describe() == (
        f"stereogest core, register map revision {CORE_REVISION}: FIFO depth 512, streaming "
        f"mode implemented, frames 640x480 (Version {identity.version_word:#010x})")
    with pytest.raises(AttributeError):
        identity.present = False                       # an immutable record
    # two reads, no side effect on the FIFOs or on the frames played per Control read
    peripheral.write32(CONTROL, CTRL_GO)
    peripheral.push_frame(5, 6, True)
    assert fifo.identify() == identity and fifo.status().length_x == 1


def test_identify_reports_the_model_parameters():
    """Another build's parameters; depths and sizes the fields cannot hold exactly
    round as the hardware's Version does (depth down, size up)."""
    _, fifo = make_fifo(depth=64, frame_width=320, frame_height=240)
    got = fifo.identify()
    assert (got.fifo_depth, got.frame_width, got.frame_height) == (64, 320, 240)
    assert "FIFO depth 64" in got.describe() and "frames 320x240" in got.describe()
    _, fifo = make_fifo(depth=20, frame_width=98, frame_height=61)
    got = fifo.identify()
    assert (got.fifo_depth, got.frame_width, got.frame_height) == (16, 104, 64)
    with pytest.raises(ValueError, match=r"^frame_width must be an int in \[1, 2040\]"):
        SimulatedFifoPeripheral(frame_width=4096)


@pytest.mark.parametrize("word", [0x00000000, 0xFFFFFFFF, 0x53475355, 0x54534753])
def test_identify_without_a_core(word):
    """An old bitstream (words 6 and 7 read 0), a bridge reading all ones, a
    near miss and the magic byte-swapped: not present, no decoded fields."""
    bus = SimBus(span=0x100)
    bus.attach(0x40, SimulatedFifoPeripheral())      # a core elsewhere in the window
    fifo = FifoPeripheral(bus)
    assert fifo.identify().present is False           # nothing at 0: reads 0
    identity = CoreIdentity.decode(word, 0x3C502902)
    assert not identity.present and not identity.supported
    assert (identity.revision, identity.fifo_depth, identity.frame_width) == (None, None, None)
    line = identity.describe()
    assert line.startswith(f"no stereogest core: ID reads {word:#010x}")
    assert "expected 0x53475354 ('SGST')" in line and "\n" not in line
    assert FifoPeripheral(bus, base=0x40).identify().present


def test_identify_an_other_revision():
    identity = CoreIdentity.decode(CORE_MAGIC, (0x3C502900 | CORE_REVISION) + 1)
    assert identity.present and not identity.supported
    assert identity.revision == CORE_REVISION + 1
    assert identity.describe().endswith(f"; this application expects revision {CORE_REVISION}")


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
    if not hasattr(sys, "stdlib_module_names"):
        pytest.skip("sys.stdlib_module_names needs Python 3.10 (the dev Python runs this)")
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


# ---- UioBus: the map size from sysfs -------------------------------------------------------
def uio_tree(tmp_path, size, offset=0, addr=0xFF200000, name="stereogest", device="uio2"):
    """A fake /sys/class/uio with one device, and a plain file as its node."""
    sysfs = tmp_path / "sys"
    maps = sysfs / device / "maps" / "map0"
    maps.mkdir(parents=True)
    (sysfs / device / "name").write_text(f"{name}\n")
    if size is not None:
        (maps / "size").write_text(f"{size:#010x}\n")
    (maps / "addr").write_text(f"{addr:#010x}\n")
    (maps / "offset").write_text(f"{offset:#x}\n")
    node = tmp_path / device
    node.write_bytes(bytes(0x2000))
    return node, sysfs


def test_read_uio_map(tmp_path):
    from sw_hps.bus import UioMap, read_uio_map
    node, sysfs = uio_tree(tmp_path, 0x1000)
    expected = UioMap(device="uio2", name="stereogest", addr=0xFF200000, size=0x1000, offset=0)
    assert read_uio_map(str(node), str(sysfs)) == expected
    link = tmp_path / "stereogest"                  # a udev symlink resolves to uio2
    link.symlink_to(node)
    assert read_uio_map(str(link), str(sysfs)) == expected
    assert read_uio_map(str(tmp_path / "uio7"), str(sysfs)) is None


@pytest.mark.parametrize("size,span", [(0x1000, 0x1000), (0x2000, 0x1000), (0x800, 0x800),
                                       (0x22, 0x20)])
def test_uio_bus_maps_at_most_the_map(tmp_path, size, span):
    node, sysfs = uio_tree(tmp_path, size)
    with UioBus(str(node), span=0x1000, need=REGISTER_SPAN, sysfs=str(sysfs)) as bus:
        assert bus.span == span
        bus.write32(span - 4, 0xA5A5A5A5)
        with pytest.raises(ValueError, match="offset"):
            bus.read32(span)
    assert node.read_bytes()[span - 4:span] == b"\xa5" * 4


def test_uio_bus_honours_the_map_offset(tmp_path):
    node, sysfs = uio_tree(tmp_path, 0x100, offset=0x40)
    with UioBus(str(node), span=0x1000, sysfs=str(sysfs)) as bus:
        bus.write32(CONTROL, 0x21)
        assert bus.span == 0x100
    assert node.read_bytes()[0x40 + CONTROL] == 0x21


def test_uio_bus_map_smaller_than_needed_is_one_clear_error(tmp_path):
    node, sysfs = uio_tree(tmp_path, 0x20)
    with pytest.raises(BusError) as error:
        UioBus(str(node), span=0x1000, need=0x10C, sysfs=str(sysfs))
    message = str(error.value)
    assert "\n" not in message and str(node) in message
    assert "is 0x20 bytes" in message and "maps/map0/size" in message and "0x10c" in message
    assert "reg = <0xff200000 0x1000>" in message


def test_uio_bus_without_a_map(tmp_path):
    node, sysfs = uio_tree(tmp_path, None)
    with pytest.raises(BusError, match=r"maps/map0/size missing.*reg = <0xff200000 0x1000>"):
        UioBus(str(node), sysfs=str(sysfs))


def test_uio_bus_refused_mapping_names_the_reg(tmp_path, monkeypatch):
    """Newer kernels refuse to map a UIO map smaller than a page (EINVAL)."""
    import errno
    node, sysfs = uio_tree(tmp_path, 0x20)

    def refuse(*args, **kwargs):
        raise OSError(errno.EINVAL, "Invalid argument")
    monkeypatch.setattr(bus_module.mmap, "mmap", refuse)
    with pytest.raises(BusError) as error:
        UioBus(str(node), span=0x1000, need=0x20, sysfs=str(sysfs))
    message = str(error.value)
    assert "Invalid argument" in message and "less than a page" in message
    assert "reg = <0xff200000 0x1000>" in message


def test_uio_bus_rejects_a_bad_need(tmp_path):
    node, sysfs = uio_tree(tmp_path, 0x1000)
    with pytest.raises(ValueError, match="need"):
        UioBus(str(node), need=-4, sysfs=str(sysfs))
