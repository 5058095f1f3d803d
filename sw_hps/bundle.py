"""Build the board bundle: the ``sw_hps`` package and a trained model in one
tarball (``make hps-bundle``; ``make deploy HPS=user@host`` installs it).

The tarball unpacks to::

    sw_hps/...             the application (Python + numpy on the board)
    sw_hps/service/...     systemd unit and its devmem drop-in, SysV init script,
                           settings example, udev rule, wait-core
    soc/hps_interface.py   what the FPGA and the application agree on (registers,
                           bases, gesture classes; standard library only)
    model.json             the HMM model file
    posture.json           the posture classifier (sw_hps/models/posture.json)
    install.sh             installs or redeploys the bundle (a fresh tree swapped in
                           by renaming), and the service
    BRINGUP.md, ROBOT.md   docs/bring-up.md and docs/robot-link.md, when present
    README.txt             what is where and how to start it

Building needs only Python's standard library (``make hps-bundle`` runs on the
system Python, not the development environment): with numpy importable the
model is validated as the application validates it, without numpy only its
structure (:mod:`sw_hps.model_format`), and the board checks the rest at start.
Every file keeps its own modification time (README.txt gets the build time), so
Python never takes a previous deploy's ``__pycache__`` for current.

Run: ``python -m sw_hps.bundle --model MODEL.json -o BUNDLE.tar.gz``;
``python -m sw_hps.bundle --next-steps USER@HOST [--dir DIR]`` prints what to run
after ``make deploy``.
"""
from __future__ import annotations

import argparse
import io
import os
import re
import sys
import tarfile
import time
from pathlib import Path

from . import INSTALL_HINT, REQUIRED_NUMPY, REQUIRED_PYTHON, __version__, numpy_version
from .model_format import read_structure

PACKAGE = Path(__file__).resolve().parent
#: The repository: the package's parent.
ROOT = PACKAGE.parent
#: Files of the repository the application imports besides its own package.
SHARED = ("soc/__init__.py", "soc/hps_interface.py")
#: The service files, shipped under sw_hps/service/ (install.sh puts them in place).
SERVICE = "sw_hps/service"
SERVICE_FILES = ("stereogest.service", "stereogest-devmem.conf", "stereogest.init",
                 "stereogest.default", "60-stereogest.rules", "wait-core")
#: The installer: its source in the repository, its name in the bundle.
INSTALLER = ("sw_hps/service/install.sh", "install.sh")
#: Documents shipped when present: source, name in the bundle, what it covers.
DOCS = (
    ("docs/bring-up.md", "BRINGUP.md",
     "program the FPGA, enable the bridge, check the core, start: read it first"),
    ("docs/robot-link.md", "ROBOT.md",
     "reach the NXT robot: RN-42, USB serial adapter, Bluetooth dongle and rfcomm"),
)
#: The example settings: the start commands printed here are built from them.
DEFAULTS = SERVICE + "/stereogest.default"
#: Where ``make deploy`` installs by default (relative to the login's home).
DEFAULT_DIR = "stereogest"
SERVICE_NAME = "stereogest"


def service_settings(root=ROOT) -> dict:
    """The ``KEY="value"`` lines of the example settings file (comments skipped)."""
    settings = {}
    for line in (Path(root) / DEFAULTS).read_text().splitlines():
        match = re.match(r'^([A-Z_]+)="(.*)"$', line.strip())
        if match:
            settings[match.group(1)] = match.group(2)
    return settings


def commands(root=ROOT) -> dict:
    """The board-side commands, run in the install directory: ``check``,
    ``start``, ``install_service`` and ``enable``; the bus and the arguments are
    the example settings' (:data:`DEFAULTS`).

    ``-B``: run as root, Python would otherwise leave a root-owned
    ``__pycache__`` that a redeploy by another user cannot remove.
    """
    settings = service_settings(root)
    if not {"STEREOGEST_BUS", "STEREOGEST_ARGS"} <= settings.keys():
        raise ValueError(f"{DEFAULTS} must set STEREOGEST_BUS and STEREOGEST_ARGS")
    bus, args = settings["STEREOGEST_BUS"], settings["STEREOGEST_ARGS"]
    return {"check": f"python3 -B -m sw_hps --check {bus}",
            "start": f"python3 -B -m sw_hps {bus} {args}",
            "install_service": "sh install.sh --service",
            "enable": f"systemctl enable --now {SERVICE_NAME}"}


