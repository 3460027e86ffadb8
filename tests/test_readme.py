"""The worked example of a user case that the README points to (docs/extend/first_case.md)
is a real, loadable, passing case, and the README gives exactly the two set-up commands
that .ci/run relies on, each in a virtual environment."""
from __future__ import annotations

import re
from pathlib import Path

from cases.registry import load_dir

ROOT = Path(__file__).resolve().parent.parent
README = (ROOT / "README.md").read_text()
FIRST_CASE = (ROOT / "docs" / "extend" / "first_case.md").read_text()


def test_the_worked_example_loads_and_runs_on_the_reference(tmp_path):
    (code,) = re.findall(r"```python\n(# my_cases/second_bounce.py\n.*?)```", FIRST_CASE, re.S)
    (tmp_path / "second_bounce.py").write_text(code)
    fams = load_dir(tmp_path)
    assert list(fams) == ["second_bounce"]
    from adapters.registry import available
    if not available("reference"):
        return
    import csv
    from physval.cli import main
    out = tmp_path / "out"
    assert main(["run", "--cases-dir", str(tmp_path), "--cases", "second_bounce", "--engines", "reference",
                 "--quiet", "--workers", "1", "--out", str(out)]) == 0
    rows = list(csv.DictReader(open(out / "results.csv")))
    assert {r["status"] for r in rows} == {"pass"}, [(r["variant"], r["measured"], r["reason"]) for r in rows]


def test_ci_runs_the_readme_test_command_verbatim():
    """Both set-up commands make (or reuse) a virtual environment and install into it:
    Debian 12 and Ubuntu 24.04 let pip install nowhere else."""
    commands = re.findall(r"^    (python3 -m venv .*)$", README, re.M)
    assert len(commands) == 2, commands
    assert all(c.startswith("python3 -m venv .venv && . .venv/bin/activate && pip install ") for c in commands)
    assert commands[1] in (ROOT / ".ci" / "run").read_text().splitlines()
