"""Every figure the benchmarks measured, as the figures pages state them.

The figures live once, in ``docs/figures/`` (one page per part of the system,
in the order of ``docs/figures/index.md``). Each ``##`` section there opens with
one line per command::

    Measured with `COMMAND` at commit `HASH` (N CPU s).

This script prints the pages as plain text (``make bench`` runs it before it
measures the quick benchmarks again), or, with ``--check``, checks them: every
section names its command and commit, every commit is in the repository's
history (unless the clone is shallow), and every benchmark script of
``benchmarks/`` is the command of some section.

Run as ``python benchmarks/figures.py [--page NAME] [--brief] [--check]``.
"""

import argparse
import re
import subprocess
import sys
from dataclasses import dataclass, field
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
FIGURES = ROOT / "docs" / "figures"
#: Scripts of benchmarks/ that measure no figure of their own.
NOT_FIGURES = {
    "figures.py": "prints the figures pages",
    "scene_pictures.py": "draws the scene difficulties' pictures",
}

MEASURED = re.compile(r"^Measured with (?P<what>.+?) at commit (?P<rest>.+)$")
COMMIT = re.compile(r"`([0-9a-f]{7,40})\+?`")
CODE = re.compile(r"`([^`]+)`")
LINK = re.compile(r"\[([^\]]+)\]\([^)]+\)")


@dataclass
class Measurement:
    """One ``Measured with`` line: the commands and the commits."""
    commands: list[str]
    commits: list[str]
    line: str


@dataclass
class Section:
    """A ``##`` section of a figures page."""
    page: str
    title: str
    measurements: list[Measurement] = field(default_factory=list)
    body: list[str] = field(default_factory=list)


def pages(root: Path = FIGURES) -> list[Path]:
    """The figures pages in the order of the index's table of contents."""
    index = (root / "index.md").read_text().split("\n")
    names, inside = [], False
    for line in index:
        if line.startswith("```{toctree}"):
            inside = True
        elif inside and line.startswith("```"):
            break
        elif inside and line.strip() and not line.startswith(":"):
            names.append(line.strip())
    return [root / f"{name}.md" for name in names]


def sections(root: Path = FIGURES) -> list[Section]:
    """Every ``##`` section of every figures page, with its measurements."""
    found = []
    for path in pages(root):
        current = None
        for line in path.read_text().split("\n"):
            if line.startswith("## "):
                current = Section(path.stem, line[3:].strip())
                found.append(current)
                continue
            if current is None or line.startswith("<!--"):
                continue
            match = MEASURED.match(line)
            if match:
                current.measurements.append(Measurement(
                    CODE.findall(match["what"]),
                    COMMIT.findall(match["rest"].split(" (")[0].split(" with ")[0]), line))
            else:
                current.body.append(line)
    return found


def _shallow() -> bool:
    proc = subprocess.run(["git", "rev-parse", "--is-shallow-repository"], cwd=ROOT,
                          capture_output=True, text=True)
    return proc.returncode != 0 or proc.stdout.strip() != "false"


def _known(commit: str) -> bool:
    return subprocess.run(["git", "cat-file", "-e", f"{commit}^{{commit}}"], cwd=ROOT,
                          capture_output=True).returncode == 0


def problems(found: list[Section], benchmarks: Path = ROOT / "benchmarks",
             check_commits: bool | None = None) -> list[str]:
    """What is wrong with the figures pages, one line each (empty: nothing)."""
    out = []
    for s in found:
        where = f"docs/figures/{s.page}.md, '{s.title}'"
        if not s.measurements:
            out.append(f"{where}: no 'Measured with `COMMAND` at commit `HASH`' line")
        for m in s.measurements:
            if not m.commands:
                out.append(f"{where}: a Measured line names no command in backticks")
            if not m.commits:
                out.append(f"{where}: a Measured line names no commit in backticks")
    if check_commits is None:
        check_commits = not _shallow()
    if check_commits:
        for commit in sorted({c for s in found for m in s.measurements for c in m.commits}):
            if not _known(commit):
                out.append(f"commit {commit} of the figures pages is not in this repository")
    commands = " ".join(c for s in found for m in s.measurements for c in m.commands)
    for script in sorted(benchmarks.glob("*.py")):
        if script.name not in NOT_FIGURES and f"benchmarks/{script.name}" not in commands:
            out.append(f"benchmarks/{script.name}: no figures section names it as its command")
    return out


def plain(text: str) -> str:
    """Markdown as a terminal shows it best (links may span lines)."""
    return LINK.sub(r"\1", text).replace("**", "")


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(prog="python benchmarks/figures.py",
                                     description=__doc__.split("\n\n")[0])
    parser.add_argument("--page", action="append", metavar="NAME",
                        help="only this page of docs/figures/ (repeatable): "
                             + ", ".join(p.stem for p in pages()))
    parser.add_argument("--brief", action="store_true",
                        help="only each section's title, commands and commits")
    parser.add_argument("--check", action="store_true",
                        help="check the pages instead of printing them; exit 1 on a problem")
    args = parser.parse_args(argv)
    found = sections()
    names = {s.page for s in found}
    for name in args.page or []:
        if name not in names:
            print(f"error: --page: {name!r} is not a figures page (one of "
                  f"{', '.join(sorted(names))})", file=sys.stderr)
            return 2
    if args.check:
        issues = problems(found)
        for line in issues:
            print(line)
        print(f"{len(found)} sections, {len(issues)} problems")
        return 1 if issues else 0
    page = None
    for s in found:
        if args.page and s.page not in args.page:
            continue
        if s.page != page:
            page = s.page
            print(f"\n#### docs/figures/{page}.md\n")
        print(f"== {s.title}")
        for m in s.measurements:
            print(f"   {', '.join(m.commands)} @ {', '.join(m.commits)}")
        if not args.brief:
            body = plain("\n".join(s.body)).strip("\n")
            print(f"\n{body}\n" if body else "")
    return 0


if __name__ == "__main__":
    sys.exit(main())
