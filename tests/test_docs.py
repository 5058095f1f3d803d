"""The documentation site (``make docs``) and the documents users read: the
site builds with warnings as errors (broken cross references and internal links
fail), its references are generated from the code, and the documents describe
the product as it is, not how it got there."""
from __future__ import annotations

import re
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parent.parent
DOCS = ROOT / "docs"

#: What a user reads: the front page, the folder READMEs and the site's pages.
USER_DOCUMENTS = sorted(
    [ROOT / "README.md"] + [ROOT / d / "README.md" for d in ("hdl", "soc", "verif", "boards")]
    + list(DOCS.glob("*.md")) + list(DOCS.glob("*.rst")) + list(DOCS.glob("*/*.md"))
    + list(DOCS.glob("*/*.rst")))
#: How the project's history shows up in prose: issue numbers, rounds of work,
#: "before issue N".
HISTORY = re.compile(r"\b[Ii]ssues? #?\d+|\b(first|second|third|fourth|fifth|sixth) round\b"
                     r"|\bround \d\b|#\d{2}\b")


@pytest.fixture(scope="module")
def site(tmp_path_factory):
    pytest.importorskip("sphinx")
    pytest.importorskip("myst_parser")
    out = tmp_path_factory.mktemp("site")
    proc = subprocess.run([sys.executable, "-m", "sphinx", "-W", "--keep-going", "-q",
                           "-b", "html", str(DOCS), str(out)],
                          capture_output=True, text=True, cwd=ROOT)
    assert proc.returncode == 0, proc.stderr
    return out


def test_site_builds_without_warnings(site):
    for page in ("index", "guides/quartus", "guides/ci", "bring-up", "reference/cli",
                 "reference/registers", "reference/golden-model", "design/hardware",
                 "figures/index"):
        assert (site / f"{page}.html").exists(), page


def test_reference_is_generated_from_the_code(site):
    from soc.hps_interface import FIFO_REGISTERS, POSTURE_REGISTERS, UART_REGISTERS
    from stereogest.cli import COMMANDS
    registers = (site / "reference" / "registers.html").read_text()
    for regmap in (FIFO_REGISTERS, UART_REGISTERS, POSTURE_REGISTERS):
        for register in regmap:
            assert register.name in registers
            for field in register.fields:
                assert field.name in registers, (register.name, field.name)
    cli = (site / "reference" / "cli.html").read_text()
    for name in COMMANDS:
        assert f"stereogest {name.replace('_', '-')}" in cli, name
    assert "python -m sw_hps" in cli and "--spotting" in cli
    model = (site / "reference" / "golden-model.html").read_text()
    assert "process_frame" in model and "sparse_census" in model


@pytest.mark.parametrize("path", USER_DOCUMENTS,
                         ids=lambda p: str(p.relative_to(ROOT)))
def test_documents_tell_no_history(path):
    for number, line in enumerate(path.read_text().splitlines(), 1):
        match = HISTORY.search(line)
        assert match is None, f"{path.relative_to(ROOT)}:{number}: {match.group(0)!r}: {line}"


def test_front_page_is_short():
    readme = (ROOT / "README.md").read_text()
    assert len(readme.splitlines()) <= 200
    assert not re.search(r"\b[0-9a-f]{7,40}\b", readme), "a commit hash on the front page"


def test_help_texts_tell_no_history_and_no_flag_defaults():
    """``--help`` of every command: no issue numbers, no "today's" (relative
    to what?), and a flag never shows a default (``--no-reject`` defaulting to
    True read as rejection being off)."""
    import argparse

    from stereogest.cli import build_parser
    parser = build_parser()
    subs = [a for a in parser._actions if isinstance(a, argparse._SubParsersAction)][0]
    for name, sub in subs.choices.items():
        text = sub.format_help()
        assert not HISTORY.search(text), (name, HISTORY.search(text).group(0))
        assert "today" not in text, name
        assert "(default: True)" not in text and "(default: False)" not in text, name


WORKFLOW = ROOT / ".github" / "workflows" / "ci.yml"


def _tool(name: str) -> str:
    import shutil
    path = Path(sys.executable).parent / name
    found = str(path) if path.exists() else shutil.which(name)
    if found is None:
        pytest.skip(f"{name} is not installed (pip install '.[test]')")
    return found


@pytest.mark.parametrize("linter", ["zizmor", "check-jsonschema"])
def test_ci_workflow_passes_its_linters(linter):
    """The CI recipe of docs/guides/ci.md: valid for GitHub Actions (its schema)
    and clean for zizmor (pinned actions, no credentials kept, least
    permissions), offline."""
    args = {"zizmor": ["--offline", str(WORKFLOW)],
            "check-jsonschema": ["--builtin-schema", "vendor.github-workflows", str(WORKFLOW)]}
    proc = subprocess.run([_tool(linter), *args[linter]], capture_output=True, text=True)
    assert proc.returncode == 0, proc.stdout + proc.stderr


def test_ci_workflow_runs_the_readmes_commands():
    text = WORKFLOW.read_text()
    readme = (ROOT / "README.md").read_text()
    for command in ("make test", "make demo"):
        assert f"run: {command}" in text and command in readme
    assert "STEREOGEST_BUILD_DIR" in text and "actions/cache@" in text
    assert "ci.yml" in (DOCS / "guides" / "ci.md").read_text()


