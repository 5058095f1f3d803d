"""The board's Python floor (``sw_hps.REQUIRED_PYTHON`` / ``REQUIRED_NUMPY``):

- the start-up check: one line and exit status 2 on an older Python (run with the
  pyenv 2.7/3.5/3.6 interpreters where they exist), with an old numpy or none;
- a static guard under the dev Python: every shipped module parses as Python 3.7
  (``ast.parse(feature_version=...)``) and uses no library call newer than the
  floor from a list of the likely ones (:data:`NEWER_APIS`);
- the board application's tests run on the floor itself: a venv of the oldest
  pyenv Python 3.7 with numpy 1.16 (built once under ``build/hps-floor/``).
"""
from __future__ import annotations

import ast
import fcntl
import os
import re
import shutil
import subprocess
import sys
from pathlib import Path

import pytest

import sw_hps
from sw_hps import REQUIRED_NUMPY, REQUIRED_PYTHON, floor_problem
from sw_hps.bundle import SHARED

ROOT = Path(__file__).resolve().parent.parent
SW_HPS = ROOT / "sw_hps"
#: The floor's test environment: the newest numpy of the floor's minor release (a
#: cp37 manylinux wheel on PyPI), and the last pytest and hypothesis for Python 3.7.
FLOOR_PINS = {"numpy": "1.16.6", "pytest": "7.4.4", "hypothesis": "6.79.4"}
#: Test files that must be among those run on the floor (more are picked up by
#: :func:`floor_test_files`).
BOARD_TEST_FILES = ("test_hps_bus.py", "test_hps_hmm.py", "test_hps_robot.py",
                    "test_hps_continuous.py", "test_hps_stroke.py", "test_hps_app.py",
                    "test_hps_app_faults.py", "test_hps_bundle.py")
#: Besides the standard library, what a test file may import to run on the floor.
FLOOR_IMPORTABLE = ("numpy", "pytest", "hypothesis", "sw_hps", "soc.hps_interface",
                    "sim.gesture_shapes")
#: pip's words for "the index cannot be reached" (the floor test then skips).
OFFLINE_SIGNS = ("NewConnectionError", "Max retries exceeded", "Temporary failure in name "
                 "resolution", "Name or service not known", "Network is unreachable",
                 "ProxyError", "ConnectTimeout", "Connection refused")


def _dotted(version) -> str:
    return ".".join(str(part) for part in version)


def shipped_files() -> list[Path]:
    """Every Python file the bundle ships: the package and the shared interface."""
    files = sorted(p for p in SW_HPS.rglob("*.py") if "__pycache__" not in p.parts)
    return files + [ROOT / name for name in SHARED]


# ---- the start-up check -----------------------------------------------------------------
@pytest.mark.parametrize("python,numpy,complaint", [
    ((3, 7, 3), "1.16.2", None),                       # Debian 10 "buster"
    ((3, 11, 7), "2.3.1", None),
    ((3, 7, 0), "1.16.0.dev0+abc123", None),
    ((3, 13, 0), "2.1.0rc1", None),
    ((3, 6, 15), "1.13.3", "found Python 3.6.15, numpy 1.13.3"),
    ((2, 7, 18), None, "found Python 2.7.18, no numpy"),
    ((3, 7, 16), "1.15.4", "found Python 3.7.16, numpy 1.15.4"),
    ((3, 11, 7), None, "found Python 3.11.7, no numpy"),
    ((3, 8, 0), "unknown", "found Python 3.8.0, numpy unknown"),
])
def test_floor_problem(python, numpy, complaint):
    problem = floor_problem(python, numpy)
    if complaint is None:
        assert problem is None
    else:
        assert problem == ("sw_hps: error: needs Python >= 3.7 and numpy >= 1.16 (%s); "
                           "on Debian/Ubuntu: apt install python3 python3-numpy" % complaint)


