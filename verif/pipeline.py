"""The GesturePipeline's Verilog under Verilator with the C++ harness
``verif/cpp/pipeline_harness.cpp``: camera pin waveforms in (:mod:`sim.camera`,
:mod:`verif.clocks`), per-frame records out, no Python per cycle (cached
builds: :mod:`verif.verilator`).
"""
from __future__ import annotations

import hashlib
import json
import subprocess
import tempfile
from dataclasses import asdict, dataclass
from pathlib import Path

import numpy as np

from sim.model.pipeline import PipelineParams
from soc.hps_interface import POSTURE_WORD_COUNT

from .clocks import Clocks, camera_waveforms, clip_timing
from .verilator import (CPP, EMISSIONS, build_root, check_emission, simulation_verilog,
                        sources_digest, verilate)

__all__ = ["PipelineRun", "build_pipeline", "run_pipeline",
           "run_clip_hardware", "RECORD_FIELDS"]

HARNESS = CPP / "pipeline_harness.cpp"
TOP = "gesture_pipeline"
RECORD_FIELDS = ("cycle", "x", "y", "flag", "centroid_x", "centroid_y", "area")


@dataclass
class PipelineRun:
    records: np.ndarray   #: structured array, one row per frame (:data:`RECORD_FIELDS`)
    video: np.ndarray | None  #: uint16 (first << 8) | pixel of the o_video beats
    stats: dict
    #: (frames, POSTURE_WORD_COUNT) int64: the posture records (None without them)
    posture: np.ndarray | None = None


def _wrapper(top, core: str) -> str:
    """A top module with plain port names; the record payload split into fields."""
    p = top.pipeline
    layout = p.o_stream.payload.shape()
    out_ports, out_assign = [], []
    for name in RECORD_FIELDS[1:]:
        f = layout[name]
        width = f.shape.width if hasattr(f.shape, "width") else int(f.shape)
        out_ports.append(f"output [{width - 1}:0] out_{name}")
        out_assign.append(f"assign out_{name} = payload[{f.offset + width - 1}:{f.offset}];")
    rec_bits = layout.size
    tb = len(p.threshold)
    posture_layout = p.o_posture.payload.shape()
    posture_bits = posture_layout.size
    assert posture_layout["word"].offset == posture_bits - 32
    return f"""
module {TOP}(input clk, input rst, input cam_left_clk, input cam_left_rst,
  input cam_right_clk, input cam_right_rst,
  input left_vsync, input left_href, input [7:0] left_data,
  input right_vsync, input right_href, input [7:0] right_data,
  input start, input pause, input [2:0] video_select,
  output out_valid, {", ".join(out_ports)},
  output video_valid, output video_first, output [7:0] video_pixel,
  output posture_valid, output [31:0] posture_word,
  output [15:0] frames, output [15:0] faults);
  wire [{rec_bits - 1}:0] payload;
  wire [8:0] video;
  wire [{posture_bits - 1}:0] posture;
  // Resets through a register of their domain: a primary input feeding logic
  // makes Verilator re-evaluate all of it at every clock edge of the harness.
  reg rst_q = 1, cam_left_rst_q = 1, cam_right_rst_q = 1;
  always @(posedge clk) rst_q <= rst;
  always @(posedge cam_left_clk) cam_left_rst_q <= cam_left_rst;
  always @(posedge cam_right_clk) cam_right_rst_q <= cam_right_rst;
  {core} core(.clk(clk), .rst(rst_q), .cam_left_clk(cam_left_clk), .cam_left_rst(cam_left_rst_q),
    .cam_right_clk(cam_right_clk), .cam_right_rst(cam_right_rst_q),
    .left__vsync(left_vsync), .left__href(left_href), .left__data(left_data),
    .right__vsync(right_vsync), .right__href(right_href), .right__data(right_data),
    .start(start), .pause(pause), .video_select(video_select),
    .threshold({tb}'d{p.params.lrcc_threshold}),
    .o_stream__valid(out_valid), .o_stream__payload(payload),
    .o_video__valid(video_valid), .o_video__payload(video),
    .o_posture__valid(posture_valid), .o_posture__payload(posture),
    .frames(frames), .faults(faults));
  {" ".join(out_assign)}
  assign posture_word = posture[{posture_bits - 1}:{posture_bits - 32}];
  assign video_first = video[0];
  assign video_pixel = video[8:1];
endmodule
"""


def _make_top(width, height, params, fifo_depth, rectification=None):
    from hdl.gesture_pipeline import GesturePipeline, PipelineTop
    return PipelineTop(GesturePipeline(width, height, params, rectification=rectification,
                                       fifo_depth=fifo_depth))


#: C++ optimisation of the Verilated model: -O3 -march=native ran 2.5 times as
#: fast as -O2 here (docs/figures/fpga.md); the build cache is per machine anyway
CFLAGS = "-O3 -march=native"


