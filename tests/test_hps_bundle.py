"""The board bundle: sw_hps plus a model, runnable without the rest of the project."""
import io
import json
import os
import re
import shutil
import signal
import stat
import subprocess
import sys
import tarfile
import time
from pathlib import Path

import numpy as np
import pytest

from sw_hps.bundle import DOCS, SERVICE, SERVICE_FILES, build_bundle, bundle_files, main
from sw_hps.gaussian_hmm import GaussianGestureModels, GaussianHMM
from sw_hps.hmm import DiscreteHMM, GestureModels, load_models, save_models

GESTURES = ("forward", "back", "right", "left", "rotate-right", "rotate-left", "stop")
#: tarfile's "data" filter where it exists (3.8.17+/3.9.17+/3.10.12+/3.11.4+; not on
#: the 3.7 floor, which extracts only the bundle this test built).
SAFE_EXTRACT = {"filter": "data"} if hasattr(tarfile, "data_filter") else {}


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
        tar.extractall(target, **SAFE_EXTRACT)
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
    rng = np.random.RandomState(0)   # legacy stream: same draws on the board's numpy 1.16
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
        tar.extractall(target, **SAFE_EXTRACT)
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


# --- Building with the standard library alone, real mtimes, the deploy ------------------

ROOT = Path(__file__).resolve().parents[1]
#: The bundle's shell scripts: name in the bundle -> source in the repository.
SCRIPTS = {"install.sh": "sw_hps/service/install.sh",
           SERVICE + "/wait-core": SERVICE + "/wait-core",
           SERVICE + "/stereogest.init": SERVICE + "/stereogest.init"}
needs_sh = pytest.mark.skipif(shutil.which("sh") is None or shutil.which("tar") is None,
                              reason="needs a POSIX sh and tar, as the board has")


def clean_env(**extra):
    """The environment without what would change how Python finds or caches modules."""
    env = {k: v for k, v in os.environ.items()
           if k not in ("PYTHONPATH", "PYTHONHOME", "PYTHONDONTWRITEBYTECODE", "PYTHONSTARTUP",
                        "MAKEFLAGS", "MAKELEVEL", "MFLAGS")}
    env.update(extra)
    return env


def source_root(tmp_path):
    """A copy of what the bundle is built from (sw_hps, soc's shared files), to edit."""
    root = tmp_path / "src"
    shutil.copytree(str(ROOT / "sw_hps"), str(root / "sw_hps"),
                    ignore=shutil.ignore_patterns("__pycache__", "*.pyc"))
    (root / "soc").mkdir()
    for name in ("soc/__init__.py", "soc/hps_interface.py"):
        shutil.copy2(str(ROOT / name), str(root / name))
    return root


def members(path):
    with tarfile.open(path) as tar:
        return {m.name: m for m in tar.getmembers()}


def test_bundle_builds_with_the_standard_library_alone(tmp_path):
    """`make hps-bundle` runs on the system Python: -S leaves out site-packages
    (numpy, the development environment), so only the standard library is there."""
    no_numpy = subprocess.run([sys.executable, "-S", "-c", "import numpy"], env=clean_env(),
                              capture_output=True, text=True)
    assert no_numpy.returncode != 0, "numpy importable without site-packages: test is moot"
    imported = subprocess.run(
        [sys.executable, "-S", "-c", "import sys, sw_hps.bundle; print(sorted(m for m in "
         "sys.modules if m.split('.')[0] in ('sw_hps', 'numpy', 'soc')))"],
        cwd=str(ROOT), env=clean_env(), capture_output=True, text=True, check=True)
    assert imported.stdout.split() == ["['sw_hps',", "'sw_hps.bundle',", "'sw_hps.model_format']"]

    model = tiny_models(tmp_path / "m.json")
    out = tmp_path / "b.tar.gz"
    run = subprocess.run([sys.executable, "-S", "-m", "sw_hps.bundle", "--model", str(model),
                          "-o", str(out)], cwd=str(ROOT), env=clean_env(),
                         capture_output=True, text=True)
    assert run.returncode == 0, run.stderr
    assert "discrete model, 7 classes" in run.stdout
    assert "the full check runs on the board at start" in run.stdout
    assert {"sw_hps/__main__.py", "soc/hps_interface.py", "model.json", "install.sh",
            "README.txt"} <= set(members(out))

    # Without numpy the structure is still checked: one line, exit 2, nothing written.
    bad = tmp_path / "bad.json"
    data = json.loads(model.read_text())
    data["class_names"] = data["class_names"][:-1]
    bad.write_text(json.dumps(data))
    run = subprocess.run([sys.executable, "-S", "-m", "sw_hps.bundle", "--model", str(bad),
                          "-o", str(tmp_path / "bad.tar.gz")], cwd=str(ROOT), env=clean_env(),
                         capture_output=True, text=True)
    assert run.returncode == 2
    assert run.stderr.strip().splitlines() == [
        f"sw_hps.bundle: error: {bad}: 6 class_names but 7 models"]
    assert not (tmp_path / "bad.tar.gz").exists()
    assert not (tmp_path / "bad.tar.gz.part").exists()