def test_the_floor_is_debian_buster():
    assert (REQUIRED_PYTHON, REQUIRED_NUMPY) == ((3, 7), (1, 16))
    assert tuple(int(p) for p in FLOOR_PINS["numpy"].split("."))[:2] == REQUIRED_NUMPY


def test_the_package_init_parses_on_old_pythons():
    """The check runs before any module written for 3.7 is compiled, so
    sw_hps/__init__.py must itself parse on Python 2.7 and 3.5 (checked here
    without those interpreters; the subprocess tests below run them)."""
    tree = ast.parse((SW_HPS / "__init__.py").read_text())
    newer = (ast.JoinedStr, ast.AnnAssign, ast.Nonlocal, ast.YieldFrom, ast.AsyncFunctionDef,
             ast.Await)
    for node in ast.walk(tree):
        where = f"sw_hps/__init__.py:{getattr(node, 'lineno', '?')}"
        assert not isinstance(node, newer), f"{where}: {type(node).__name__}"
        if isinstance(node, ast.FunctionDef):
            args = node.args
            assert node.returns is None and not args.kwonlyargs, where
            assert all(a.annotation is None for a in args.args), where
        assert not (isinstance(node, ast.Raise) and node.cause is not None), where
        assert not (isinstance(node, ast.ImportFrom) and node.module == "__future__"), where


def _run_module(python, *args, env=None):
    return subprocess.run([str(python), *args], cwd=ROOT, capture_output=True, text=True,
                          timeout=120, env=env)


def _clean_env(**extra) -> dict[str, str]:
    env = {k: v for k, v in os.environ.items() if k not in ("PYTHONPATH", "PYTHONHOME")}
    env.update(extra)
    return env


def _assert_one_line(done, found):
    assert done.returncode == 2, done.stderr
    assert done.stdout == ""
    lines = done.stderr.splitlines()
    assert len(lines) == 1 and "Traceback" not in done.stderr, done.stderr
    assert lines[0].startswith("sw_hps: error: needs Python >= 3.7 and numpy >= 1.16 (found ")
    assert found in lines[0]
    assert lines[0].endswith("); on Debian/Ubuntu: apt install python3 python3-numpy")


def test_old_numpy_gives_one_line(tmp_path):
    fake = tmp_path / "numpy"
    fake.mkdir()
    (fake / "__init__.py").write_text('__version__ = "1.13.3"\n')
    done = _run_module(sys.executable, "-m", "sw_hps", "--help",
                       env=_clean_env(PYTHONPATH=str(tmp_path)))
    _assert_one_line(done, "Python %s, numpy 1.13.3" % _dotted(sys.version_info[:3]))


def test_missing_numpy_gives_one_line():
    # -S: no site-packages, hence no numpy; sw_hps comes from the working directory.
    done = _run_module(sys.executable, "-S", "-m", "sw_hps", "--help", env=_clean_env())
    _assert_one_line(done, "Python %s, no numpy" % _dotted(sys.version_info[:3]))


def test_the_bundle_builder_does_not_need_numpy(tmp_path):
    """Only ``python -m sw_hps`` checks numpy: importing the package does not."""
    done = _run_module(sys.executable, "-S", "-c",
                       "import sys, sw_hps; print(sw_hps.REQUIRED_PYTHON, 'numpy' in sys.modules)",
                       env=_clean_env())
    assert done.returncode == 0, done.stderr
    assert done.stdout.strip() == "(3, 7) False"


def pyenv_root() -> Path:
    if os.environ.get("PYENV_ROOT"):
        return Path(os.environ["PYENV_ROOT"])
    if shutil.which("pyenv"):
        done = subprocess.run(["pyenv", "root"], capture_output=True, text=True, timeout=30)
        if done.returncode == 0 and done.stdout.strip():
            return Path(done.stdout.strip())
    return Path.home() / ".pyenv"


