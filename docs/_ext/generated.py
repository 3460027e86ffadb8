"""Sphinx extension: the figures the docs show come from the files physval generates.

A page names what it shows with one directive line, an HTML comment (so that a page read
as plain markdown, on a forge, shows the sentence before it and nothing else):

    <!-- include: reports/bench/bench.md section="step" -->
    <!-- include: reports/report.md section="Scorecard" paragraphs=1 -->
    <!-- include: pyproject.toml section="[project.optional-dependencies]" -->
    <!-- file-sizes: reports/results.csv reports/knobs.json -->
    <!-- status-counts: reports/results.csv -->
    <!-- command-help: run -->
    <!-- deviation-files -->

The build replaces it with that part of the file (markdown as it is, any other file as a
code block), set apart in a box titled with its source. Paths are from the repository's root. A file or
a section that is not there stops the build with a line naming the page and the directive,
so a page cannot show a figure whose source has gone.

Included markdown was written to sit in its own folder (under reports/), so its headings
become bold lines (they would otherwise enter the page's contents and anchors), its
relative links become their text, and its pictures become the path of the picture.
"""
from __future__ import annotations

import re
import shlex
from pathlib import Path

from sphinx.errors import ExtensionError

DIRECTIVE = re.compile(r"^<!-- (include|file-sizes|status-counts|command-help|deviation-files):?(.*?)-->[ \t]*$", re.M)
HEADING = re.compile(r"^(#{1,6})\s+(.*?)\s*#*\s*$")
# [text](target), the text allowed one level of brackets: [central_impact[e=0.5]](families/...)
LINK = re.compile(r"(!?)\[((?:[^\[\]]|\[[^\[\]]*\])*)\]\(([^)\s]*)\)")
LANGUAGES = {".toml": "toml", ".py": "python", ".txt": "text", ".csv": "text", ".json": "json"}


def setup(app):
    app.connect("source-read", _source_read)
    return {"parallel_read_safe": True, "parallel_write_safe": True}


def _source_read(app, docname: str, source: list[str]) -> None:
    source[0] = expand(source[0], Path(app.confdir).parent, docname)


def expand(markdown: str, root: Path, page: str) -> str:
    """The page with every directive replaced by what it names."""

    def expand(m: re.Match) -> str:
        kind, args = m[1], shlex.split(m[2])
        try:
            if kind == "include":
                return include(root, *args)
            if kind == "file-sizes":
                return file_sizes(root, args)
            if kind == "status-counts":
                return status_counts(root, *args)
            if kind == "command-help":
                return command_help(*args)
            return deviation_files(root)
        except (OSError, ValueError, TypeError, KeyError) as e:
            raise ExtensionError(f"{page}: {m[0].strip()}: {e}") from None

    return DIRECTIVE.sub(expand, markdown)


def include(root: Path, path: str, *options: str) -> str:
    opts = dict(o.split("=", 1) for o in options)
    unknown = set(opts) - {"section", "paragraphs"}
    if unknown:
        raise ValueError(f"unknown options {sorted(unknown)}: section=HEADING, paragraphs=N")
    text = (root / path).read_text(encoding="utf-8")
    section = opts.get("section")
    where = f"`{path}`" + (f", section *{section}*" if section else "")
    if Path(path).suffix != ".md":
        lines = _code_section(text, section) if section else text.splitlines()
        return _framed(where, "\n".join([f"```{LANGUAGES.get(Path(path).suffix, 'text')}", *lines, "```"]))
    lines = _md_section(text, section) if section else _without_title(text.splitlines())
    blocks = _blocks(lines)
    if "paragraphs" in opts:
        blocks = blocks[:int(opts["paragraphs"])]
    return _framed(where, "\n\n".join(_plain(block) for block in blocks))


def _framed(where: str, body: str) -> str:
    """Set apart from the page's own text, under the name of its source."""
    return f"~~~~~{{admonition}} From {where}\n:class: generated\n\n{body}\n~~~~~\n"


def _md_section(text: str, title: str) -> list[str]:
    lines = text.splitlines()
    for i, line in enumerate(lines):
        h = HEADING.match(line)
        if h and h[2] == title:
            level, body = len(h[1]), []
            for rest in lines[i + 1:]:
                n = HEADING.match(rest)
                if n and len(n[1]) <= level:
                    break
                body.append(rest)
            return body
    raise ValueError(f"no heading {title!r}")


def _without_title(lines: list[str]) -> list[str]:
    return lines[1:] if lines and lines[0].startswith("# ") else lines


def _code_section(text: str, start: str) -> list[str]:
    """The lines from the one equal to `start` ("[project.optional-dependencies]") to the
    next line that opens a section."""
    lines = text.splitlines()
    if start not in lines:
        raise ValueError(f"no line {start!r}")
    i = lines.index(start)
    end = next((j for j in range(i + 1, len(lines)) if lines[j].startswith("[")), len(lines))
    return lines[i:end]