def build_pipeline(width: int, height: int, params: PipelineParams = PipelineParams(),
                   fifo_depth: int = 2048, jobs: int | None = None, threads: int = 1,
                   cflags: str = CFLAGS, emission: str = EMISSIONS[0],
                   rectification=None) -> Path:
    """Build (or reuse) the Verilated pipeline harness; returns the executable.
    ``threads`` > 1 builds a multithreaded model (Verilator ``--threads``);
    ``emission``: how its Verilog is written (:data:`verif.verilator.EMISSIONS`);
    ``rectification``: :class:`sim.model.rectify.StereoRectification` or None."""
    from sim.model.pipeline import check_rectification
    params.validate(width, height)
    check_rectification(rectification, width, height)
    check_emission(emission)       # before a pipeline is built for it
    spec = dict(width=width, height=height, fifo_depth=fifo_depth, threads=threads,
                cflags=cflags, emission=emission, **params.as_dict())
    if rectification is not None:
        spec["rectification"] = rectification.digest()
    key = hashlib.sha256(json.dumps(spec, sort_keys=True).encode()).hexdigest()[:12]
    digest = sources_digest(["hdl"], [HARNESS])
    folder = build_root() / f"pipeline-{key}-{digest}"
    exe = folder / "obj_dir" / "pipeline_harness"
    if exe.exists():
        return exe
    from hdl.synthesis import component_ports
    top = _make_top(width, height, params, fifo_depth, rectification)   # only when not cached
    core = TOP + "_core"
    text = simulation_verilog(top, core, component_ports(top), emission)
    return verilate(folder, f"{TOP}.v", text + _wrapper(top, core), spec, TOP,
                    "pipeline_harness", HARNESS, jobs=jobs, cflags=cflags, threads=threads)


def run_pipeline(left_wave, right_wave, width: int, height: int,
                 params: PipelineParams = PipelineParams(), *, clocks: Clocks = Clocks(),
                 fifo_depth: int = 2048, drain: int | None = None, reset_at: int = -1,
                 reset_cycles: int = 16, video_select: int | None = None,
                 jobs: int | None = None, threads: int = 1,
                 emission: str = EMISSIONS[0], rectification=None) -> PipelineRun:
    """Replay two camera waveforms (:class:`sim.camera.CameraWaveform`) through the
    Verilated pipeline; returns its per-frame records and the harness statistics.
    ``drain``: pipeline cycles run after the cameras' last sample (default: enough
    for the last frame's flush, record and the FIFOs)."""
    from hdl.gesture_pipeline import pipeline_timing
    from sim.camera import pack_pins
    exe = build_pipeline(width, height, params, fifo_depth, jobs, threads, CFLAGS, emission,
                         rectification)
    if drain is None:
        drain = pipeline_timing(width, height, params, rectification).record_cycles \
            + 2 * fifo_depth + 4 * width
    dtype = np.dtype([(name, "<i8") for name in RECORD_FIELDS])
    with tempfile.TemporaryDirectory() as tmp:
        paths = [Path(tmp) / n for n in ("left.bin", "right.bin", "out.bin", "video.bin",
                                         "posture.bin")]
        pack_pins(left_wave).astype("<u2").tofile(paths[0])
        pack_pins(right_wave).astype("<u2").tofile(paths[1])
        video_arg = str(paths[3]) if video_select is not None else "-"
        args = [str(exe), str(paths[0]), str(paths[1]), str(paths[2]), *clocks.camera_args(),
                str(drain), str(reset_at),
                str(reset_cycles), str(video_select or 0), video_arg, str(paths[4])]
        proc = subprocess.run(args, capture_output=True, text=True)
        if proc.returncode != 0:
            raise RuntimeError(f"harness failed ({proc.returncode}): {proc.stderr}{proc.stdout}")
        stats = json.loads(proc.stdout.strip().splitlines()[-1])
        records = np.fromfile(paths[2], dtype=dtype)
        video = np.fromfile(paths[3], dtype="<u2") if video_select is not None else None
        words = np.fromfile(paths[4], dtype="<u4").astype(np.int64)
    stats["exe"] = str(exe)
    stats["clocks"] = asdict(clocks)
    posture = None
    if params.posture:
        whole = len(words) // POSTURE_WORD_COUNT * POSTURE_WORD_COUNT
        posture = words[:whole].reshape(-1, POSTURE_WORD_COUNT)
        stats["posture_words"] = len(words)
    return PipelineRun(records, video, stats, posture)


def run_clip_hardware(left_frames, right_frames, params: PipelineParams = PipelineParams(), *,
                      clocks: Clocks = Clocks(), fifo_depth: int = 2048,
                      emission: str = EMISSIONS[0], rectification=None):
    """A clip's 4:2:2 frames through the Verilated pipeline, as the golden model's
    :class:`sim.model.pipeline.Trajectory` (``symbol`` from the records' smoothed
    points and flags, as :func:`~sim.model.pipeline.step_symbols` does), plus the
    harness statistics. Raises RuntimeError if a frame's record is missing."""
    from hdl.gesture_pipeline import pipeline_timing
    from sim.model.pipeline import Trajectory, step_symbols

    frames = len(left_frames)
    height, width = np.shape(left_frames[0])[0], np.shape(left_frames[0])[1] // 2
    params.validate(width, height)
    flush = pipeline_timing(width, height, params, rectification).flush
    timing = clip_timing(width, height, flush, clocks)
    left_wave, right_wave = camera_waveforms(left_frames, right_frames, timing)
    run = run_pipeline(left_wave, right_wave, width, height, params, clocks=clocks,
                       fifo_depth=fifo_depth, emission=emission, rectification=rectification)
    rec = run.records
    if len(rec) != frames:
        raise RuntimeError(f"the pipeline produced {len(rec)} frame records for {frames} frames "
                           f"({run.stats})")
    smoothed = np.stack([rec["x"], rec["y"]], axis=1)
    flag = rec["flag"].astype(bool)
    posture = run.posture
    if posture is not None and len(posture) != frames:
        raise RuntimeError(f"the pipeline produced {len(posture)} posture records for "
                           f"{frames} frames ({run.stats})")
    trajectory = Trajectory(np.stack([rec["centroid_x"], rec["centroid_y"]], axis=1),
                            rec["area"].copy(), smoothed, flag, step_symbols(smoothed, flag),
                            posture)
    return trajectory, run.stats