def pyenv_pythons() -> dict[tuple[int, ...], Path]:
    """The pyenv interpreters by version (plain ``X.Y.Z`` installs only)."""
    found = {}
    versions = pyenv_root() / "versions"
    if versions.is_dir():
        for entry in versions.iterdir():
            python = entry / "bin" / "python"
            if re.fullmatch(r"\d+\.\d+\.\d+", entry.name) and python.exists():
                found[tuple(int(p) for p in entry.name.split("."))] = python
    return found


@pytest.mark.parametrize("minor", [(2, 7), (3, 5), (3, 6)])
def test_an_older_python_gives_one_line(minor):
    """On Python 3.6 ``python3 -m sw_hps`` used to stop at a SyntaxError from
    ``from __future__ import annotations``; now: one line, status 2."""
    candidates = sorted(v for v in pyenv_pythons() if v[:2] == minor)
    if not candidates:
        pytest.skip(f"no pyenv Python {_dotted(minor)} (pyenv install {_dotted(minor)})")
    version = candidates[-1]
    done = _run_module(pyenv_pythons()[version], "-m", "sw_hps", "--help", env=_clean_env())
    _assert_one_line(done, "found Python %s, " % _dotted(version))


# ---- static guard: what the dev Python can tell about the floor ------------------------------
def test_shipped_modules_parse_as_the_floor_python():
    for path in shipped_files():
        try:
            ast.parse(path.read_text(), filename=str(path), feature_version=REQUIRED_PYTHON)
        except SyntaxError as exc:
            pytest.fail(f"{path.relative_to(ROOT)}:{exc.lineno}: {exc.msg}")


#: Library names newer than the floor that board code is likely to reach for:
#: dotted name -> (library, version that added it).
NEWER_APIS = {
    "math.prod": ("Python", (3, 8)), "math.isqrt": ("Python", (3, 8)),
    "math.comb": ("Python", (3, 8)), "math.dist": ("Python", (3, 8)),
    "math.lcm": ("Python", (3, 9)), "statistics.fmean": ("Python", (3, 8)),
    "functools.cached_property": ("Python", (3, 8)), "functools.cache": ("Python", (3, 9)),
    "shlex.join": ("Python", (3, 8)), "importlib.metadata": ("Python", (3, 8)),
    "typing.Protocol": ("Python", (3, 8)), "typing.Literal": ("Python", (3, 8)),
    "typing.Final": ("Python", (3, 8)), "typing.TypedDict": ("Python", (3, 8)),
    "typing.runtime_checkable": ("Python", (3, 8)), "typing.get_args": ("Python", (3, 8)),
    "signal.strsignal": ("Python", (3, 8)), "signal.raise_signal": ("Python", (3, 8)),
    "signal.valid_signals": ("Python", (3, 8)), "threading.get_native_id": ("Python", (3, 8)),
    "os.waitstatus_to_exitcode": ("Python", (3, 9)), "argparse.BooleanOptionalAction":
    ("Python", (3, 9)), "itertools.pairwise": ("Python", (3, 10)),
    "sys.stdlib_module_names": ("Python", (3, 10)), "contextlib.chdir": ("Python", (3, 11)),
    "enum.StrEnum": ("Python", (3, 11)), "zoneinfo": ("Python", (3, 9)),
    "graphlib": ("Python", (3, 9)), "tomllib": ("Python", (3, 11)),
    "numpy.random.default_rng": ("numpy", (1, 17)), "numpy.random.Generator": ("numpy", (1, 17)),
    "numpy.lib.stride_tricks.sliding_window_view": ("numpy", (1, 20)),
    "numpy.typing": ("numpy", (1, 20)), "numpy.exceptions": ("numpy", (1, 25)),
    "numpy.trapezoid": ("numpy", (2, 0)), "numpy.concat": ("numpy", (2, 0)),
    "numpy.pow": ("numpy", (2, 0)), "numpy.astype": ("numpy", (2, 0)),
    "numpy.vecdot": ("numpy", (2, 0)), "numpy.cumulative_sum": ("numpy", (2, 1)),
}
#: Methods newer than the floor, whatever their object: name -> (library, version).
NEWER_METHODS = {"removeprefix": ("Python", (3, 9)), "removesuffix": ("Python", (3, 9)),
                 "is_relative_to": ("Python", (3, 9)), "with_stem": ("Python", (3, 9)),
                 "bit_count": ("Python", (3, 10))}
