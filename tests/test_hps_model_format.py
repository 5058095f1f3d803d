"""sw_hps.model_format: the model file's structure, checked with the standard
library alone (the bundle does it where numpy is missing)."""
import json
import subprocess
import sys
from pathlib import Path

import pytest

from sw_hps.hmm import load_models
from sw_hps.model_format import MODEL_FORMAT, check_structure, read_structure

ROOT = Path(__file__).resolve().parents[1]
#: the HMM models (posture.json is the posture classifier's, tests/test_hps_posture.py)
SHIPPED = sorted(p for p in (ROOT / "sw_hps" / "models").glob("*.json")
                 if p.name != "posture.json")


@pytest.mark.parametrize("path", SHIPPED, ids=[p.name for p in SHIPPED])
def test_shipped_models_pass_and_agree_with_the_full_check(path):
    info = read_structure(path)
    models = load_models(path)
    assert info["class_names"] == list(models.class_names)
    assert info["emission"] == models.emission
    assert info["version"] == json.loads(path.read_text())["version"]


def _model():
    """A version 3 file (every field the format has)."""
    return json.loads((ROOT / "sw_hps" / "models" / "continuous7.json").read_text())


def _edit(**changes):
    data = _model()
    for key, value in changes.items():
        if value is KeyError:
            del data[key]
        else:
            data[key] = value
    return data


# Mistakes both checks see: the structural check says what the full one says.
SHARED_MISTAKES = [
    ("not an object", [1, 2]),
    ("format", _edit(format="stereogest-hmm2")),
    ("no format", _edit(format=KeyError)),
    ("version", _edit(version=7)),
    ("version bool", _edit(version=True)),
    ("emission", _edit(emission="poisson")),
    ("class_names not a list", _edit(class_names="forward")),
    ("models not a list", _edit(models={})),
    ("count", _edit(class_names=_model()["class_names"][:3])),
]


@pytest.mark.parametrize("case, data", SHARED_MISTAKES, ids=[c for c, _ in SHARED_MISTAKES])
def test_structural_errors_read_as_the_full_checks(tmp_path, case, data):
    path = tmp_path / "m.json"
    path.write_text(json.dumps(data))
    with pytest.raises(ValueError) as structural:
        read_structure(path)
    with pytest.raises(ValueError) as full:
        load_models(path)
    assert str(structural.value) == str(full.value)
    assert str(structural.value).startswith(f"{path}: ")


@pytest.mark.parametrize("names", [[], ["forward", "forward"], ["forward", ""], ["forward", 3]])
def test_class_names_must_be_unique_non_empty_strings(names):
    data = _edit(class_names=names, models=[{}] * len(names))
    with pytest.raises(ValueError, match="class_names must be unique and non-empty"):
        check_structure(data)


def test_a_version_1_file_is_discrete_whatever_it_says():
    data = _edit(version=1, emission="gaussian")
    assert check_structure(data)["emission"] == "discrete"
    assert check_structure(_edit(emission=KeyError))["emission"] == "discrete"


def test_unreadable_and_not_json_name_the_file(tmp_path):
    missing = tmp_path / "missing.json"
    with pytest.raises(ValueError, match=f"^{missing}: cannot read model file"):
        read_structure(missing)
    for name, raw in (("text.json", b"format: stereogest-hmm"), ("binary.json", b"\xff\xfe\x00{")):
        path = tmp_path / name
        path.write_bytes(raw)
        with pytest.raises(ValueError, match=f"^{path}: not valid JSON"):
            read_structure(path)
    assert check_structure(_model())["version"] == _model()["version"]
    assert MODEL_FORMAT == _model()["format"]


def test_imports_nothing_but_the_standard_library():
    probe = ("import sys; import sw_hps.model_format; "
             "print(sorted(m for m in sys.modules if m.split('.')[0] in ('numpy', 'sw_hps')))")
    out = subprocess.run([sys.executable, "-S", "-c", probe], cwd=str(ROOT),
                         capture_output=True, text=True, check=True)
    assert out.stdout.strip() == "['sw_hps', 'sw_hps.model_format']"