def _blocks(lines: list[str]) -> list[str]:
    """Paragraphs, tables and lists: runs of lines between blank lines."""
    return [b.strip("\n") for b in re.split(r"\n[ \t]*\n", "\n".join(lines)) if b.strip()]


def _plain(block: str) -> str:
    def link(m: re.Match) -> str:
        image, text, target = m[1], m[2], m[3]
        if image:
            return f"(picture: `{target}`)"
        return m[0] if re.match(r"[a-z]+://", target) else text

    out = []
    for line in block.splitlines():
        h = HEADING.match(line)
        out.append(f"**{h[2]}**" if h else LINK.sub(link, line))
    return "\n".join(out)


def file_sizes(root: Path, paths: list[str]) -> str:
    rows = ["| file | size |", "|:--|--:|"]
    for path in paths:
        size = (root / path).stat().st_size
        rows.append(f"| `{path}` | {size / 1e6:.1f} MB |" if size >= 1e6 else f"| `{path}` | {size / 1e3:.0f} KB |")
    return "\n".join(rows) + "\n\n*Sizes of the files as they are in this checkout.*\n"


def status_counts(root: Path, path: str) -> str:
    """Checks by status for each engine of a results.csv, in the order the engines first
    appear (the order of the run)."""
    import csv

    statuses = ("pass", "deviation", "fail", "unsupported", "unstable", "error")
    counts: dict[str, dict[str, int]] = {}
    with open(root / path, newline="", encoding="utf-8") as f:
        for row in csv.DictReader(f):
            counts.setdefault(row["engine"], dict.fromkeys(statuses, 0))[row["status"]] += 1
    if not counts:
        raise ValueError("no rows")
    rows = ["| engine | " + " | ".join(statuses) + " |", "|:--|" + "--:|" * len(statuses)]
    rows += [f"| `{engine}` | " + " | ".join(str(c[s]) for s in statuses) + " |" for engine, c in counts.items()]
    return "\n".join(rows) + f"\n\n*Counted from `{path}`.*\n"


def command_help(*command: str) -> str:
    """`physval [COMMAND] --help` as the installed command line prints it, 100 columns wide."""
    import argparse
    import os

    from physval.cli import COMMANDS, parser

    if command and command[0] not in COMMANDS:
        raise ValueError(f"no command {command[0]!r}: one of {', '.join(COMMANDS)}")
    p = parser(list(command[:1]))
    if command:
        (sub,) = [a for a in p._actions if isinstance(a, argparse._SubParsersAction)]
        p = sub.choices[command[0]]
    columns = os.environ.get("COLUMNS")
    os.environ["COLUMNS"] = "100"
    try:
        text = p.format_help()
    finally:
        if columns is None:
            del os.environ["COLUMNS"]
        else:
            os.environ["COLUMNS"] = columns
    return f"```text\n{text.rstrip()}\n```\n\n*From `physval {' '.join(command + ('--help',))}`.*\n"


def deviation_files(root: Path) -> str:
    """Every engine's deviation file: a table of entries and bands, then each file's own
    opening comment and its entries (pattern and cause) under a heading of its own."""
    from physval.core.deviations import parse  # the one reader of the format

    files = sorted((root / "adapters" / "xfails").glob("*.txt"), key=lambda p: p.stem)
    if not files:
        raise ValueError("no adapters/xfails/*.txt")
    summary = ["| engine | entries | bands |", "|:--|--:|--:|"]
    blocks = []
    for path in files:
        entries = parse(path)
        engine = path.stem
        summary.append(f"| `{engine}` | {len(entries)} | {sum(len(e.bands) for e in entries)} |")
        header = []
        for line in path.read_text(encoding="utf-8").splitlines():
            if not line.startswith("#"):
                break
            header.append(line.lstrip("# ").rstrip())
        rows = ["| checks | cause |", "|:--|:--|"]
        rows += [f"| `{e.pattern}` | {_escape(e.reason)} |" for e in entries]
        body = [f"### {engine}", "", f"`adapters/xfails/{path.name}`: {len(entries)} entries, "
                f"{sum(len(e.bands) for e in entries)} bands.", ""]
        body += [_escape(" ".join(header)), ""] if header else []
        body += rows if entries else ["No entry: every check of this engine is within its tolerance."]
        blocks.append("\n".join(body))
    return "\n".join(summary) + "\n\n*From `adapters/xfails/*.txt`.*\n\n" + "\n\n".join(blocks) + "\n"


def _escape(text: str) -> str:
    """Hand-written text as it reads, in a table cell or a paragraph: no markup."""
    return re.sub(r"([\\`*_\[\]<>|])", r"\\\1", text)