#: Keyword arguments newer than the floor: (function or method, keyword) -> (library, version).
NEWER_KEYWORDS = {
    ("unlink", "missing_ok"): ("Python", (3, 8)), ("basicConfig", "force"): ("Python", (3, 8)),
    ("copytree", "dirs_exist_ok"): ("Python", (3, 8)), ("zip", "strict"): ("Python", (3, 10)),
    ("dataclass", "slots"): ("Python", (3, 10)), ("dataclass", "kw_only"): ("Python", (3, 10)),
    ("extractall", "filter"): ("Python", (3, 8, 17)), ("percentile", "method"): ("numpy", (1, 22)),
    ("quantile", "method"): ("numpy", (1, 22)), ("unique", "equal_nan"): ("numpy", (1, 24)),
    ("sum", "where"): ("numpy", (1, 17)), ("mean", "where"): ("numpy", (1, 20)),
    ("concatenate", "dtype"): ("numpy", (1, 20)),
}
_BUILTIN_GENERICS = {"list", "dict", "tuple", "set", "frozenset", "type"}
_GUARD_ERRORS = {"ImportError", "ModuleNotFoundError", "AttributeError", "Exception"}


def _newer(library, version) -> bool:
    return version > (REQUIRED_PYTHON if library == "Python" else REQUIRED_NUMPY)


