"""Markdown pieces: a report's heading, tables, numbers, anchors and table of contents; a
frame written as CSV, and another command's CSV read back."""
from __future__ import annotations

import math
import re
from pathlib import Path

import numpy as np
import pandas as pd

from physval.files import write_atomic


def heading(title: str, command: str = "", interrupted: str = "") -> list[str]:
    """A report's first lines: its title, the command that made it, and, for a run that
    was interrupted, a bold notice saying so (`interrupted` says what is missing)."""
    lines = [f"# {title}", ""]
    if command:
        lines += [f"Command: `{command}`", ""]
    if interrupted:
        lines += [f"**INCOMPLETE: {interrupted}** Run the same command again to finish it.", ""]
    return lines


def md_table(df: pd.DataFrame, missing: str | None = None) -> str:
    """`df` as a markdown table; with `missing`, a missing cell (NaN, None) prints as it (a
    figure not measured: "" where the row says why), else as pandas prints it ("nan")."""
    if not len(df):
        return "_(none)_"
    if missing is None:
        return df.to_markdown(index=False)
    return df.astype(object).where(df.notna(), None).to_markdown(index=False, missingval=missing)


# what ends a clause in a note: a colon, semicolon, comma or full stop before a space, or
# the space before a parenthesis
_CLAUSE_END = re.compile(r"[:;,.](?= )| (?=\()")


def first_clause(note: str, width: int = 100) -> str:
    """A note for a table cell: whole up to `width` characters; a longer one cut after its
    leading clauses that fit in `width` (after its first clause where not even that fits),
    never inside a word, its end marked " …". The whole note stays in the rows it came from."""
    text = " ".join(str(note).split())
    if len(text) <= width:
        return text
    ends = [m.start() + (m.group() != " ") for m in _CLAUSE_END.finditer(text) if m.start() > 0]
    fit = [e for e in ends if e <= width]
    if not ends:
        return text
    return text[:(fit or ends)[-1 if fit else 0]].rstrip(" :;,.") + " …"


def fmt(x) -> str:
    if isinstance(x, (float, np.floating)):
        if math.isnan(x):
            return ""
        return f"{x:.4g}"
    return str(x)


def anchor(title: str) -> str:
    """The GitHub-style anchor of a markdown heading."""
    keep = "".join(ch for ch in title.lower() if ch.isalnum() or ch in " -_")
    return keep.strip().replace(" ", "-")


def titles(text: str, level: int = 2) -> list[tuple[int, str]]:
    """The headings of `level` and one below in a markdown text: (level, title) each."""
    found = []
    for line in text.splitlines():
        hashes = len(line) - len(line.lstrip("#"))
        if line.startswith("#") and level <= hashes <= level + 1 and line[hashes:hashes + 1] == " ":
            found.append((hashes, line[hashes:].strip()))
    return found


def contents(sections: list[str], level: int = 2) -> str:
    """A table of contents of the headings of `level` (and one below) in `sections`."""
    lines = ["## Contents", ""]
    for text in sections:
        lines += [f"{'  ' * (hashes - level)}- [{title}](#{anchor(title)})" for hashes, title in titles(text, level)]
    return "\n".join(lines) + "\n"


def write_csv(df: pd.DataFrame, path: Path, columns: list[str] | None = None) -> None:
    write_atomic(path, (df[columns] if columns else df).to_csv(index=False))

def companion_table(file: Path, command: str, columns) -> pd.DataFrame | str:
    """The table another command wrote in `file`, or why it cannot be used: it cannot be
    read as CSV, or lacks one of `columns`."""
    try:
        table = pd.read_csv(file)
    except (OSError, ValueError) as exc:  # pandas' EmptyDataError and ParserError are ValueErrors
        return f"cannot be read as the table `physval {command}` writes ({type(exc).__name__}: {exc})"
    missing = [c for c in columns if c not in table.columns]
    if missing:
        return f"not the table `physval {command}` writes (no {', '.join(missing)} column)"
    return table
