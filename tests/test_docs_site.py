"""The documentation as a reader meets it: the README a front door of at most 200 lines
whose links resolve and which types no measured figure; the site in docs/ built in strict
mode (a broken link or anchor, a page left out of the contents, or a generated figure whose
file or section has gone stops it); and the build's directives (docs/_ext/generated.py)
including what they name, and refusing what is not there. That every command the pages show
runs from the installed wheel is tests/test_installed.py's."""
from __future__ import annotations

import re
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parent.parent
DOCS = ROOT / "docs"
README = ROOT / "README.md"
sys.path.insert(0, str(DOCS / "_ext"))
import generated  # noqa: E402  (docs/_ext is no package: Sphinx finds it through docs/conf.py)

# A number with a unit of time, size or ratio: what a regeneration changes. The README keeps
# none (decision 13); the pages include them from generated files.
MEASURED = re.compile(r"\b\d+(?:\.\d+)?\s?(?:ms|us|µs|s|min|minutes|hours|MB|KB|GB|%|x)(?![\w-])")


def test_the_readme_is_a_front_door():
    text = README.read_text()
    assert len(text.splitlines()) <= 200, f"README.md has {len(text.splitlines())} lines; topics go to docs/"
    figures = [(i, line) for i, line in enumerate(text.splitlines(), 1) if MEASURED.search(line)]
    assert not figures, f"measured figures in README.md (they belong on a page that includes them): {figures}"
    targets = re.findall(r"\]\(([^)#\s]+)(?:#[^)]*)?\)", text)
    assert any(t.startswith("docs/") for t in targets)
    broken = [t for t in targets if not re.match(r"[a-z]+://", t) and not (ROOT / t).exists()]
    assert not broken, f"README.md links to files that are not there: {broken}"


def test_the_site_builds_in_strict_mode(tmp_path):
    """The command the docs give (sphinx-build -W), into a folder of the test's own."""
    for module in ("sphinx", "myst_parser", "furo"):
        pytest.importorskip(module, reason='the docs toolchain: pip install ".[docs]"')
    done = subprocess.run([sys.executable, "-m", "sphinx", "-W", "--keep-going", "-q", "-b", "html",
                           "-d", str(tmp_path / "doctrees"), str(DOCS), str(tmp_path / "site")],
                          cwd=ROOT, capture_output=True, text=True, timeout=600)
    assert done.returncode == 0, done.stderr[-4000:]
    pages = {p.relative_to(DOCS).with_suffix(".html") for p in DOCS.rglob("*.md") if "_ext" not in p.parts}
    built = {p.relative_to(tmp_path / "site") for p in (tmp_path / "site").rglob("*.html")}
    assert pages <= built, pages - built
    report = (tmp_path / "site" / "use" / "report.html").read_text()
    assert "From <code" in report and "reports/report.md" in report  # a generated part, named by its source


def test_the_commands_page_has_every_commands_help():
    from physval.cli import COMMANDS
    page = (DOCS / "use" / "commands.md").read_text()
    missing = [c for c in COMMANDS if f"<!-- command-help: {c} -->" not in page]
    assert not missing, f"docs/use/commands.md gives no help of: {missing}"


# --- the directives, on files made here -------------------------------------------------------

REPORT = """# a report

Command: `physval run`

12 checks: 10 pass, 2 fail.

## Scorecard

The rule: **A** all within tolerance; see [central_impact[e=0.5]](families/central_impact.md) and [docs](https://example.org).

![a plot](plots/x.png)

| engine | grade |
|---|---|
| mujoco | A |

### detail

inside the section

## Cost

not in the section
"""


def _root(tmp_path) -> Path:
    (tmp_path / "reports").mkdir()
    (tmp_path / "reports" / "report.md").write_text(REPORT)
    (tmp_path / "pyproject.toml").write_text('[project]\nname = "x"\n\n[project.optional-dependencies]\n'
                                             'a = ["b>=1"]  # 9 MB\n\n[tool.x]\ny = 1\n')
    return tmp_path


def test_an_include_takes_its_section_and_names_its_source(tmp_path):
    root = _root(tmp_path)
    out = generated.expand('<!-- include: reports/report.md section="Scorecard" -->', root, "page")
    assert out.startswith("~~~~~{admonition} From `reports/report.md`, section *Scorecard*")
    assert "| mujoco | A |" in out and "inside the section" in out and "not in the section" not in out
    assert "**detail**" in out and "### detail" not in out       # headings stay out of the page's contents
    assert "see central_impact[e=0.5] and [docs](https://example.org)" in out  # its own links: their text
    assert "(picture: `plots/x.png`)" in out and "![" not in out
    first = generated.expand("<!-- include: reports/report.md paragraphs=2 -->", root, "page")
    assert "Command: `physval run`" in first and "12 checks" in first and "Scorecard" not in first


def test_an_include_of_another_file_is_a_code_block_of_its_section(tmp_path):
    root = _root(tmp_path)
    out = generated.expand('<!-- include: pyproject.toml section="[project.optional-dependencies]" -->', root, "p")
    assert "```toml\n[project.optional-dependencies]\na = [\"b>=1\"]  # 9 MB\n" in out and "[tool.x]" not in out


@pytest.mark.parametrize("directive", ['<!-- include: reports/report.md section="Nowhere" -->',
                                       "<!-- include: reports/gone.md -->",
                                       "<!-- include: reports/report.md lines=3 -->",
                                       "<!-- file-sizes: reports/gone.csv -->",
                                       "<!-- command-help: no-such-command -->"])
def test_a_directive_whose_source_is_not_there_stops_the_build(tmp_path, directive):
    from sphinx.errors import ExtensionError
    with pytest.raises(ExtensionError, match=re.escape(directive)):
        generated.expand(f"text\n{directive}\nmore", _root(tmp_path), "page")


def test_status_counts_and_file_sizes_are_read_from_the_files(tmp_path):
    root = _root(tmp_path)
    (root / "reports" / "results.csv").write_text("engine,status\nmujoco,pass\nmujoco,fail\ndart,pass\n")
    out = generated.expand("<!-- status-counts: reports/results.csv -->\n<!-- file-sizes: reports/results.csv -->",
                           root, "page")
    assert "| `mujoco` | 1 | 0 | 1 | 0 | 0 | 0 |" in out and "| `dart` | 1 | 0 | 0 | 0 | 0 | 0 |" in out
    assert f"| `reports/results.csv` | {len((root / 'reports' / 'results.csv').read_bytes()) / 1e3:.0f} KB |" in out