class NewerApiFinder(ast.NodeVisitor):
    """Uses of :data:`NEWER_APIS`, :data:`NEWER_METHODS` and :data:`NEWER_KEYWORDS`
    beyond the floor, ``bytes.hex(sep)`` (3.8), ``numpy.pad`` without a mode (1.17)
    and ``list[int]``-style subscripts evaluated at run time (3.9). Code under a
    ``try`` that catches ImportError/AttributeError, or under an ``if`` that tests
    ``sys.version_info`` or ``hasattr``, counts as guarded."""

    def __init__(self, postponed_annotations: bool):
        self.postponed = postponed_annotations
        self.aliases: dict[str, str] = {}
        self.found: list[str] = []
        self.guarded = 0

    def report(self, node, text, library, version):
        if _newer(library, version) and not self.guarded:
            self.found.append(f"{node.lineno}: {text} needs {library} {_dotted(version)}")

    def dotted(self, node) -> str | None:
        parts = []
        while isinstance(node, ast.Attribute):
            parts.append(node.attr)
            node = node.value
        if not isinstance(node, ast.Name):
            return None
        return ".".join([self.aliases.get(node.id, node.id), *reversed(parts)])

    def check_name(self, node, name):
        for known, (library, version) in NEWER_APIS.items():
            if name == known or name.startswith(known + "."):
                self.report(node, name, library, version)

    def visit_Import(self, node):
        for alias in node.names:
            self.aliases[(alias.asname or alias.name).split(".")[0]] = \
                alias.name if alias.asname else alias.name.split(".")[0]
            self.check_name(node, alias.name)

    def visit_ImportFrom(self, node):
        for alias in node.names:
            if node.level == 0 and node.module:
                self.aliases[alias.asname or alias.name] = f"{node.module}.{alias.name}"
                self.check_name(node, f"{node.module}.{alias.name}")

    def visit_Attribute(self, node):
        name = self.dotted(node)
        if name is not None:
            self.check_name(node, name)
        if node.attr in NEWER_METHODS:
            self.report(node, "." + node.attr, *NEWER_METHODS[node.attr])
        self.generic_visit(node)

    def visit_Call(self, node):
        func = node.func
        name = func.attr if isinstance(func, ast.Attribute) else getattr(func, "id", None)
        for keyword in node.keywords:
            if (name, keyword.arg) in NEWER_KEYWORDS:
                self.report(node, f"{name}({keyword.arg}=)", *NEWER_KEYWORDS[name, keyword.arg])
        if name == "hex" and isinstance(func, ast.Attribute) and (node.args or node.keywords):
            self.report(node, "bytes.hex(sep)", "Python", (3, 8))
        if self.dotted(func) == "numpy.pad" and len(node.args) < 3 \
                and not any(k.arg == "mode" for k in node.keywords):
            self.report(node, "numpy.pad without mode", "numpy", (1, 17))
        self.generic_visit(node)

    def visit_Subscript(self, node):
        if isinstance(node.value, ast.Name) and node.value.id in _BUILTIN_GENERICS:
            self.report(node, f"{node.value.id}[...] at run time", "Python", (3, 9))
        self.generic_visit(node)

    def _guarded(self, statements):
        self.guarded += 1
        for statement in statements:
            self.visit(statement)
        self.guarded -= 1

    def visit_Try(self, node):
        names = set()
        for handler in node.handlers:
            for sub in ast.walk(handler.type) if handler.type is not None else ():
                if isinstance(sub, ast.Name):
                    names.add(sub.id)
        if names & _GUARD_ERRORS:
            self._guarded(node.body)
        else:
            for statement in node.body:
                self.visit(statement)
        for part in (node.handlers, node.orelse, node.finalbody):
            for statement in part:
                self.visit(statement)

    def visit_If(self, node):
        test = ast.dump(node.test)
        self.visit(node.test)
        if "version_info" in test or "'hasattr'" in test:
            self._guarded(node.body)
        else:
            for statement in node.body:
                self.visit(statement)
        for statement in node.orelse:
            self.visit(statement)

    def _function(self, node):
        for part in (node.decorator_list, node.args.defaults, node.args.kw_defaults, node.body):
            for child in part:
                if child is not None:
                    self.visit(child)
        if not self.postponed:    # annotations evaluated when the def runs
            for arg in [*node.args.args, *node.args.kwonlyargs, node.args.vararg,
                        node.args.kwarg]:
                if arg is not None and arg.annotation is not None:
                    self.visit(arg.annotation)
            if node.returns is not None:
                self.visit(node.returns)

    visit_FunctionDef = visit_AsyncFunctionDef = _function

    def visit_AnnAssign(self, node):
        for child in (node.target, node.value):
            if child is not None:
                self.visit(child)
        if not self.postponed:
            self.visit(node.annotation)


def newer_apis(source: str) -> list[str]:
    """Lines of ``source`` that need more than the floor (:class:`NewerApiFinder`)."""
    tree = ast.parse(source)
    postponed = any(isinstance(n, ast.ImportFrom) and n.module == "__future__"
                    and any(a.name == "annotations" for a in n.names) for n in tree.body)
    finder = NewerApiFinder(postponed)
    finder.visit(tree)
    return finder.found


def test_the_guard_finds_what_it_looks_for():
    source = '''
import math
import numpy as np
from functools import cached_property
from typing import Protocol
try:
    from typing import Literal
except ImportError:
    Literal = None
if hasattr(math, "isqrt"):
    root = math.isqrt(9)
ALIAS = tuple[int, int]
def f(path, data: list[int]) -> dict[str, int]:
    path.unlink(missing_ok=True)
    np.random.default_rng(0)
    np.pad(data, 2)
    np.pad(data, 2, "edge")
    return data.hex(" "), data.hex(), "x".removeprefix("y"), math.prod(data)
'''
    found = newer_apis(source)
    expected = ["4: functools.cached_property needs Python 3.8",
                "5: typing.Protocol needs Python 3.8",
                "12: tuple[...] at run time needs Python 3.9",
                "13: list[...] at run time needs Python 3.9",
                "13: dict[...] at run time needs Python 3.9",
                "14: unlink(missing_ok=) needs Python 3.8",
                "15: numpy.random.default_rng needs numpy 1.17",
                "16: numpy.pad without mode needs numpy 1.17",
                "18: bytes.hex(sep) needs Python 3.8",
                "18: .removeprefix needs Python 3.9",
                "18: math.prod needs Python 3.8"]
    assert sorted(found) == sorted(expected)
    # postponed annotations are never evaluated; a runtime alias still is
    postponed = newer_apis("from __future__ import annotations\nALIAS = tuple[int, int]\n"
                           "def f(data: list[int]) -> dict[str, int]:\n    return data\n")
    assert postponed == ["2: tuple[...] at run time needs Python 3.9"]


