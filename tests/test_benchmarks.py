"""Smoke tests of the benchmark scripts (benchmarks/ is not a package)."""
from __future__ import annotations

import importlib.util
import json
from pathlib import Path

import pytest

BENCHMARKS = Path(__file__).resolve().parent.parent / "benchmarks"


def load_script(name: str):
    spec = importlib.util.spec_from_file_location(f"bench_{name}", BENCHMARKS / f"{name}.py")
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def test_bench_hmm_quick_prints_json(capsys):
    pytest.importorskip("hmmlearn")
    bench = load_script("bench_hmm")
    assert bench.main(["--quick"]) == 0
    out = capsys.readouterr().out
    result = json.loads(out.strip().splitlines()[-1])
    assert {"symbols", "models", "states", "us", "update_us_per_symbol",
            "classify_vs_hmmlearn", "max_abs_difference", "timer", "gaussian",
            "table"} <= result.keys()
    assert result["timer"] == "process_time"
    assert result["max_abs_difference"] < 1e-9
    assert {"GestureModels.classify", "ForwardStream reset+feed",
            "ForwardStream reset+60 update", "hmmlearn 7 x score"} <= result["us"].keys()
    assert set(result["gaussian"]) == set(bench.GAUSSIAN_SETTINGS)
    for name, (classes, components, states) in bench.GAUSSIAN_SETTINGS.items():
        g = result["gaussian"][name]
        assert (g["classes"], g["components"], g["states"]) == (classes, components, states)
        assert g["feature_vectors"] == 63 and g["resample"] == 64
        assert {"scores_of_points", "stroke_features", "scores_of_features",
                "hmmlearn 1 x score"} <= g["us"].keys()
        assert g["hmmlearn_us_per_gesture"] > 0 and g["per_point_us"] > 0
        assert g["model_bytes"] > 0 and g["max_abs_emission_difference"] < 1e-9
    assert [r["setting"] for r in result["table"]] == \
        ["discrete (thesis)"] + [f"gaussian {n}" for n in bench.GAUSSIAN_SETTINGS]
    assert "| setting | classes x components x states |" in out