def test_make_hps_bundle_needs_no_development_environment():
    if shutil.which("make") is None:
        pytest.skip("make is not installed")
    plan = subprocess.run(["make", "-n", "-C", str(ROOT), "hps-bundle", "PYTHON=sys-python"],
                          env=clean_env(), capture_output=True, text=True, check=True)
    commands = [line for line in plan.stdout.splitlines() if not line.startswith("make")]
    assert commands == ["sys-python -m sw_hps.bundle --model sw_hps/models/gestures7.json "
                        "-o build/stereogest-hps.tar.gz"]


def test_bundle_members_have_real_mtimes_modes_and_no_pycache(tmp_path):
    root = source_root(tmp_path)
    # What a development tree holds besides the sources: none of it ships.
    (root / "sw_hps" / "__pycache__").mkdir()
    (root / "sw_hps" / "__pycache__" / "app.cpython-311.pyc").write_bytes(b"\0" * 16)
    (root / "sw_hps" / "service" / "__pycache__").mkdir()
    (root / "sw_hps" / "service" / "__pycache__" / "x.pyc").write_bytes(b"\0" * 16)
    old = time.time() - 3 * 86400
    os.utime(str(root / "sw_hps" / "fifo.py"), (old, old))
    model = tiny_models(tmp_path / "m.json")
    before = int(time.time())
    names = build_bundle(model, tmp_path / "b.tar.gz", root=root)
    after = time.time()
    found = members(tmp_path / "b.tar.gz")
    assert names == sorted(names) and list(found) == names  # written in sorted order
    assert not [n for n in names if "__pycache__" in n or n.endswith(".pyc")]
    sources = bundle_files(model, root)
    assert set(names) == set(sources) | {"README.txt"}
    for name, member in found.items():
        if name == "README.txt":
            assert before <= member.mtime <= after  # generated: the build time
        else:
            assert member.mtime == int(os.stat(str(sources[name])).st_mtime), name
        expected = 0o755 if name in SCRIPTS else 0o644
        assert stat.S_IMODE(member.mode) == expected, name
    assert found["sw_hps/fifo.py"].mtime == int(old)
    assert {SERVICE + "/" + n for n in SERVICE_FILES} <= set(names)


def test_bundle_ships_the_guides_when_present(tmp_path):
    root = source_root(tmp_path)
    model = tiny_models(tmp_path / "m.json")
    names = build_bundle(model, tmp_path / "without.tar.gz", root=root)
    shipped = {name for _, name, _ in DOCS}
    assert not shipped & set(names)
    (root / "docs").mkdir()
    for source, _, _ in DOCS:
        (root / source).write_text(f"# {source}\n")
    names = build_bundle(model, tmp_path / "with.tar.gz", root=root)
    assert shipped <= set(names)
    with tarfile.open(tmp_path / "with.tar.gz") as tar:
        readme = tar.extractfile("README.txt").read().decode()
        for source, name, _ in DOCS:
            assert tar.extractfile(name).read().decode() == f"# {source}\n"
            assert f"\n  {name} " in readme
    assert "is in BRINGUP.md" in readme


def as_old_bundle(path):
    """Rewrite a bundle as the builder before issue 30 wrote it: every member's
    mtime 0 (the default of a bare tarfile.TarInfo)."""
    with tarfile.open(path) as tar:
        old = [(m, tar.extractfile(m).read()) for m in tar.getmembers()]
    with tarfile.open(path, "w:gz") as tar:
        for member, data in old:
            member.mtime = 0
            tar.addfile(member, io.BytesIO(data))