@pytest.mark.parametrize("path", shipped_files(), ids=lambda p: str(p.relative_to(ROOT)))
def test_shipped_modules_use_nothing_newer_than_the_floor(path):
    assert newer_apis(path.read_text()) == []


# ---- the board's tests on the floor ----------------------------------------------------------
def _module_imports(tree) -> list[str]:
    """Modules a test file imports when it is collected (module level, also under
    a top-level ``try``/``if``)."""
    names = []
    pending = list(tree.body)
    while pending:
        node = pending.pop()
        if isinstance(node, ast.Import):
            names += [alias.name for alias in node.names]
        elif isinstance(node, ast.ImportFrom) and node.level == 0 and node.module:
            names.append(node.module)
        elif isinstance(node, (ast.Try, ast.If)):
            pending += [*node.body, *node.orelse, *getattr(node, "handlers", ()),
                        *getattr(node, "finalbody", ())]
        elif isinstance(node, ast.ExceptHandler):
            pending += node.body
    return names


def floor_test_files() -> list[str]:
    """The ``tests/test_hps_*.py`` files that import nothing beyond the standard
    library, :data:`FLOOR_IMPORTABLE` and each other (this file excepted)."""
    tests = ROOT / "tests"
    candidates = {p.name: _module_imports(ast.parse(p.read_text()))
                  for p in sorted(tests.glob("test_hps_*.py")) if p.name != Path(__file__).name}

    def allowed(name, chosen):
        top = name.split(".")[0]
        if name.startswith("tests."):
            return name.split(".")[1] + ".py" in chosen
        return top in sys.stdlib_module_names or any(
            name == m or name.startswith(m + ".") for m in FLOOR_IMPORTABLE) \
            or name in ("soc", "sim")

    chosen = set(candidates)
    while True:       # drop files until every kept file's imports are allowed
        keep = {f for f in chosen if all(allowed(n, chosen) for n in candidates[f])}
        if keep == chosen:
            return sorted(chosen)
        chosen = keep


def test_the_board_tests_are_chosen_for_the_floor():
    chosen = floor_test_files()
    assert set(BOARD_TEST_FILES) <= set(chosen), set(BOARD_TEST_FILES) - set(chosen)
    assert "test_hps_gaussian_hmm.py" not in chosen         # hmmlearn: a dev oracle


def floor_interpreter() -> Path:
    """The oldest pyenv interpreter at or above the floor; skip unless it is the floor."""
    versions = sorted(v for v in pyenv_pythons() if v[:2] >= REQUIRED_PYTHON)
    if not versions or versions[0][:2] != REQUIRED_PYTHON:
        pytest.skip(f"no Python {_dotted(REQUIRED_PYTHON)} under {pyenv_root()}/versions: "
                    f"install one with `pyenv install {_dotted(REQUIRED_PYTHON)}` "
                    "(https://github.com/pyenv/pyenv) to run the board's tests on its floor")
    return pyenv_pythons()[versions[0]]


