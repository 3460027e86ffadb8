"""A report is a declared list of sections. A section is one object: it measures or reads
what it shows from the report's source (for a run: its rows, its folder, the readings
beside it) once, then renders that to markdown and to HTML. So report.md and report.html
carry the same sections in the same order, and adding a section is one object and one line
of the list.

    class Section:                        # or any object with the same methods
        def measure(self, source): ...    # what it shows (None, empty: the section is left out)
        def markdown(self, data) -> str   # its markdown, opening with its "## title"
        def html(self, data, html) -> str # its HTML (None, the default: its markdown as HTML)

A section's markdown is rendered once (drawing a plot, writing a CSV beside the report are
done then, once), and it is its HTML unless `html` renders more (links, colours, sort keys).

A reading module (physval/readings/: `measure(...)` -> rows, `section(rows)` -> markdown)
is such an object as it is: `Reading(module)`, or the bare module in a report's list,
hands it the source's results frame (`reads="df"`; another attribute of the source, or a
function of it, by name).
"""
from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Callable, Sequence

import pandas as pd
from markupsafe import Markup

from physval.files import write_atomic
from physval.report.html import Html
from physval.report.text import anchor, contents, heading, titles


class Section:
    """One section of a report (see the module's docstring); subclasses render markdown,
    and HTML where a page can show more than the markdown's (links, colours, sort keys)."""

    def measure(self, source) -> Any:
        return source

    def markdown(self, data) -> str:
        raise NotImplementedError

    def html(self, data, html: Html) -> str | None:
        return None


@dataclass(frozen=True)
class Reading(Section):
    """A reading module as a section: `module.measure(reads(source))`, then
    `module.section(rows)` for its markdown (and `module.html(rows, html)` if it has one)."""
    module: Any
    reads: str | Callable = "df"

    def measure(self, source):
        got = self.reads(source) if callable(self.reads) else getattr(source, self.reads)
        return self.module.measure(got)

    def markdown(self, data) -> str:
        return self.module.section(data)

    def html(self, data, html: Html) -> str | None:
        return self.module.html(data, html) if hasattr(self.module, "html") else None


def as_section(part) -> Section:
    """A section as it is; a reading module (measure and section, no markdown) as Reading."""
    if hasattr(part, "markdown"):
        return part
    if hasattr(part, "measure") and hasattr(part, "section"):
        return Reading(part)
    raise TypeError(f"{part!r} is no report section: it needs measure() and markdown() (or a reading's section())")


def _empty(data) -> bool:
    if data is None:
        return True
    if isinstance(data, pd.DataFrame):
        return data.empty
    try:
        return len(data) == 0
    except TypeError:
        return False


def _name(section) -> str:
    """A short name for the ids of a section's HTML tables: its reading's, or its class's."""
    module = getattr(section, "module", None)
    return anchor(module.__name__.rsplit(".", 1)[-1] if module is not None else type(section).__name__) or "section"


@dataclass
class Rendered:
    """The sections of a report as rendered, in order: markdown and HTML side by side."""
    markdown: list[str] = field(default_factory=list)
    html: list[str] = field(default_factory=list)

    def titles(self) -> list[str]:
        return [t for text in self.markdown for _, t in titles(text)]


def render(parts: Sequence, source, html: Html) -> Rendered:
    """Every section measured once and rendered twice; one with nothing to show (its
    measurement empty, or its markdown blank) is left out of both."""
    out = Rendered()
    for part in parts:
        section = as_section(part)
        data = section.measure(source)
        if _empty(data):
            continue
        text = section.markdown(data)
        if not text.strip():
            continue
        out.markdown.append(text)
        shown = section.html(data, html)
        out.html.append(html.markdown(text, _name(section)) if shown is None else shown)
    return out


@dataclass
class Report:
    """A report's title, the command that made it, what an interrupted run misses, the
    markdown lines that open it (under its heading, before the contents), and its
    sections in order. `write` renders them into NAME.md and NAME.html in one folder."""
    title: str
    sections: Sequence
    command: str = ""
    interrupted: str = ""
    opening: Sequence[str] = ()
    contents: bool = True

    def write(self, out: Path, source, html: Html, name: str = "report") -> Rendered:
        done = render(self.sections, source, html)
        head = heading(self.title, self.command, self.interrupted) + list(self.opening)
        toc = [contents(done.markdown)] if self.contents and done.markdown else []
        write_atomic(Path(out) / f"{name}.md", "\n".join(head + toc + done.markdown))
        opening = ([f"Command: `{self.command}`", ""] if self.command else []) + list(self.opening)
        # Python-Markdown nests a list item by 4 spaces (GitHub's markdown by 2, as `contents` writes them)
        parts = [html.markdown("\n".join(opening), "opening")] + [
            html.markdown(t.replace("\n  - ", "\n    - "), "contents") for t in toc]
        write_atomic(Path(out) / f"{name}.html", html.page(  # a section's HTML is markup, not text to escape
            "sections.html", title=self.title, root="", interrupted=self.interrupted,
            parts=[Markup(p) for p in parts + done.html]))
        return done
