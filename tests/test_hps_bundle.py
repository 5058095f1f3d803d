"""The board bundle: sw_hps plus a model, runnable without the rest of the project."""
import json
import subprocess
import sys
import tarfile

import numpy as np

from sw_hps.bundle import build_bundle, main
from sw_hps.hmm import DiscreteHMM, GestureModels, save_models

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
    assert {"sw_hps/app.py", "sw_hps/__main__.py", "model.json", "README.txt"} <= set(names)
    target = tmp_path / "board"
    with tarfile.open(tmp_path / "b.tar.gz") as tar:
        tar.extractall(target, filter="data")
    assert json.loads((target / "model.json").read_text()) == json.loads(model.read_text())
    # Isolated interpreter, only the unpacked bundle on the path: the app must
    # import with nothing of the project but sw_hps.
    probe = (
        "import sys; sys.path.insert(0, sys.argv[1]); import sw_hps.app, sw_hps.__main__;"
        "bad = sorted(m for m in sys.modules if m.split('.')[0] in "
        "('sim', 'recognition', 'stereogest', 'hdl', 'soc', 'boards'));"
        "assert sw_hps.__file__.startswith(sys.argv[1]), sw_hps.__file__;"
        "print(bad)")
    out = subprocess.run([sys.executable, "-I", "-c", probe, str(target)],
                         capture_output=True, text=True, check=True)
    assert out.stdout.strip() == "[]"


def test_bundle_refuses_a_bad_model(tmp_path, capsys):
    bad = tmp_path / "bad.json"
    bad.write_text("{}")
    assert main(["--model", str(bad), "-o", str(tmp_path / "b.tar.gz")]) == 2
    assert "format" in capsys.readouterr().err
    assert not (tmp_path / "b.tar.gz").exists()
