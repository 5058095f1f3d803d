"""The whole FPGA side (:class:`soc.core.StereogestCore`) under Verilator, with
the board application on its registers: the end-to-end demo's engine.

The C++ harness ``verif/cpp/system_harness.cpp`` runs the five clocks and
replays the camera pins; Python talks to it line by line (read, write, run for
some nanoseconds, grab a VGA frame, the UART line). :class:`SystemBus` turns
that into the :class:`sw_hps.bus.Bus` protocol, so the unmodified
:class:`sw_hps.app.GestureApp` with its :class:`~sw_hps.fifo.FifoPeripheral`
and :class:`~sw_hps.robot.UartLink` drives the simulated hardware exactly as it
drives the board through ``/dev/mem``; its sleeps advance simulated time.

The cameras' I2C lines have no target in this simulation: after their power-up
the configuration masters meet NACKs and end with their error output (LEDR[2],
106 ms of simulated time after reset); the camera waveforms stand for
configured cameras. The cameras' PWDN and RESETB (``*_power``) are outputs of
the wrapper nobody reads.
"""
from __future__ import annotations

import hashlib
import json
import subprocess
import tempfile
from pathlib import Path

import numpy as np

from sim.model.pipeline import PipelineParams
from sim.model.validation import check_int

from .clocks import Clocks, camera_waveforms, clip_timing
from .pipeline import CFLAGS
from .verilator import (CPP, EMISSIONS, build_root, check_emission, simulation_verilog,
                        sources_digest, verilate)

__all__ = ["build_system", "VerilatorSystem", "SystemBus", "decode_uart"]

HARNESS = CPP / "system_harness.cpp"
TOP = "stereogest_system"


def _wrapper(core) -> str:
    """The harness's top, derived from the core's ports (:func:`soc.core.core_ports`):
    the same names with ``__`` made ``_`` (Verilator mangles Amaranth's ``__``); one
    ``reset`` input, registered per domain; the I2C lines pulled up with no target
    (each ``*_i`` reads its own ``*_oe`` inverted)."""
    from soc.core import core_ports
    ports, connections, resets = [], [], []
    for name, direction, width in core_ports(core):
        if name == "rst" or name.endswith("_rst"):
            clock = name[:-len("rst")] + "clk"
            reg = f"{name}_q"
            resets.append(f"  reg {reg} = 1;\n  always @(posedge {clock}) {reg} <= reset;")
            connections.append(f".{name}({reg})")
        elif "_i2c__" in name:
            oe = name[:-len("_i")] + "_oe" if name.endswith("_i") else name
            wire = oe.replace("__", "_")
            if name == oe:
                resets.append(f"  wire {wire};")
            connections.append(f".{name}({'!' if name != oe else ''}{wire})")
        else:
            plain = name.replace("__", "_")
            ports.append(f"{direction} {f'[{width - 1}:0] ' if width > 1 else ''}{plain}")
            connections.append(f".{name}({plain})")
    return (f"\nmodule {TOP}({', '.join(ports)}, input reset);\n"
            "  // Resets through a register of their domain: a primary input feeding logic\n"
            "  // makes Verilator re-evaluate all of it at every clock edge of the harness.\n"
            + "\n".join(resets) + "\n"
            f"  stereogest_core core({', '.join(connections)});\nendmodule\n")


def _make_core(width, height, params, clocks: Clocks, rectification=None, vga_scale=None,
               fifo_depth=None):
    from soc.core import VGA_SCALE, StereogestCore
    from soc.hps_interface import FIFO_DEPTH
    return StereogestCore(width, height, params, rectification=rectification,
                          sync_freq=clocks.sync_hz, config_freq=1e12 / clocks.config_ps,
                          vga_scale=VGA_SCALE if vga_scale is None else vga_scale,
                          fifo_depth=FIFO_DEPTH if fifo_depth is None else fifo_depth)


