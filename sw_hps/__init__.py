"""The board application (``python -m sw_hps``): runs on the DE1-SoC's ARM.

The board's floor is :data:`REQUIRED_PYTHON` and :data:`REQUIRED_NUMPY`, what
Debian 10 "buster" ships (python3 3.7.3, python3-numpy 1.16.2);
``tests/test_hps_floor.py`` runs the board's tests on that floor.

Importing the package on an older Python prints one line and exits with status
2, before any module written for Python 3.7 is compiled (``python -m sw_hps`` on
3.6 would otherwise stop at a SyntaxError). This file is therefore kept to
syntax that Python 2.7 and 3.5 parse: no f-strings, no annotations. numpy is
checked by :func:`check_floor`, which ``python -m sw_hps`` calls before it
imports anything that needs numpy (``python -m sw_hps.bundle`` runs without it).
"""
import sys

#: The project's version: ``stereogest --version``, ``python -m sw_hps --version``,
#: the bundle and CHANGELOG.md's newest section say it (pyproject.toml reads it here).
__version__ = "0.2.0"

#: Oldest Python the board application supports (``from __future__ import
#: annotations``, dataclasses).
REQUIRED_PYTHON = (3, 7)
#: Oldest numpy it supports (``np.diff(prepend=...)`` came with 1.16).
REQUIRED_NUMPY = (1, 16)
#: How an image of the boards' age gets both.
INSTALL_HINT = "on Debian/Ubuntu: apt install python3 python3-numpy"


def _dotted(numbers):
    return ".".join(str(number) for number in numbers)


def _leading_numbers(text):
    """``"1.16.6"`` -> ``(1, 16, 6)``; ``"2.0.0rc1"`` -> ``(2, 0, 0)``; no number -> ``()``."""
    numbers = []
    for part in str(text).split("."):
        digits = ""
        for char in part:
            if not char.isdigit():
                break
            digits += char
        if not digits:
            break
        numbers.append(int(digits))
        if len(digits) < len(part):     # "0rc1": a pre-release suffix ends the version
            break
    return tuple(numbers)


def numpy_version():
    """Return the importable numpy's version string, or None if there is none.

    Any exception counts as "no numpy": a numpy built for another Python fails
    inside its own import with errors other than ImportError.
    """
    try:
        import numpy
    except Exception:
        return None
    return str(getattr(numpy, "__version__", "unknown"))


def floor_problem(python, numpy):
    """Return the one-line complaint about the versions found, or None if they do.

    Parameters
    ----------
    python : sequence of int
        The running Python's version, e.g. ``sys.version_info[:3]``.
    numpy : str or None
        numpy's ``__version__``, or None when numpy is missing.
    """
    python = tuple(python)
    if python[:2] >= REQUIRED_PYTHON and numpy is not None \
            and _leading_numbers(numpy)[:2] >= REQUIRED_NUMPY:
        return None
    found = "Python %s, %s" % (_dotted(python), "no numpy" if numpy is None else "numpy " + numpy)
    return "sw_hps: error: needs Python >= %s and numpy >= %s (found %s); %s" % (
        _dotted(REQUIRED_PYTHON), _dotted(REQUIRED_NUMPY), found, INSTALL_HINT)


def check_floor():
    """Exit with status 2 and one line on stderr unless Python and numpy meet the floor."""
    problem = floor_problem(sys.version_info[:3], numpy_version())
    if problem is not None:
        sys.stderr.write(problem + "\n")
        raise SystemExit(2)


if sys.version_info[:2] < REQUIRED_PYTHON:
    check_floor()