def probe_value(tree):
    """``sw_hps._probe.VALUE`` as a Python started in ``tree`` imports it (writing
    __pycache__ as usual: -I ignores PYTHONDONTWRITEBYTECODE)."""
    out = subprocess.run(
        [sys.executable, "-I", "-c", "import sys; sys.path.insert(0, sys.argv[1]);"
         "import sw_hps._probe as p; assert p.__file__.startswith(sys.argv[1]); print(p.VALUE)",
         str(tree)], cwd=str(tree), env=clean_env(), capture_output=True, text=True, check=True)
    return int(out.stdout)


def run_install(tarball, cwd, *args, env=None):
    """Run the bundle's own install.sh (taken out of the tarball, as `make deploy` does)."""
    script = Path(str(cwd)) / ".install-under-test.sh"
    with tarfile.open(tarball) as tar:
        script.write_bytes(tar.extractfile("install.sh").read())
    try:
        return subprocess.run(["sh", str(script)] + [str(a) for a in args], cwd=str(cwd),
                              env=env or clean_env(), capture_output=True, text=True)
    finally:
        script.unlink()


def installed_tree(tmp_path):
    """A bundle of a tiny model installed by its install.sh into tmp_path/home:
    the tree it made (home/stereogest)."""
    model = tiny_models(tmp_path / "m.json")
    build_bundle(model, tmp_path / "b.tar.gz")
    home = tmp_path / "home"
    home.mkdir()
    assert run_install(tmp_path / "b.tar.gz", home, tmp_path / "b.tar.gz").returncode == 0
    return home / "stereogest"


def pycaches(tree):
    return sorted(str(p.relative_to(tree)) for p in Path(str(tree)).rglob("__pycache__"))


@needs_sh
def test_redeploy_over_an_older_bundle_runs_the_new_code(tmp_path):
    """Issue 30 item 7: unpacking a bundle whose files have mtime 0 over the
    previous one let Python keep the previous .pyc of a module of the same size,
    and left deleted modules behind. install.sh swaps in a fresh tree instead."""
    src = source_root(tmp_path)
    probe = src / "sw_hps" / "_probe.py"
    model = tiny_models(tmp_path / "m.json")
    home = tmp_path / "home"
    home.mkdir()
    target = home / "stereogest"

    # The previous deploy, done the old way: mtime-0 members unpacked with tar, then run.
    probe.write_text("VALUE = 1\n")
    (src / "sw_hps" / "gone.py").write_text("GONE = True\n")
    build_bundle(model, tmp_path / "old.tar.gz", root=src)
    as_old_bundle(tmp_path / "old.tar.gz")
    target.mkdir()
    subprocess.run(["tar", "-xzf", str(tmp_path / "old.tar.gz"), "-C", str(target)], check=True)
    assert probe_value(target) == 1
    assert pycaches(target) == [os.path.join("sw_hps", "__pycache__")]

    # The edit: same size, and a module deleted.
    probe.write_text("VALUE = 2\n")
    (src / "sw_hps" / "gone.py").unlink()

    # The bug, reproduced on a copy: the old way of redeploying runs the old value.
    buggy = home / "buggy"
    shutil.copytree(str(target), str(buggy))
    build_bundle(model, tmp_path / "edited-old-style.tar.gz", root=src)
    as_old_bundle(tmp_path / "edited-old-style.tar.gz")
    subprocess.run(["tar", "-xzf", str(tmp_path / "edited-old-style.tar.gz"), "-C", str(buggy)],
                   check=True)
    assert (buggy / "sw_hps" / "_probe.py").read_text() == "VALUE = 2\n"
    assert probe_value(buggy) == 1  # stale .pyc: the bug
    assert (buggy / "sw_hps" / "gone.py").exists()

    # The new way: real mtimes, a fresh tree swapped in by install.sh.
    build_bundle(model, tmp_path / "new.tar.gz", root=src)
    run = run_install(tmp_path / "new.tar.gz", home, tmp_path / "new.tar.gz", "stereogest")
    assert run.returncode == 0, run.stderr
    assert run.stdout.splitlines()[0] == f"install.sh: installed {target} (the previous tree is replaced)"
    assert not (target / "sw_hps" / "gone.py").exists()
    assert pycaches(target) == []
    assert probe_value(target) == 2
    assert sorted(p.name for p in home.iterdir()) == ["buggy", "stereogest"]  # no .new/.old left