def build_system(width: int, height: int, params: PipelineParams = PipelineParams(),
                 clocks: Clocks = Clocks(), jobs: int | None = None,
                 log=None, emission: str = EMISSIONS[0], rectification=None,
                 vga_scale: int | None = None, fifo_depth: int | None = None) -> Path:
    """Build (or reuse, cached under ``<build>/verilator/system-*``) the Verilated
    core with the harness, its Verilog written as ``emission`` says
    (:data:`verif.verilator.EMISSIONS`), with ``rectification``'s stages if given,
    its VGA frame buffer at ``vga_scale`` (None: the core's default), its
    centroid FIFOs ``fifo_depth`` entries deep (None: the board's,
    :data:`soc.hps_interface.FIFO_DEPTH`); returns the executable."""
    from soc.core import CORE_NAME, VGA_SCALE, strip_zero_init
    vga_scale = VGA_SCALE if vga_scale is None else vga_scale
    spec = dict(width=width, height=height, sync_ps=clocks.sync_ps,
                config_ps=clocks.config_ps, emission=check_emission(emission),
                vga_scale=vga_scale,
                **params.as_dict())
    if rectification is not None:
        spec["rectification"] = rectification.digest()
    if fifo_depth is not None:
        spec["fifo_depth"] = fifo_depth
    key = hashlib.sha256(json.dumps(spec, sort_keys=True).encode()).hexdigest()[:12]
    digest = sources_digest(["hdl", "soc"], [HARNESS, Path(__file__)])   # the wrapper too
    folder = build_root() / f"system-{key}-{digest}"
    exe = folder / "obj_dir" / "system_harness"
    if exe.exists():
        return exe
    if log is not None:
        log(f"building the Verilated system ({width}x{height}; a few minutes, cached)")
    core = _make_core(width, height, params, clocks, rectification, vga_scale, fifo_depth)
    text = strip_zero_init(simulation_verilog(core, CORE_NAME, emission=emission)) \
        + _wrapper(core)
    return verilate(folder, f"{TOP}.v", text, spec, TOP, "system_harness", HARNESS,
                    jobs=jobs, cflags=CFLAGS)


class VerilatorSystem:
    """A running harness process (use as a context manager).

    Parameters
    ----------
    left_frames, right_frames : (F, H, 2W) uint8
        The clip's 4:2:2 camera frames.
    params : PipelineParams
    clocks : Clocks
    stage : int
        ``stage_select`` (SW[9:7]) for the whole run.
    exe : path, optional
        A harness already built by :func:`build_system` for these parameters
        (default: build or reuse the cached one).
    rectification : sim.model.rectify.StereoRectification, optional
        The core's rectification stages (their maps), as :func:`build_system`.
    vga_scale : int in [1, 2], optional
        Resolution of the core's VGA frame buffer (None: its default).
    pins : (left, right) uint16 arrays, optional
        The cameras' packed pins (:func:`sim.camera.pack_pins`) to play instead
        of the clip's waveforms (the frames then only give the size); a long run
        gives more with :meth:`append_pins`.
    """

    def __init__(self, left_frames, right_frames, params: PipelineParams = PipelineParams(),
                 *, clocks: Clocks = Clocks(), stage: int = 5, log=None,
                 exe: Path | None = None, rectification=None, vga_scale: int | None = None,
                 pins=None):
        from hdl.gesture_pipeline import pipeline_timing
        from sim.camera import pack_pins
        from soc.vga_timing import VGA_640x480_60
        left_frames, right_frames = np.asarray(left_frames), np.asarray(right_frames)
        if left_frames.shape != right_frames.shape or left_frames.ndim != 3:
            raise ValueError(f"left and right frames must be equal (F, H, 2W) arrays, got "
                             f"{left_frames.shape} and {right_frames.shape}")
        check_int("stage", stage, 0, 7)
        self.height, self.width = left_frames.shape[1], left_frames.shape[2] // 2
        params.validate(self.width, self.height)
        self.clocks = clocks
        self.exe = Path(exe) if exe is not None else \
            build_system(self.width, self.height, params, clocks, log=log,
                         rectification=rectification, vga_scale=vga_scale)
        flush = pipeline_timing(self.width, self.height, params, rectification).flush
        timing = clip_timing(self.width, self.height, flush, clocks)
        self._tmp = tempfile.TemporaryDirectory(prefix="stereogest-system-")
        tmp = Path(self._tmp.name)
        if pins is None:
            pins = [pack_pins(wave) for wave in
                    camera_waveforms(left_frames, right_frames, timing)]
        for name, samples in zip(("left.bin", "right.bin"), pins):
            np.asarray(samples, dtype="<u2").tofile(tmp / name)
        mode = VGA_640x480_60
        self.vga_size = (mode.h_active, mode.v_active)
        args = [str(self.exe), str(tmp / "left.bin"), str(tmp / "right.bin"),
                *clocks.camera_args(), str(clocks.config_ps),
                str(clocks.vga_ps), str(stage), str(mode.h_active), str(mode.v_active)]
        self._proc = subprocess.Popen(args, stdin=subprocess.PIPE, stdout=subprocess.PIPE,
                                      stderr=subprocess.PIPE, text=True, bufsize=1)
        self.cycles = 0
        self.cameras_done = False
        self.stats: dict | None = None
        # the harness holds every domain in reset for its first cycles: the
        # application starts once they are over, as on the board
        self.advance(1e-6)

    def _ask(self, line: str) -> str:
        if self._proc.poll() is not None:
            raise RuntimeError(f"the system harness ended ({self._proc.returncode}): "
                               f"{self._proc.stderr.read()}")
        self._proc.stdin.write(line + "\n")
        self._proc.stdin.flush()
        reply = self._proc.stdout.readline().strip()
        if not reply or reply.startswith("error"):
            raise RuntimeError(f"system harness: {line!r} -> {reply!r} "
                               f"({self._proc.stderr.read() if not reply else ''})")
        return reply

    def read32(self, address: int) -> int:
        """Avalon read at byte ``address`` of the bridge window."""
        return int(self._ask(f"r {address}"))

    def write32(self, address: int, value: int) -> None:
        self._ask(f"w {address} {value}")

    def advance(self, seconds: float) -> None:
        """Run the hardware for ``seconds`` of simulated time."""
        cycles, done = self._ask(f"t {max(1, int(round(seconds * 1e9)))}").split()
        self.cycles, self.cameras_done = int(cycles), done == "1"

    def append_pins(self, left, right) -> None:
        """Play these packed pin samples (:func:`sim.camera.pack_pins`) after
        what each camera has been given so far."""
        tmp = Path(self._tmp.name)
        for name, samples in (("more-left.bin", left), ("more-right.bin", right)):
            np.asarray(samples, dtype="<u2").tofile(tmp / name)
        self._ask(f"a {tmp / 'more-left.bin'} {tmp / 'more-right.bin'}")

    def vga_frame(self) -> np.ndarray:
        """The next whole VGA frame's active area (red channel), (height, width) uint8."""
        path = Path(self._tmp.name) / "vga.bin"
        self._ask(f"v {path}")
        width, height = self.vga_size
        return np.fromfile(path, dtype=np.uint8).reshape(height, width)

    def uart_edges(self) -> np.ndarray:
        """UART TX line changes since the last call: (N, 2) int64 of (ps, level)."""
        fields = [int(v) for v in self._ask("u").split()]
        return np.array(fields[1:], dtype=np.int64).reshape(-1, 2)

    def close(self) -> dict:
        """End the harness; returns its statistics."""
        if self.stats is None and self._proc.poll() is None:
            self._proc.stdin.write("q\n")
            self._proc.stdin.flush()
            out, err = self._proc.communicate(timeout=60)
            lines = out.strip().splitlines()
            self.stats = json.loads(lines[-1]) if lines else {"error": err}
        self._tmp.cleanup()
        return self.stats or {}

    def __enter__(self):
        return self

    def __exit__(self, *exc):
        self.close()
        if self._proc.poll() is None:
            self._proc.kill()


