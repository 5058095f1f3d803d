"""The ``stereogest`` console script: one subcommand per job.

Every subcommand lives in :mod:`stereogest.commands`; a ``ValueError`` raised by
parameter validation, or an ``OSError`` of a file it reads or writes, is
reported as a one-line error (exit status 2), never as a traceback. A reader
that leaves early (``stereogest ... | head``) ends the command quietly, exit
status 1, whichever subcommand (or ``--help``) was writing.
"""
from __future__ import annotations

import argparse
import importlib
import sys

#: Subcommand modules, in the order a user meets them.
COMMANDS = ("render", "clip", "chessboards", "calibrate", "stereo", "eval_stereo", "pipeline",
            "demo", "live", "gestures", "dataset", "train", "classify",
            "postures", "train_posture", "classify_posture", "posture_commands",
            "resources", "timing", "generate")


class _HelpFormatter(argparse.ArgumentDefaultsHelpFormatter):
    """Show a default only where it says something (not None/False, not a flag's,
    not already in the text)."""

    def _get_help_string(self, action):
        text = action.help or ""
        if "default" in text or action.default in (None, False, argparse.SUPPRESS) \
                or action.nargs == 0:
            return text
        return super()._get_help_string(action)


class _Parser(argparse.ArgumentParser):
    """An argument parser whose errors are one line (``stereogest COMMAND:
    error: argument --width: invalid int value: 'abc'``, exit status 2):
    ``--help`` has the usage."""

    def error(self, message):
        self.exit(2, f"{self.prog}: error: {message}\n")


def _version() -> str:
    """The project's version (one definition: :data:`sw_hps.__version__`)."""
    from sw_hps import __version__
    return __version__


def build_parser() -> argparse.ArgumentParser:
    parser = _Parser(
        prog="stereogest",
        description="Stereo-vision hand-gesture recogniser for the DE1-SoC: "
                    "golden model, scene renderer and tools.")
    parser.add_argument("--version", action="version", version=f"%(prog)s {_version()}")
    sub = parser.add_subparsers(dest="command", metavar="COMMAND", required=True,
                                parser_class=_Parser)
    for mod_name in COMMANDS:
        mod = importlib.import_module(f"stereogest.commands.{mod_name}")
        p = sub.add_parser(mod.NAME, help=mod.HELP, description=mod.__doc__,
                           formatter_class=_HelpFormatter)
        mod.add_arguments(p)
        p.set_defaults(_run=mod.run, _parser=p)
    return parser


def in_option_names(message: str, parser: argparse.ArgumentParser) -> str:
    """A validation message that starts with a parameter's name
    (``census_window must be ...``) in terms of the option that sets it
    (``--census-window must be ...``)."""
    word = message.split(" ", 1)[0].rstrip(":,")
    for action in parser._actions:
        if action.dest == word and action.option_strings:
            return max(action.option_strings, key=len) + message[len(word):]
    return message


def main(argv: list[str] | None = None) -> int:
    try:
        try:
            return _main(argv)
        finally:
            # A pipe makes stdout block-buffered: a short report meets the closed
            # pipe only here (or at exit, as an "Exception ignored" traceback).
            if sys.stdout is not None:
                sys.stdout.flush()
    except BrokenPipeError:  # `stereogest ... | head`: the reader left, nothing to say
        _discard_stdout()
        return 1             # what Python itself returns on EPIPE (signal module docs)


def _discard_stdout() -> None:
    """Point stdout at /dev/null, so Python's own flush at exit raises nothing
    more (https://docs.python.org/3/library/signal.html#note-on-sigpipe)."""
    import os
    try:
        devnull = os.open(os.devnull, os.O_WRONLY)
        os.dup2(devnull, sys.stdout.fileno())
        os.close(devnull)
    except (OSError, ValueError, AttributeError):  # no real stdout (captured, closed, None)
        pass


def _main(argv: list[str] | None) -> int:
    parser = build_parser()
    args = parser.parse_args(argv)
    try:
        return int(args._run(args) or 0)
    except (ValueError, FileNotFoundError) as exc:
        message = in_option_names(str(exc), args._parser)
        print(f"stereogest {args.command}: error: {message}", file=sys.stderr)
        return 2
    except BrokenPipeError:
        raise                # main's: not a file the command failed to write
    except OSError as exc:  # a path that cannot be read or written: no traceback
        where = f" ({exc.filename})" if getattr(exc, "filename", None) else ""
        print(f"stereogest {args.command}: error: {exc.strerror or exc}{where}", file=sys.stderr)
        return 2
    except RuntimeError as exc:  # a tool (Verilator, yosys) or a simulation failed
        print(f"stereogest {args.command}: error: {exc}", file=sys.stderr)
        return 1
    except KeyboardInterrupt:
        print(f"stereogest {args.command}: interrupted", file=sys.stderr)
        return 130


if __name__ == "__main__":
    raise SystemExit(main())