@needs_sh
def test_install_refuses_a_broken_bundle_and_keeps_the_tree(tmp_path):
    model = tiny_models(tmp_path / "m.json")
    good = tmp_path / "good.tar.gz"
    build_bundle(model, good)
    home = tmp_path / "home"
    home.mkdir()
    assert run_install(good, home, good).returncode == 0  # DIR defaults to stereogest
    before = sorted(str(p.relative_to(home)) for p in home.rglob("*"))

    truncated = tmp_path / "truncated.tar.gz"
    truncated.write_bytes(good.read_bytes()[:3000])
    not_ours = tmp_path / "other.tar.gz"
    with tarfile.open(not_ours, "w:gz") as tar:
        info = tarfile.TarInfo("install.sh")
        script = (ROOT / "sw_hps/service/install.sh").read_bytes()
        info.size = len(script)
        tar.addfile(info, io.BytesIO(script))
    for bad, message in ((truncated, "cannot unpack"), (not_ours, "is not a stereogest bundle")):
        script_source = good if bad is truncated else not_ours
        run = run_install(script_source, home, bad, "stereogest")
        assert run.returncode == 1, bad
        assert [line for line in run.stderr.splitlines() if line.startswith("install.sh: error:")] \
            == [line for line in run.stderr.splitlines() if message in line], run.stderr
        assert sorted(str(p.relative_to(home)) for p in home.rglob("*")) == before

    run = run_install(good, home, "--bogus", good)
    assert run.returncode == 2
    assert run.stderr.splitlines()[0] == "install.sh: error: unknown option '--bogus'"


FAKE_SCP = """#!/bin/sh
# scp that fails unless given -O (an OpenSSH 9 client against a server without
# SFTP), then copies host:path to $FAKE_HOME/path
echo "scp $*" >>"$FAKE_LOG"
if [ "$1" != -O ]; then
    echo "scp: Connection closed" >&2
    exit 255
fi
cp "$2" "$FAKE_HOME/${3#*:}"
"""
FAKE_SSH = """#!/bin/sh
# ssh that runs the command in $FAKE_HOME, as a login's home
echo "ssh $*" >>"$FAKE_LOG"
[ "$1" = -t ] && shift
shift
cd "$FAKE_HOME" && exec sh -c "$*"
"""


@needs_sh
def test_make_deploy_end_to_end_with_the_scp_fallback(tmp_path):
    if shutil.which("make") is None:
        pytest.skip("make is not installed")
    from sw_hps.bundle import commands
    fake = tmp_path / "bin"
    fake.mkdir()
    for name, text in (("scp", FAKE_SCP), ("ssh", FAKE_SSH)):
        (fake / name).write_text(text)
        (fake / name).chmod(0o755)
    home, tmp = tmp_path / "home", tmp_path / "tmp"
    home.mkdir()
    tmp.mkdir()
    log = tmp_path / "log"
    env = clean_env(PATH=str(fake) + os.pathsep + os.environ["PATH"], FAKE_HOME=str(home),
                    FAKE_LOG=str(log), TMPDIR=str(tmp))
    model = tiny_models(tmp_path / "m.json")
    bundle = tmp_path / "out" / "b.tar.gz"
    make = ["make", "--no-print-directory", "-C", str(ROOT), "deploy", "HPS=me@board",
            f"BUNDLE={bundle}", f"MODEL={model}", f"PYTHON={sys.executable}"]

    run = subprocess.run(make, env=env, capture_output=True, text=True)
    assert run.returncode == 0, run.stdout + run.stderr
    calls = log.read_text().splitlines()
    assert calls[:2] == [f"scp {bundle} me@board:stereogest-hps.tar.gz",
                         f"scp -O {bundle} me@board:stereogest-hps.tar.gz"]
    assert len(calls) == 3 and calls[2].startswith("ssh me@board ")
    assert "retrying with scp -O" in run.stderr
    tree = home / "stereogest"
    assert (tree / "model.json").read_text() == model.read_text()
    assert (tree / "sw_hps" / "__main__.py").is_file() and os.access(str(tree / "install.sh"), os.X_OK)
    assert f"install.sh: installed {tree}\n" in run.stdout
    cmd = commands()
    for step in ("check", "start", "install_service", "enable"):
        assert f"ssh -t me@board 'cd stereogest && sudo {cmd[step]}'" in run.stdout, step
    assert "systemctl enable --now stereogest" in run.stdout
    assert list(tmp.iterdir()) == []  # the copy of install.sh is removed

    # Redeploy over a tree holding leftovers: they go.
    (tree / "sw_hps" / "stale.py").write_text("X = 1\n")
    (tree / "sw_hps" / "__pycache__").mkdir()
    log.unlink()
    run = subprocess.run(make + ["HPS=root@board"], env=env, capture_output=True, text=True)
    assert run.returncode == 0, run.stdout + run.stderr
    assert "(the previous tree is replaced)" in run.stdout
    assert not (tree / "sw_hps" / "stale.py").exists() and pycaches(tree) == []
    assert f"ssh -t root@board 'cd stereogest && {cmd['check']}'" in run.stdout  # root: no sudo
    assert sorted(p.name for p in home.iterdir()) == ["stereogest", "stereogest-hps.tar.gz"]


