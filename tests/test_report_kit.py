"""The report kit (physval.report): a report is a declared list of sections, each measured
once and rendered to markdown and to HTML, so the two files carry the same sections in the
same order; a reading module (measure() and section()) is a section as it is."""
from __future__ import annotations

import re
import types
from dataclasses import dataclass

import pandas as pd
import pytest

from physval.report import Html, Reading, Report, Section, as_section, render, titles


@dataclass
class Source:
    df: pd.DataFrame
    measured: list


class Counted(Section):
    """A section that records each measurement, to show it is measured once."""

    def __init__(self, title: str):
        self.title = title

    def measure(self, source: Source):
        source.measured.append(self.title)
        return source.df

    def markdown(self, df) -> str:
        self.rendered = getattr(self, "rendered", 0) + 1
        return "\n".join([f"## {self.title}", "", f"{len(df)} rows", ""])


class Empty(Section):
    def measure(self, source):
        return source.df.iloc[0:0]

    def markdown(self, df) -> str:
        raise AssertionError("an empty measurement is not rendered")


def _reading() -> types.ModuleType:
    """A reading as physval/readings/ writes them: measure(df) -> rows, section(rows) -> markdown."""
    module = types.ModuleType("physval.readings.cost_example")
    module.measure = lambda df: df.groupby("engine", as_index=False).wall_s.sum()
    module.section = lambda rows: "\n".join(["## Cost", "", "| engine | wall_s |", "|:--|--:|"]
                                            + [f"| {r.engine} | {r.wall_s:g} |" for r in rows.itertuples()] + [""])
    return module


def _source() -> Source:
    return Source(pd.DataFrame({"engine": ["a", "a", "b"], "wall_s": [1.0, 2.0, 0.5]}), [])


def test_a_reading_module_is_one_section_and_empty_sections_are_left_out():
    source, first = _source(), Counted("First")
    done = render([first, Empty(), _reading(), Counted("Last")], source, Html())
    assert done.titles() == ["First", "Cost", "Last"]
    assert source.measured == ["First", "Last"]  # each measured once, for both renderings
    assert first.rendered == 1  # and its markdown (with what it draws or writes) made once
    assert len(done.html) == len(done.markdown) == 3
    assert '<h2 id="cost">Cost</h2>' in done.html[1] and "<td>3</td>" in done.html[1].replace(' style="text-align: right;"', "")
    assert isinstance(as_section(_reading()), Reading)
    with pytest.raises(TypeError, match="no report section"):
        as_section(object())


def test_report_md_and_report_html_hold_the_same_sections_in_order(tmp_path):
    Report("A report", [Counted("One"), _reading(), Counted("Three")], command="physval x",
           opening=["An opening line.", ""]).write(tmp_path, _source(), Html())
    md = (tmp_path / "report.md").read_text()
    html = (tmp_path / "report.html").read_text()
    assert md.startswith("# A report\n\nCommand: `physval x`\n\nAn opening line.\n\n## Contents\n")
    heads = [t for _, t in titles(md)]
    assert heads == ["Contents", "One", "Cost", "Three"]
    assert re.findall(r"<h2 id=\"[^\"]*\">([^<]*)</h2>", html) == heads
    for title in heads[1:]:  # the contents link every section, in both files
        assert f'href="#{title.lower()}"' in html and f"(#{title.lower()})" in md


def test_a_section_s_markdown_becomes_the_pages_html():
    text = "\n".join(["## Known deviations that vanished", "", "See [the page](families/x.md) and `code`.", "",
                      "| a | b |", "|:--|:--|"] + [f"| {i} | x |" for i in range(9)]
                     + ["", "<details><summary>More</summary>", "", "| c |", "|:--|", "| 1 |", "", "</details>", ""])
    html = Html(links=lambda href: href.replace("families/", "html/families/").replace(".md", ".html"))
    out = str(html.markdown(text, "dev"))
    assert '<h2 id="known-deviations-that-vanished">' in out  # the id report.md's contents link
    assert '<a href="html/families/x.html">the page</a>' in out and "<code>code</code>" in out
    assert '<table class="data" id="t-dev-1">' in out and '<table class="data" id="t-dev-2">' in out  # sortable
    assert 'data-table="t-dev-1"' in out and 'data-table="t-dev-2"' not in out  # a filter box on the long one
    assert "<details>" in out and "| c |" not in out  # markdown inside <details> is read as markdown
    assert 'id="t-dev2-1"' in str(html.markdown(text, "dev"))  # another section of that name: other ids
