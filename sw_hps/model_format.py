"""The model file's identity (format name, versions, emissions) and a
structural check of it that needs nothing but Python's standard library.

:mod:`sw_hps.hmm` holds the file's full description and its full validation
(numpy); this module is what a machine without numpy can check, so that
``make hps-bundle`` refuses a file that is not a model file at all before the
board does (:mod:`sw_hps.bundle`).
"""
from __future__ import annotations

import json
from pathlib import Path

__all__ = ["MODEL_FORMAT", "MODEL_VERSION", "MODEL_VERSIONS", "EMISSIONS", "check_header",
           "check_structure", "read_json", "read_structure"]

MODEL_FORMAT = "stereogest-hmm"
#: Version written; 1 (discrete, no rejection), 2 (no spotting), 3 (no
#: postures), 4 (no commands) and 5 (no verifier) are still read.
MODEL_VERSION = 6
#: Versions read.
MODEL_VERSIONS = (1, 2, 3, 4, 5, 6)
#: Emission models a model file may hold.
EMISSIONS = ("discrete", "gaussian")


def check_header(data) -> tuple[int, str]:
    """``(version, emission)`` of a model file's parsed JSON once its object,
    ``format``, ``version`` and ``emission`` are right; ``ValueError`` names the
    first that is not (the one check of these fields, :func:`check_structure`
    and :meth:`sw_hps.hmm.GestureModels.from_dict` call it)."""
    if not isinstance(data, dict):
        raise ValueError("model file must hold a JSON object")
    if data.get("format") != MODEL_FORMAT:
        raise ValueError(f"format must be {MODEL_FORMAT!r}, got {data.get('format')!r}")
    version = data.get("version")
    if version not in MODEL_VERSIONS or isinstance(version, bool):
        raise ValueError(f"version must be one of {list(MODEL_VERSIONS)}, got {version!r}")
    emission = data.get("emission", "discrete") if version >= 2 else "discrete"
    if emission not in EMISSIONS:
        raise ValueError(f"emission must be one of {list(EMISSIONS)}, got {emission!r}")
    return version, emission


def check_structure(data) -> dict:
    """Check what the standard library can: the format, the version, the
    emission, the class names and one model entry per class.

    Parameters
    ----------
    data : object
        The parsed JSON of a model file.

    Returns
    -------
    dict
        ``{"version": int, "emission": str, "class_names": list of str}``.

    Raises
    ------
    ValueError
        Naming the first field that is wrong. The messages match
        :meth:`sw_hps.hmm.GestureModels.from_dict` where both check the same field.
    """
    version, emission = check_header(data)
    names = data.get("class_names")
    entries = data.get("models")
    if not isinstance(names, list) or not isinstance(entries, list):
        raise ValueError("class_names and models must be lists")
    if not names or not all(isinstance(n, str) and n for n in names) \
            or len(set(names)) != len(names):
        raise ValueError(f"class_names must be unique and non-empty, got {names!r}")
    if len(names) != len(entries):
        raise ValueError(f"{len(names)} class_names but {len(entries)} models")
    if not all(isinstance(entry, dict) for entry in entries):
        raise ValueError("each entry of models must be a JSON object")
    return {"version": version, "emission": emission, "class_names": list(names)}


def read_json(path):
    """The parsed JSON of a model file; ``ValueError`` names the file and why it
    cannot be read or parsed."""
    try:
        raw = Path(path).read_bytes()
    except OSError as exc:
        raise ValueError(f"{path}: cannot read model file ({exc.strerror})") from None
    try:
        return json.loads(raw)
    except json.JSONDecodeError as exc:
        raise ValueError(f"{path}: not valid JSON ({exc.msg} at line {exc.lineno})") from None
    except ValueError as exc:  # bytes that are no UTF-8/16/32 text
        raise ValueError(f"{path}: not valid JSON ({exc})") from None


def read_structure(path) -> dict:
    """:func:`check_structure` of a model file; ``ValueError`` names the file
    and what is wrong (unreadable, not JSON, a field)."""
    data = read_json(path)
    try:
        return check_structure(data)
    except ValueError as exc:
        raise ValueError(f"{path}: {exc}") from None