def test_make_deploy_without_a_host_says_so(tmp_path):
    if shutil.which("make") is None:
        pytest.skip("make is not installed")
    bundle = tmp_path / "b.tar.gz"
    run = subprocess.run(["make", "-s", "-C", str(ROOT), "deploy", f"BUNDLE={bundle}"],
                         env=clean_env(), capture_output=True, text=True)
    assert run.returncode == 2
    assert run.stderr.splitlines()[0].startswith("make deploy: HPS=user@host is required")
    assert not bundle.exists()


@pytest.mark.parametrize("script", sorted(SCRIPTS.values()))
@pytest.mark.parametrize("shell", ["sh", "dash", "bash", "busybox"])
def test_scripts_parse(script, shell):
    if shutil.which(shell) is None:
        pytest.skip(f"{shell} is not installed")
    argv = [shell, "sh", "-n"] if shell == "busybox" else [shell, "-n"]
    run = subprocess.run(argv + [str(ROOT / script)], capture_output=True, text=True)
    assert run.returncode == 0 and run.stderr == "", run.stderr
    assert (ROOT / script).read_text().startswith("#!/bin/sh\n")


def parse_unit(text):
    """systemd unit syntax: ``{section: {key: [values]}}`` (keys may repeat)."""
    sections, current = {}, None
    for raw in text.splitlines():
        line = raw.strip()
        if not line or line[0] in "#;":
            continue
        if line.startswith("[") and line.endswith("]"):
            current = sections.setdefault(line[1:-1], {})
            continue
        key, sep, value = line.partition("=")
        assert sep and current is not None, f"not a key=value line in a section: {raw!r}"
        current.setdefault(key.strip(), []).append(value.strip())
    return sections


def test_systemd_unit_runs_the_module_after_waiting_for_the_core():
    from sw_hps.bundle import service_settings
    unit = parse_unit((ROOT / SERVICE / "stereogest.service").read_text())
    assert set(unit) == {"Unit", "Service", "Install"}
    service = unit["Service"]
    start = service["ExecStart"]
    assert len(start) == 1
    argv = start[0].split()
    assert argv[:3] == ["@PYTHON@", "-m", "sw_hps"]
    assert (ROOT / "sw_hps" / "__main__.py").is_file()
    assert argv[3:] == ["$STEREOGEST_BUS", "$STEREOGEST_ARGS"]
    assert service["ExecStartPre"] == ["/bin/sh @DIR@/sw_hps/service/wait-core $STEREOGEST_BUS"]
    assert service["WorkingDirectory"] == ["@DIR@"]
    assert service["EnvironmentFile"] == ["-/etc/default/stereogest"]
    assert service["ExecReload"] == ["/bin/kill -HUP $MAINPID"]
    assert service["Restart"] == ["on-failure"] and int(service["RestartSec"][0]) > 0
    assert service["StandardError"] == ["journal"]
    assert unit["Install"]["WantedBy"] == ["multi-user.target"]
    # Never root, no capabilities, nothing but its install directory to read.
    assert service["User"] == ["stereogest"] and service["Group"] == ["stereogest"]
    assert service["CapabilityBoundingSet"] == [""] and service["DevicePolicy"] == ["closed"]
    assert service["BindReadOnlyPaths"] == ["@DIR@"] and service["ProtectSystem"] == ["strict"]
    # The devmem drop-in: root for the mapping, then --user to the same user.
    dropin = parse_unit((ROOT / SERVICE / "stereogest-devmem.conf").read_text())["Service"]
    assert dropin["User"] == ["root"] and dropin["DeviceAllow"] == ["/dev/mem rw"]
    assert dropin["ExecStart"] == ["", start[0] + " --user " + service["User"][0]]
    assert set(dropin["CapabilityBoundingSet"][0].split()) == {
        "CAP_SYS_RAWIO", "CAP_SETUID", "CAP_SETGID"}
    rule = (ROOT / SERVICE / "60-stereogest.rules").read_text()
    assert 'GROUP="stereogest"' in rule and 'ATTR{name}=="stereogest"' in rule
    # Every setting the unit uses is in the example settings file.
    settings = service_settings()
    assert {"STEREOGEST_BUS", "STEREOGEST_ARGS", "STEREOGEST_WAIT"} <= set(settings)
    assert "--model model.json" in settings["STEREOGEST_ARGS"]
    assert settings["STEREOGEST_BUS"].startswith("--bus ")