def _dotted(version) -> str:
    return ".".join(str(n) for n in version)


def readme(names, root=ROOT) -> str:
    """README.txt of a bundle holding ``names``."""
    cmd = commands(root)
    files = [("sw_hps/", "the application (python3 -m sw_hps --help lists its options)"),
             (SERVICE + "/", "systemd unit, SysV init script, example settings, wait-core"),
             ("soc/hps_interface.py", "the registers the FPGA core and the application share"),
             ("model.json", "the trained gesture model"),
             ("posture.json", "the posture classifier (--posture-model posture.json)"),
             (INSTALLER[1], "installs or redeploys this bundle, and the service")]
    files += [(name, what) for _, name, what in DOCS if name in names]
    files.append(("README.txt", "this file"))
    first = "BRINGUP.md" if "BRINGUP.md" in names else "the project's docs/bring-up.md"
    lines = [
        f"stereogest board application {__version__}",
        "=" * len(f"stereogest board application {__version__}"),
        "",
        f"Needs Python >= {_dotted(REQUIRED_PYTHON)} and numpy >= {_dotted(REQUIRED_NUMPY)} "
        f"on the board ({INSTALL_HINT}).",
        "",
    ]
    lines += [f"  {name:<21} {what}" for name, what in files]
    lines += [
        "",
        f"Bring-up (loading the FPGA, enabling the bridge, uio) is in {first}.",
        "In this directory, as root (/dev/mem needs it; otherwise put sudo in front):",
        "",
        f"1. check the FPGA and the core:   {cmd['check']}",
        f"2. start it by hand (Ctrl-C):     {cmd['start']}",
        f"3. or run it as a service:        {cmd['install_service']}",
        f"   then                           {cmd['enable']}",
        f"   (settings: /etc/default/{SERVICE_NAME}; log: journalctl -u {SERVICE_NAME} -f;",
        "   install.sh names the init-script way on images without systemd)",
        "",
        "-B keeps Python from writing __pycache__ as root here, which a redeploy by",
        "another user could not remove.",
        "",
        "Redeploy with `make deploy HPS=user@host` on the development machine, or on the",
        "board with `sh DIR/install.sh stereogest-hps.tar.gz DIR`: the whole directory is",
        "replaced (keep your own files elsewhere); restart the service afterwards.",
        "",
    ]
    return "\n".join(lines)


def next_steps(host: str, directory: str = DEFAULT_DIR, root=ROOT) -> str:
    """What to run from the development machine after ``make deploy``.

    ``ssh -t`` gives sudo a terminal for its password and ties the program to
    the session (Ctrl-C reaches it); ``sudo`` unless the login is root.
    """
    cmd = commands(root)
    sudo = "" if host.split("@")[0] == "root" and "@" in host else "sudo "

    def remote(command):
        return f"ssh -t {host} 'cd {directory} && {sudo}{command}'"

    guide = f" ({directory}/BRINGUP.md explains each step)" if any(
        name == "BRINGUP.md" and (Path(root) / source).is_file() for source, name, _ in DOCS) else ""
    lines = [
        f"Installed on {host} in {directory}. Next{guide}:",
        f"  check the FPGA and the core:  {remote(cmd['check'])}",
        f"  start it by hand (Ctrl-C):    {remote(cmd['start'])}",
        f"  or install the service:       {remote(cmd['install_service'])}",
        f"  then enable and start it:     {remote(cmd['enable'])}",
        f"  (settings: /etc/default/{SERVICE_NAME} on the board; install.sh names the "
        "init-script way on images without systemd)",
    ]
    return "\n".join(lines)