class SystemBus:
    """:class:`sw_hps.bus.Bus` over the simulated lightweight bridge.

    Every access is one Avalon transfer of the harness; ``sleep(seconds)`` (give
    it to the application) runs the hardware for that long. Pops of Dato_X /
    Dato_Y are recorded in :attr:`popped` (raw words), Control reads in
    :attr:`last_control`.
    """

    span = 0x1000

    def __init__(self, system: VerilatorSystem):
        self.system = system
        self.popped: list[tuple[int, int]] = []
        self._x: int | None = None
        self.last_control = 0
        self.accesses = 0

    def read32(self, offset: int) -> int:
        from sw_hps.bus import check_offset
        from sw_hps.fifo import CONTROL, DATO_X, DATO_Y
        check_offset(offset, self.span)
        self.accesses += 1
        value = self.system.read32(offset)
        if offset == DATO_X:
            self._x = value
        elif offset == DATO_Y and self._x is not None:
            self.popped.append((self._x, value))
            self._x = None
        elif offset == CONTROL:
            self.last_control = value
        return value

    def write32(self, offset: int, value: int) -> None:
        from sw_hps.bus import check_offset
        check_offset(offset, self.span)
        self.accesses += 1
        self.system.write32(offset, value)

    def sleep(self, seconds: float) -> None:
        self.system.advance(seconds)

    def close(self) -> None:
        pass


def decode_uart(edges: np.ndarray, baudrate: int = 115200) -> bytes:
    """Bytes of an 8N1 line from its changes ((ps, level) rows, idle high): each
    start bit's falling edge, then every bit sampled at its centre; a byte whose
    stop bit reads 0 is dropped. An independent model of the receiver (not the
    UART slave's logic)."""
    bit = 1e12 / baudrate
    times, levels = edges[:, 0].astype(float), edges[:, 1]

    def level_at(t: float) -> int:
        k = np.searchsorted(times, t, side="right") - 1
        return 1 if k < 0 else int(levels[k])

    out = bytearray()
    t_end = -1.0
    for t, level in zip(times, levels):
        if level != 0 or t < t_end:
            continue
        if level_at(t + 0.5 * bit) != 0:
            continue  # a glitch, not a start bit
        value = sum(level_at(t + (1.5 + i) * bit) << i for i in range(8))
        if level_at(t + 9.5 * bit):
            out.append(value)
        t_end = t + 9.5 * bit
    return bytes(out)