def install_service(tree, destdir, init, python, *options):
    env = clean_env(DESTDIR=str(destdir), STEREOGEST_PYTHON=str(python))
    return subprocess.run(["sh", str(tree / "install.sh"), "--service", "--init", init,
                           *options], env=env, capture_output=True, text=True)


@needs_sh
@pytest.mark.parametrize("init", ["systemd", "sysv"])
def test_install_service_fills_in_the_paths(tmp_path, init):
    tree = installed_tree(tmp_path)
    dest = tmp_path / "root"
    run = install_service(tree, dest, init, sys.executable)
    assert run.returncode == 0, run.stderr
    installed = dest / ("etc/systemd/system/stereogest.service" if init == "systemd"
                        else "etc/init.d/stereogest")
    text = installed.read_text()
    assert "@DIR@" not in text and "@PYTHON@" not in text
    assert str(tree) in text and sys.executable in text
    assert stat.S_IMODE(installed.stat().st_mode) == (0o644 if init == "systemd" else 0o755)
    defaults = dest / "etc/default/stereogest"
    assert defaults.read_text() == (ROOT / SERVICE / "stereogest.default").read_text()
    assert (dest / "etc/udev/rules.d/60-stereogest.rules").read_text() == \
        (ROOT / SERVICE / "60-stereogest.rules").read_text()
    dropin = dest / "etc/systemd/system/stereogest.service.d/devmem.conf"
    assert dropin.is_file() == (init == "systemd")     # the default bus is devmem
    assert "the system user stereogest is not created here" in run.stdout
    enable = ("systemctl enable --now stereogest" if init == "systemd"
              else "/etc/init.d/stereogest start")
    assert enable in run.stdout
    # A second install keeps the user's settings.
    defaults.write_text('STEREOGEST_BUS="--bus uio --uio /dev/uio1"\n')
    run = install_service(tree, dest, init, sys.executable)
    assert run.returncode == 0 and "kept /etc/default/stereogest" in run.stdout
    assert defaults.read_text() == 'STEREOGEST_BUS="--bus uio --uio /dev/uio1"\n'
    assert not list(dest.rglob("*.tmp"))
    if init == "systemd" and shutil.which("systemd-analyze"):
        verify = subprocess.run(["systemd-analyze", "verify", str(installed)],
                                capture_output=True, text=True)
        complaints = [line for line in (verify.stdout + verify.stderr).splitlines()
                      if "stereogest" in line]
        assert verify.returncode == 0 and complaints == [], verify.stdout + verify.stderr


def exposure(destdir):
    """``systemd-analyze security --offline``'s overall exposure of the unit
    installed under ``destdir`` (drop-ins included)."""
    run = subprocess.run(["systemd-analyze", "security", "--offline=yes", f"--root={destdir}",
                          "--no-pager", "stereogest.service"], capture_output=True, text=True)
    assert run.returncode == 0, run.stdout + run.stderr
    found = re.search(r"Overall exposure level for stereogest\.service: ([0-9.]+)", run.stdout)
    assert found, run.stdout
    return float(found.group(1))


@needs_sh
@pytest.mark.skipif(shutil.which("systemd-analyze") is None,
                    reason="systemd-analyze (Debian package systemd) rates the unit")