@pytest.fixture(scope="module")
def floor_python():
    """A venv of the floor Python with :data:`FLOOR_PINS`, built once per versions
    under ``build/hps-floor/`` and shared by later runs (a file lock keeps two
    pytest processes from building it at the same time)."""
    base = floor_interpreter()
    version = base.parent.parent.name
    key = f"python{version}-" + "-".join(f"{k}{v}" for k, v in sorted(FLOOR_PINS.items()))
    home = ROOT / "build" / "hps-floor"
    home.mkdir(parents=True, exist_ok=True)
    venv = home / key
    stamp = venv / "complete"
    with open(home / (key + ".lock"), "w") as lock:
        fcntl.flock(lock, fcntl.LOCK_EX)
        if not stamp.exists():
            shutil.rmtree(venv, ignore_errors=True)     # a build cut short
            made = subprocess.run([str(base), "-m", "venv", str(venv)], capture_output=True,
                                  text=True, timeout=300)
            assert made.returncode == 0, f"python {version} -m venv failed: {made.stderr}"
            pins = [f"{name}=={pin}" for name, pin in sorted(FLOOR_PINS.items())]
            pip = subprocess.run([str(venv / "bin" / "python"), "-m", "pip", "install",
                                  "--quiet", "--retries", "1", "--timeout", "60", *pins],
                                 capture_output=True, text=True, timeout=1200)
            if pip.returncode != 0:
                output = pip.stdout + pip.stderr
                shutil.rmtree(venv, ignore_errors=True)
                errors = [line for line in output.splitlines() if line.startswith("ERROR")]
                if any(sign in output for sign in OFFLINE_SIGNS):
                    pytest.skip(f"PyPI unreachable, cannot install {' '.join(pins)}: "
                                f"{(errors or ['?'])[-1]}")
                pytest.fail(f"pip install {' '.join(pins)} failed:\n{output[-3000:]}")
            stamp.write_text(" ".join(pins) + "\n")
    return venv / "bin" / "python"


def test_the_floor_venv_has_the_floor(floor_python):
    done = subprocess.run([str(floor_python), "-c", "import sys, numpy; print("
                           "'%d.%d' % sys.version_info[:2], numpy.__version__)"],
                          capture_output=True, text=True, timeout=120)
    assert done.returncode == 0, done.stderr
    assert done.stdout.split() == [_dotted(REQUIRED_PYTHON), FLOOR_PINS["numpy"]]


def test_the_board_tests_pass_on_the_floor(floor_python):
    files = [f"tests/{name}" for name in floor_test_files()]
    # No .pyc files or pytest cache from the old Python in the tree; the project's
    # addopts are the dev pytest's; a test stuck for a minute gets its stack dumped.
    command = [str(floor_python), "-m", "pytest", "-q", "-p", "no:cacheprovider",
               "-o", "addopts=", "-o", "faulthandler_timeout=60", "-rfEs", "--tb=short", *files]
    try:
        done = subprocess.run(command, cwd=ROOT, capture_output=True, text=True, timeout=900,
                              env=_clean_env(PYTHONDONTWRITEBYTECODE="1"))
    except subprocess.TimeoutExpired as exc:
        out, err = (text.decode(errors="replace") if isinstance(text, bytes) else text or ""
                    for text in (exc.stdout, exc.stderr))
        pytest.fail(f"the board tests on Python {_dotted(REQUIRED_PYTHON)} ran over "
                    f"{exc.timeout} s:\n{out[-3000:]}\n{err[-6000:]}")
    summary = done.stdout.strip().splitlines()[-1] if done.stdout.strip() else ""
    assert done.returncode == 0, f"on Python {_dotted(REQUIRED_PYTHON)}:\n" \
        f"{done.stdout[-6000:]}\n{done.stderr[-2000:]}"
    passed = re.search(r"(\d+) passed", summary)
    assert passed and int(passed.group(1)) > 0, summary
    print(f"board tests on Python {_dotted(REQUIRED_PYTHON)} + numpy {FLOOR_PINS['numpy']}: "
          f"{summary} ({len(files)} files)")
