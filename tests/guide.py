"""The worked example of docs/extend/writing_cases.md as files, so tests run exactly what the
guide shows (a code block is found by its first line, e.g. '# my_cases/pair_drop.py')."""
from __future__ import annotations

import re
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
GUIDE = ROOT / "docs" / "extend" / "writing_cases.md"


def block(first_line: str) -> str:
    """The fenced code block of the guide that starts with `first_line`."""
    found = re.findall(r"^```\w*\n(" + re.escape(first_line) + r"\n.*?)^```", GUIDE.read_text(), re.S | re.M)
    assert len(found) == 1, f"{GUIDE.name}: {len(found)} code blocks start with {first_line!r}"
    return found[0]


def write_example(folder: Path) -> Path:
    """my_cases/pair_drop.py of the guide under `folder`; returns the file."""
    cases = folder / "my_cases"
    cases.mkdir(parents=True, exist_ok=True)
    path = cases / "pair_drop.py"
    path.write_text(block("# my_cases/pair_drop.py"))
    return path


def write_known(folder: Path) -> Path:
    """my_known.txt of the guide (the entry line, without bands) under `folder`."""
    path = folder / "my_known.txt"
    path.write_text(block("# my_known.txt"))
    return path


def section(heading: str) -> str:
    """The guide's text under the heading line `heading` (its '#'s included), up to the next
    heading of the same or a higher level."""
    text = GUIDE.read_text()
    level = len(heading) - len(heading.lstrip("#"))
    found = re.search(r"^" + re.escape(heading) + r"\n(.*?)(?=^#{1," + str(level) + r"} |\Z)", text, re.S | re.M)
    assert found, f"{GUIDE.name}: no heading {heading!r}"
    return found.group(1)