def test_the_service_is_confined(tmp_path):
    """The installed unit's exposure: at most 2.5 with --bus uio, 5.0 with the
    devmem drop-in (systemd's own scale, 0 safe to 10 unsafe)."""
    tree = installed_tree(tmp_path)
    dest = tmp_path / "root"
    run = install_service(tree, dest, "systemd", sys.executable, "--bus", "uio")
    assert run.returncode == 0, run.stderr
    uio = exposure(dest)
    run = install_service(tree, dest, "systemd", sys.executable, "--bus", "devmem")
    assert run.returncode == 0, run.stderr
    devmem = exposure(dest)
    # verify loads the drop-in beside the unit file too
    verify = subprocess.run(["systemd-analyze", "verify",
                             str(dest / "etc/systemd/system/stereogest.service")],
                            capture_output=True, text=True)
    assert verify.returncode == 0 and [line for line in (verify.stdout + verify.stderr).splitlines()
            if "stereogest" in line] == []
    assert uio <= 2.5 and devmem <= 5.0, (uio, devmem)
    # The unconfined unit (the same commands, none of the sandbox) rates far worse.
    plain = dest / "etc/systemd/system/stereogest.service"
    text = plain.read_text()
    plain.write_text(text[:text.index("# Who: a user of its own.")] + "\n[Install]\n"
                     "WantedBy=multi-user.target\n")
    (dest / "etc/systemd/system/stereogest.service.d/devmem.conf").unlink()
    assert exposure(dest) > 9.0


@needs_sh
def test_install_service_bus_sets_the_settings_and_the_drop_in(tmp_path):
    tree = installed_tree(tmp_path)
    dest = tmp_path / "root"
    defaults = dest / "etc/default/stereogest"
    dropin = dest / "etc/systemd/system/stereogest.service.d/devmem.conf"
    run = install_service(tree, dest, "systemd", sys.executable, "--bus", "uio")
    assert run.returncode == 0, run.stderr
    assert not dropin.exists()
    assert 'STEREOGEST_BUS="--bus uio --uio /dev/stereogest"\n' in defaults.read_text()
    # The user's own lines survive a change of bus; only STEREOGEST_BUS changes.
    defaults.write_text(defaults.read_text() + 'STEREOGEST_ARGS="--model mine.json"\n')
    run = install_service(tree, dest, "systemd", sys.executable, "--bus", "devmem")
    assert run.returncode == 0 and dropin.is_file(), run.stderr
    text = defaults.read_text()
    assert 'STEREOGEST_BUS="--bus devmem"\n' in text and text.endswith(
        'STEREOGEST_ARGS="--model mine.json"\n')
    # Without --bus the settings decide: a uio bus written by hand drops the drop-in.
    defaults.write_text('STEREOGEST_BUS="--bus uio --uio /dev/uio1"\n')
    run = install_service(tree, dest, "systemd", sys.executable)
    assert run.returncode == 0 and not dropin.exists(), run.stderr
    assert defaults.read_text() == 'STEREOGEST_BUS="--bus uio --uio /dev/uio1"\n'
    assert not list(dest.rglob("*.tmp"))


@needs_sh
@pytest.mark.parametrize("options, says", [
    (["--bus", "pci"], "--bus must be devmem or uio, got 'pci'"),
    (["--bus"], "--bus needs devmem or uio"),
])
def test_install_service_bad_bus(tmp_path, options, says):
    tree = installed_tree(tmp_path)
    run = install_service(tree, tmp_path / "root", "systemd", sys.executable, *options)
    assert run.returncode == 2 and f"install.sh: error: {says}" in run.stderr
    assert not (tmp_path / "root").exists()


FAKE_PYTHON = """#!/bin/sh
# python3 stand-in: `-m sw_hps --check ...` answers with the next status of
# $FAKE_STATUSES (the last one repeats); anything else runs until SIGTERM.
# The traps come before the first line: a test that sees it may signal at once.
trap 'echo "got HUP"' HUP
trap 'echo "got TERM"; exit 0' TERM
echo "fake-python $*"
case " $* " in
    *" --check "*)
        n=$(cat "$FAKE_STATE" 2>/dev/null || echo 0)
        n=$((n + 1))
        echo "$n" >"$FAKE_STATE"
        i=0
        for status in ${FAKE_STATUSES:-0}; do
            i=$((i + 1))
            last=$status
            [ "$i" -eq "$n" ] && exit "$status"
        done
        exit "$last"
        ;;
esac
while :; do
    sleep 1 &
    wait $!
done
"""


def fake_python(tmp_path):
    path = tmp_path / "fake-python"
    path.write_text(FAKE_PYTHON)
    path.chmod(0o755)
    return path


