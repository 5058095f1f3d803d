"""The board bundle: sw_hps plus a model, runnable without the rest of the project."""
import json
import subprocess
import sys
import tarfile

import numpy as np

from sw_hps.bundle import build_bundle, main
from sw_hps.gaussian_hmm import GaussianGestureModels, GaussianHMM
from sw_hps.hmm import DiscreteHMM, GestureModels, load_models, save_models

GESTURES = ("forward", "back", "right", "left", "rotate-right", "rotate-left", "stop")


def tiny_models(path):
    models = []
    for k in range(len(GESTURES)):
        b = np.full((2, 8), 0.02)
        b[:, k] = 1 - 0.02 * 7
        models.append(DiscreteHMM([1.0, 0.0], [[0.9, 0.1], [0.0, 1.0]], b))
    save_models(GestureModels(GESTURES, tuple(models)), path)
    return path


def test_bundle_runs_alone(tmp_path):
    model = tiny_models(tmp_path / "m.json")
    names = build_bundle(model, tmp_path / "b.tar.gz")
    assert {"sw_hps/app.py", "sw_hps/__main__.py", "soc/hps_interface.py", "model.json",
            "README.txt"} <= set(names)
    target = tmp_path / "board"
    with tarfile.open(tmp_path / "b.tar.gz") as tar:
        tar.extractall(target, filter="data")
    assert json.loads((target / "model.json").read_text()) == json.loads(model.read_text())
    # Isolated interpreter, only the unpacked bundle on the path: the app must
    # import with nothing of the project but sw_hps and the shared interface
    # (which imports nothing but the standard library).
    probe = (
        "import sys; sys.path.insert(0, sys.argv[1]); import sw_hps.app, sw_hps.__main__;"
        "import soc.hps_interface;"
        "bad = sorted(m for m in sys.modules if m.split('.')[0] in "
        "('sim', 'recognition', 'stereogest', 'hdl', 'soc', 'boards', 'amaranth') "
        "and m not in ('soc', 'soc.hps_interface'));"
        "assert sw_hps.__file__.startswith(sys.argv[1]), sw_hps.__file__;"
        "assert soc.hps_interface.__file__.startswith(sys.argv[1]);"
        "print(bad)")
    out = subprocess.run([sys.executable, "-I", "-c", probe, str(target)],
                         capture_output=True, text=True, check=True)
    assert out.stdout.strip() == "[]"


def test_bundle_with_a_gaussian_model_scores_alone(tmp_path):
    """The Gaussian model code (sw_hps.gaussian_hmm, sw_hps.stroke) ships in the
    bundle and scores a gesture on numpy alone, as in the project."""
    rng = np.random.default_rng(0)
    comps = []
    for _ in GESTURES:
        stay = np.r_[rng.uniform(0.3, 0.9, 2), 1.0]
        comps.append((GaussianHMM(stay, rng.normal(0, 0.5, (3, 6)), rng.uniform(0.2, 1, (3, 6))),))
    path = tmp_path / "g.json"
    save_models(GaussianGestureModels(GESTURES, comps, 10, np.ones(6), [-50.0] * 7), path)
    names = build_bundle(path, tmp_path / "b.tar.gz")
    assert {"sw_hps/gaussian_hmm.py", "sw_hps/stroke.py"} <= set(names)
    target = tmp_path / "board"
    with tarfile.open(tmp_path / "b.tar.gz") as tar:
        tar.extractall(target, filter="data")
    points = [[100, 100], [140, 90], [180, 120], [200, 180], [170, 230]]
    probe = (
        "import sys, json; sys.path.insert(0, sys.argv[1]); import sw_hps.app;"
        "from sw_hps.hmm import load_models;"
        "m = load_models(sys.argv[1] + '/model.json');"
        "scores = m.scores_of_points(json.loads(sys.argv[2]));"
        "bad = sorted(k for k in sys.modules if k.split('.')[0] in "
        "('sim', 'recognition', 'stereogest', 'hdl', 'soc', 'boards', 'amaranth') "
        "and k not in ('soc', 'soc.hps_interface'));"
        "assert sys.modules['sw_hps.gaussian_hmm'].__file__.startswith(sys.argv[1]);"
        "print(json.dumps({'emission': m.emission, 'scores': scores.tolist(),"
        " 'decision': m.decide(scores)[0], 'bad': bad}))")
    out = subprocess.run([sys.executable, "-I", "-c", probe, str(target), json.dumps(points)],
                         capture_output=True, text=True, check=True)
    result = json.loads(out.stdout)
    assert result["emission"] == "gaussian" and result["bad"] == []
    expected = load_models(path).scores_of_points(points)
    assert np.allclose(result["scores"], expected, rtol=1e-12)
    assert result["decision"] == load_models(path).decide(expected)[0]


def test_bundle_refuses_a_bad_model(tmp_path, capsys):
    bad = tmp_path / "bad.json"
    bad.write_text("{}")
    assert main(["--model", str(bad), "-o", str(tmp_path / "b.tar.gz")]) == 2
    assert "format" in capsys.readouterr().err
    assert not (tmp_path / "b.tar.gz").exists()
