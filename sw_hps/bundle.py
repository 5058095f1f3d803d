"""Build the board bundle: the ``sw_hps`` package and a trained model in one
tarball (``make hps-bundle``; ``make deploy HPS=user@host`` copies it over).

The tarball unpacks to::

    sw_hps/...      the application (Python 3 + numpy only)
    soc/hps_interface.py   what the FPGA and the application agree on (registers,
                    bases, gesture classes; standard library only)
    model.json      the HMM model file
    README.txt      how to start it

Run: ``python -m sw_hps.bundle --model MODEL.json -o BUNDLE.tar.gz``.
"""
from __future__ import annotations

import argparse
import io
import sys
import tarfile
from pathlib import Path

from sw_hps.app import check_models
from sw_hps.hmm import load_models

PACKAGE = Path(__file__).resolve().parent
#: Files of the repository the application imports besides its own package.
SHARED = ("soc/__init__.py", "soc/hps_interface.py")

START = """stereogest HPS application
==========================

Requires Python 3.8+ and numpy on the board (e.g. `apt install python3-numpy`).

Start (the lightweight HPS-to-FPGA bridge through /dev/mem needs root):

    sudo python3 -m sw_hps --model model.json --bus devmem --robot serial:/dev/ttyUSB0

Other choices: --bus uio (with --uio /dev/uioN), --robot uart (the FPGA UART
slave) or --robot none; `python3 -m sw_hps --help` lists every option.
"""


def _add_bytes(tar: tarfile.TarFile, name: str, data: bytes) -> None:
    info = tarfile.TarInfo(name)
    info.size = len(data)
    info.mode = 0o644
    tar.addfile(info, io.BytesIO(data))


def build_bundle(model_path, output) -> list[str]:
    """Write the tarball; return the member names. The model is validated first."""
    model_path = Path(model_path)
    check_models(load_models(model_path))  # refuse a model the application would refuse
    output = Path(output)
    output.parent.mkdir(parents=True, exist_ok=True)
    members = sorted(p for p in PACKAGE.rglob("*.py") if "__pycache__" not in p.parts)
    tmp = output.with_name(output.name + ".part")
    names = []
    try:
        with tarfile.open(tmp, "w:gz") as tar:
            for path in members:
                name = "sw_hps/" + path.relative_to(PACKAGE).as_posix()
                _add_bytes(tar, name, path.read_bytes())
                names.append(name)
            for name in SHARED:
                _add_bytes(tar, name, (PACKAGE.parent / name).read_bytes())
                names.append(name)
            _add_bytes(tar, "model.json", model_path.read_bytes())
            _add_bytes(tar, "README.txt", START.encode())
            names += ["model.json", "README.txt"]
        tmp.replace(output)
    finally:
        if tmp.exists():
            tmp.unlink()
    return names


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(prog="python -m sw_hps.bundle", description=__doc__.split("\n\n")[0])
    parser.add_argument("--model", required=True, help="trained HMM model file (JSON)")
    parser.add_argument("-o", "--output", required=True, help="tarball to write (.tar.gz)")
    args = parser.parse_args(argv)
    try:
        names = build_bundle(args.model, args.output)
    except (ValueError, OSError) as exc:
        print(f"sw_hps.bundle: error: {exc}", file=sys.stderr)
        return 2
    print(f"wrote {args.output} ({len(names)} files); deploy with: make deploy HPS=user@host")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