@needs_sh
@pytest.mark.parametrize("statuses, wait, code, calls, says", [
    ("1 0", "60", 0, 2, "waiting up to 60 s"),
    ("1", "0", 1, 1, "no stereogest core after"),
    ("2", "60", 2, 1, "exited with status 2; not waiting"),
    ("0", "soon", 2, 0, "STEREOGEST_WAIT must be a whole number of seconds in [0, 86400]"),
])
def test_wait_core(tmp_path, statuses, wait, code, calls, says):
    state = tmp_path / "calls"
    env = clean_env(STEREOGEST_PYTHON=str(fake_python(tmp_path)), STEREOGEST_WAIT=wait,
                    FAKE_STATUSES=statuses, FAKE_STATE=str(state))
    run = subprocess.run(["sh", str(ROOT / SERVICE / "wait-core"), "--bus", "devmem"],
                         env=env, capture_output=True, text=True, timeout=30)
    assert run.returncode == code, run.stderr
    assert (int(state.read_text()) if state.exists() else 0) == calls
    assert says in run.stderr
    if code == 0:
        assert run.stdout == "fake-python -m sw_hps --check --bus devmem\n"


def _default_hup():
    signal.signal(signal.SIGHUP, signal.SIG_DFL)


def _wait_for(predicate, seconds=10.0):
    deadline = time.time() + seconds
    while time.time() < deadline:
        if predicate():
            return True
        time.sleep(0.1)
    return predicate()


@needs_sh
def test_init_script_starts_reloads_and_stops(tmp_path):
    from sw_hps.bundle import service_settings
    tree = installed_tree(tmp_path)
    dest = tmp_path / "root"
    python = fake_python(tmp_path)
    assert install_service(tree, dest, "sysv", python).returncode == 0
    pidfile, logfile = tmp_path / "stereogest.pid", tmp_path / "stereogest.log"
    env = clean_env(STEREOGEST_DEFAULTS=str(dest / "etc/default/stereogest"),
                    STEREOGEST_PIDFILE=str(pidfile), STEREOGEST_LOG=str(logfile),
                    FAKE_STATE=str(tmp_path / "checks"), STEREOGEST_USER="nobody")
    script = str(dest / "etc/init.d/stereogest")
    # Started as root, the application gives root up once the bus is open.
    drop = " --user nobody" if os.geteuid() == 0 else ""

    def init(action):
        # as init runs it: SIGHUP at its default (a shell started with it
        # ignored, under nohup, cannot trap it, so the stand-in would not log)
        return subprocess.run(["sh", script, action], env=env, capture_output=True, text=True,
                              timeout=60, preexec_fn=_default_hup)

    pid = None
    try:
        run = init("start")
        assert run.returncode == 0, run.stdout + run.stderr
        pid = int(pidfile.read_text())
        assert f"stereogest: started (pid {pid}" in run.stdout
        assert init("start").stdout == f"stereogest: already running (pid {pid})\n"
        assert init("status").stdout == f"stereogest: running (pid {pid})\n"
        settings = service_settings()
        assert _wait_for(lambda: f"fake-python -m sw_hps {settings['STEREOGEST_BUS']} "
                                 f"{settings['STEREOGEST_ARGS']}{drop}\n"
                                 in logfile.read_text())
        assert "fake-python -m sw_hps --check " + settings["STEREOGEST_BUS"] in logfile.read_text()
        assert init("reload").returncode == 0
        assert _wait_for(lambda: "got HUP" in logfile.read_text())
        run = init("stop")
        assert run.returncode == 0 and run.stdout.endswith("stereogest: stopped\n")
        assert _wait_for(lambda: not os.path.exists(f"/proc/{pid}"))
        assert "got TERM" in logfile.read_text() and not pidfile.exists()
        run = init("status")
        assert run.returncode == 3 and run.stdout == "stereogest: not running\n"
        assert init("bogus").returncode == 2
    finally:
        if pid is not None and os.path.exists(f"/proc/{pid}"):
            os.kill(pid, 9)


@needs_sh
def test_wait_core_with_the_real_check_on_the_simulated_core():
    """The unit's ExecStartPre against the application's own --check."""
    env = clean_env(STEREOGEST_PYTHON=sys.executable, STEREOGEST_WAIT="0")
    run = subprocess.run(["sh", str(ROOT / SERVICE / "wait-core"), "--bus", "sim"], cwd=str(ROOT),
                         env=env, capture_output=True, text=True, timeout=60)
    assert run.returncode == 0, run.stdout + run.stderr
    assert len(run.stdout.splitlines()) == 1 and "OK" in run.stdout
