"""The ``stereogest`` console script: one subcommand per job.

Every subcommand lives in :mod:`stereogest.commands`; a ``ValueError`` raised by
parameter validation is reported as a one-line error (exit status 2), never
as a traceback.
"""
from __future__ import annotations

import argparse
import importlib
import sys

#: Subcommand modules, in the order a user meets them.
COMMANDS = ("render", "stereo", "eval_stereo", "pipeline", "demo", "gestures", "train", "classify",
            "resources", "timing", "generate")


class _HelpFormatter(argparse.ArgumentDefaultsHelpFormatter):
    """Show a default only where it says something (not None/False, not already in the text)."""

    def _get_help_string(self, action):
        text = action.help or ""
        if "default" in text or action.default in (None, False, argparse.SUPPRESS):
            return text
        return super()._get_help_string(action)


def build_parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(
        prog="stereogest",
        description="Stereo-vision hand-gesture recogniser for the DE1-SoC: "
                    "golden model, scene renderer and tools.")
    sub = parser.add_subparsers(dest="command", metavar="COMMAND", required=True)
    for mod_name in COMMANDS:
        mod = importlib.import_module(f"stereogest.commands.{mod_name}")
        p = sub.add_parser(mod.NAME, help=mod.HELP, description=mod.__doc__,
                           formatter_class=_HelpFormatter)
        mod.add_arguments(p)
        p.set_defaults(_run=mod.run)
    return parser


def main(argv: list[str] | None = None) -> int:
    parser = build_parser()
    args = parser.parse_args(argv)
    try:
        return int(args._run(args) or 0)
    except (ValueError, FileNotFoundError) as exc:
        print(f"stereogest {args.command}: error: {exc}", file=sys.stderr)
        return 2
    except RuntimeError as exc:  # a tool (Verilator, yosys) or a simulation failed
        print(f"stereogest {args.command}: error: {exc}", file=sys.stderr)
        return 1
    except KeyboardInterrupt:
        print(f"stereogest {args.command}: interrupted", file=sys.stderr)
        return 130


if __name__ == "__main__":
    raise SystemExit(main())