def check_model(path) -> str:
    """Refuse (``ValueError``) a model the application would refuse; return
    what was checked, for the output line. Without numpy only the structure
    can be checked here."""
    if numpy_version() is None:
        info = read_structure(path)
        return (f"{info['emission']} model, {len(info['class_names'])} classes; numpy is not "
                "installed here, so only its structure was checked: the full check runs on "
                "the board at start")
    # numpy is there: validate exactly as the application does.
    from .app import check_models
    from .hmm import load_models
    models = check_models(load_models(path))
    if models.postures is not None:       # the bundle's posture classifier must know them
        from .posture import read_posture_model
        from .posture_commands import check_posture_classes
        posture = read_posture_model(Path(__file__).parent / "models" / "posture.json")
        check_posture_classes(models.postures, posture.class_names, where=f"{path}: postures")
    return f"{models.emission} model, {len(models.class_names)} classes, checked in full"


def _is_script(data: bytes) -> bool:
    return data.startswith(b"#!")


def bundle_files(model_path, root=ROOT) -> dict:
    """``{name in the bundle: source path}`` of every file but README.txt."""
    root = Path(root)
    package = root / "sw_hps"
    files = {}
    for path in package.rglob("*.py"):
        rel = path.relative_to(root)
        if "__pycache__" not in rel.parts:
            files[rel.as_posix()] = path
    for name in SERVICE_FILES:
        files[f"{SERVICE}/{name}"] = root / SERVICE / name
    for name in SHARED:
        files[name] = root / name
    files[INSTALLER[1]] = root / INSTALLER[0]
    for source, name, _ in DOCS:
        if (root / source).is_file():
            files[name] = root / source
    files["model.json"] = Path(model_path)
    files["posture.json"] = package / "models" / "posture.json"
    return files


def _add(tar: tarfile.TarFile, name: str, data: bytes, mtime: float) -> None:
    info = tarfile.TarInfo(name)
    info.size = len(data)
    info.mtime = int(mtime)
    info.mode = 0o755 if _is_script(data) else 0o644
    info.uid = info.gid = 0
    info.uname = info.gname = "root"
    tar.addfile(info, io.BytesIO(data))


def build_bundle(model_path, output, root=ROOT) -> list[str]:
    """Write the tarball; return the member names (sorted).

    Parameters
    ----------
    model_path : path
        The model file, shipped as ``model.json``; checked first
        (:func:`check_model`).
    output : path
        The tarball; written through a temporary file, never half-written.
    root : path
        The repository to take ``sw_hps``, ``soc`` and ``docs`` from.
    """
    check_model(model_path)
    return _write(model_path, output, root)


def _write(model_path, output, root=ROOT) -> list[str]:
    files = bundle_files(model_path, root)
    names = sorted(list(files) + ["README.txt"])
    output = Path(output)
    output.parent.mkdir(parents=True, exist_ok=True)
    tmp = output.with_name(output.name + ".part")
    try:
        with tarfile.open(tmp, "w:gz") as tar:
            for name in names:
                if name == "README.txt":
                    _add(tar, name, readme(names, root).encode(), time.time())
                else:
                    path = files[name]
                    _add(tar, name, path.read_bytes(), os.stat(path).st_mtime)
        tmp.replace(output)
    finally:
        if tmp.exists():
            tmp.unlink()
    return names


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(prog="python -m sw_hps.bundle",
                                     description=__doc__.split("\n\n")[0])
    parser.add_argument("--model", help="trained HMM model file (JSON)")
    parser.add_argument("-o", "--output", help="tarball to write (.tar.gz)")
    parser.add_argument("--next-steps", metavar="USER@HOST",
                        help="print what to run after `make deploy HPS=USER@HOST` and exit")
    parser.add_argument("--dir", default=DEFAULT_DIR,
                        help=f"install directory on the board, for --next-steps (default "
                             f"{DEFAULT_DIR})")
    args = parser.parse_args(argv)
    if args.next_steps is not None:
        print(next_steps(args.next_steps, args.dir))
        return 0
    if args.model is None or args.output is None:
        parser.error("--model and -o/--output are required (or --next-steps)")
    try:
        checked = check_model(args.model)
        names = _write(args.model, args.output)
    except (ValueError, OSError) as exc:
        print(f"sw_hps.bundle: error: {exc}", file=sys.stderr)
        return 2
    print(f"wrote {args.output} ({len(names)} files; {checked}); "
          "deploy with: make deploy HPS=user@host")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