def test_one_version_everywhere():
    """CHANGELOG.md's newest section, ``stereogest --version``, ``python -m
    sw_hps --version``, the bundle's README.txt and the installed metadata say
    one version; the section names the register interface the FIFO's Version
    register reports."""
    from importlib.metadata import version

    import sw_hps
    from soc.hps_interface import CORE_REVISION
    from stereogest.cli import _version
    from sw_hps.bundle import readme
    changelog = (ROOT / "CHANGELOG.md").read_text()
    newest = re.search(r"^## (\d+\.\d+\.\d+) \((\d{4}-\d\d-\d\d)\), register interface "
                       r"revision (\d+)$", changelog, re.M)
    assert newest, "CHANGELOG.md's first section must be '## X.Y.Z (date), register ...'"
    assert newest.group(1) == sw_hps.__version__ == _version() == version("stereogest")
    assert int(newest.group(3)) == CORE_REVISION
    assert readme([]).startswith(f"stereogest board application {sw_hps.__version__}\n")
    for prog in (["-m", "sw_hps"], ["-m", "stereogest"]):
        out = subprocess.run([sys.executable, *prog, "--version"], capture_output=True,
                             text=True, cwd=ROOT).stdout
        assert sw_hps.__version__ in out, (prog, out)


def test_front_page_timing_is_the_records():
    """The front page's routed Fmax per placer seed is hdl/timing_pipeline.json's
    (the record ``make timing`` writes), rounded to 0.1 MHz."""
    import json
    record = json.loads((ROOT / "hdl" / "timing_pipeline.json").read_text())
    readme = (ROOT / "README.md").read_text()
    for name, words in (("thesis", "thesis parameters"),
                        ("calibration + hand tracking", "calibration and hand tracking")):
        seeds = sorted(record["configurations"][name]["seeds"].items(), key=lambda s: int(s[0]))
        figures = " / ".join(f"{run['clocks']['clk']['fmax_mhz']:.1f}" for _, run in seeds)
        assert f"{figures} MHz ({words})" in readme, (name, figures)


def _figures_script():
    import importlib.util
    spec = importlib.util.spec_from_file_location("figures_pages", ROOT / "benchmarks" / "figures.py")
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def test_every_figure_names_its_command_and_commit():
    """Each section of docs/figures/ says which command measured it at which
    commit, and every benchmark script is the command of some section."""
    figures = _figures_script()
    found = figures.sections()
    assert len(found) >= 20 and {s.page for s in found} >= {"fpga", "stereo", "system"}
    assert figures.problems(found) == []


def test_figures_check_finds_what_is_missing(tmp_path):
    figures = _figures_script()
    pages = tmp_path / "figures"
    pages.mkdir()
    (pages / "index.md").write_text("# F\n\n```{toctree}\n:maxdepth: 1\n\npart\n```\n")
    (pages / "part.md").write_text(
        "# Part\n\n## Named\n\nMeasured with `python benchmarks/a.py` at commit `0123abc` "
        "(3 CPU s).\n\n| x |\n|---|\n| 1 |\n\n## Unnamed\n\nA figure: 42.\n\n"
        "## No commit\n\nMeasured with `python benchmarks/a.py` at commit 0123abc.\n")
    scripts = tmp_path / "benchmarks"
    scripts.mkdir()
    for name in ("a.py", "b.py", "figures.py"):
        (scripts / name).write_text("")
    found = figures.sections(pages)
    assert [s.title for s in found] == ["Named", "Unnamed", "No commit"]
    assert found[0].measurements[0].commands == ["python benchmarks/a.py"]
    assert found[0].measurements[0].commits == ["0123abc"]
    issues = figures.problems(found, scripts, check_commits=False)
    assert any("'Unnamed': no 'Measured with" in line for line in issues)
    assert any("'No commit': a Measured line names no commit" in line for line in issues)
    assert any(line.startswith("benchmarks/b.py: no figures section") for line in issues)
    assert not any("a.py" in line or "figures.py" in line for line in issues)
    # a commit that is not in the history is named
    issues = figures.problems(found[:1], scripts, check_commits=True)
    assert any("commit 0123abc" in line for line in issues) or figures._shallow()


def test_make_bench_prints_every_figure_section():
    figures = _figures_script()
    proc = subprocess.run([sys.executable, str(ROOT / "benchmarks" / "figures.py")],
                          capture_output=True, text=True, cwd=ROOT)
    assert proc.returncode == 0, proc.stderr
    for section in figures.sections():
        assert f"== {section.title}" in proc.stdout
    assert "**" not in proc.stdout and "](" not in proc.stdout
    bad = subprocess.run([sys.executable, str(ROOT / "benchmarks" / "figures.py"),
                          "--page", "nowhere"], capture_output=True, text=True, cwd=ROOT)
    assert bad.returncode == 2 and bad.stderr.count("\n") == 1 and "--page" in bad.stderr
    assert "benchmarks/figures.py" in (ROOT / "Makefile").read_text()


def test_front_page_figures_come_from_the_figures_pages():
    """Each number of the front page's figures table stands on a figures page:
    the front page quotes the figures, it does not hold them. (The routed Fmax,
    rounded there, is tied to its record by the test above.)"""
    readme = (ROOT / "README.md").read_text()
    table = readme.split("## Figures", 1)[1].split("\n## ", 1)[0]
    pages = "\n".join(p.read_text() for p in (DOCS / "figures").glob("*.md"))
    rows = [line for line in table.split("\n") if line.startswith("| ")][1:]
    assert len(rows) >= 10
    for row in rows:
        if "`make timing`" in row:
            continue
        value = row.strip("|").split("|")[1]
        for number in re.findall(r"\d[\d,]*(?:\.\d+)?", value):
            assert number in pages, (number, row[:60])
