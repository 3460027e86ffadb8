"""HTML pieces: the Jinja2 pages (templates/ beside this file: base.html, the page every
report page extends, with its sortable and filterable tables; macros.html, the table), a
frame as such a table, and a section's markdown as HTML (Python-Markdown, with the same
heading anchors as the markdown's table of contents and every table sortable).

Pages are opened from disk (no server, no network): every link is relative, and the few
lines of script that sort and filter tables are inlined in base.html.
"""
from __future__ import annotations

import xml.etree.ElementTree as etree
from typing import Callable

import markdown
import pandas as pd
from markdown.extensions import Extension
from markdown.treeprocessors import Treeprocessor
from markupsafe import Markup

from physval.report.text import anchor, fmt

FILTER_FROM = 8  # rows: a table this long gets a filter box


def cell(value, href: str = "", cls: str = "", key="") -> dict:
    """A table cell: its text, a link, a CSS class and a sort key (its text when empty)."""
    return {"text": fmt(value), "href": href, "cls": cls, "key": key}


def table(name: str, df: pd.DataFrame, links: dict[str, Callable] | None = None,
          classes: dict[str, Callable] | None = None) -> dict:
    """A frame as the template's table: `links` column -> value -> href, `classes` column ->
    value -> CSS class; a filter box once it is FILTER_FROM rows long."""
    links, classes = links or {}, classes or {}
    rows = [[cell(v, links[c](v) if c in links else "", classes[c](v) if c in classes else "")
             for c, v in zip(df.columns, values)] for values in df.itertuples(index=False)]
    return rows_table(name, [str(c) for c in df.columns], rows)


def rows_table(name: str, columns: list[str], rows: list[list[dict]]) -> dict:
    """A table of cells made one by one (`cell`)."""
    return {"id": name, "columns": columns, "rows": rows, "filter": len(rows) >= FILTER_FROM}


class Html:
    """The pages of one report: its templates (the kit's, and those of `packages`, which
    may extend base.html) and `links`, which maps a link of a section's markdown to the
    page it names in HTML (a family's families/NAME.md to its HTML page, say)."""

    def __init__(self, *packages: str, links: Callable[[str], str] | None = None):
        import jinja2
        loaders = [jinja2.PackageLoader(p, "templates") for p in (*packages, "physval.report")]
        self.env = jinja2.Environment(loader=jinja2.ChoiceLoader(loaders), autoescape=True, trim_blocks=True,
                                      lstrip_blocks=True, undefined=jinja2.StrictUndefined)
        self.links = links or (lambda href: href)
        self.names: dict[str, int] = {}

    def page(self, template: str, **values) -> str:
        return self.env.get_template(template).render(**values)

    def table(self, t: dict) -> Markup:
        """A table (`table`, `rows_table`) as HTML, as a template's macro draws it."""
        return Markup(self.env.get_template("macros.html").module.table(t))

    def markdown(self, text: str, name: str = "md") -> Markup:
        """Markdown as HTML: headings get the ids `anchor` gives them (the markdown's table
        of contents links them), tables are the sortable tables of the pages (`name`-1,
        `name`-2, ... as ids, `name` numbered when it was used before; a filter box on long ones), links pass through `links`, and
        markdown inside a <details> block is read as markdown."""
        self.names[name] = seen = self.names.get(name, 0) + 1  # two sections' tables never share an id
        name = name if seen == 1 else f"{name}{seen}"
        md = markdown.Markdown(extensions=["tables", "md_in_html", "toc", _Extension(self.links, name)],
                               extension_configs={"toc": {"slugify": lambda value, separator: anchor(value)}})
        return Markup(md.convert(text.replace("<details>", '<details markdown="1">')))


class _Pages(Treeprocessor):
    """Links through the page's `links`; each table sortable, with an id and, when long, a
    filter box (as the macro's tables)."""

    def __init__(self, md, links: Callable[[str], str], name: str):
        super().__init__(md)
        self.links, self.name = links, name

    def run(self, root):
        for a in root.iter("a"):
            if a.get("href"):
                a.set("href", self.links(a.get("href")))
        tables = [(parent, child) for parent in root.iter() for child in parent if child.tag == "table"]
        for count, (parent, child) in enumerate(tables, 1):
            ident = f"t-{self.name}-{count}"
            child.set("class", "data")
            child.set("id", ident)
            at = list(parent).index(child)
            parent.remove(child)
            wrap = etree.Element("div", {"class": "scroll"})
            wrap.append(child)
            parent.insert(at, wrap)
            rows = len(child.findall("./tbody/tr"))
            if rows >= FILTER_FROM:
                box = etree.Element("div")
                etree.SubElement(box, "input", {"class": "filter", "type": "search", "data-table": ident,
                                                "placeholder": "filter rows (words, all must match)"})
                etree.SubElement(box, "span", {"class": "count", "id": f"{ident}-count"}).text = f"{rows} rows"
                parent.insert(at, box)


class _Extension(Extension):
    def __init__(self, links: Callable[[str], str], name: str):
        super().__init__()
        self.links, self.name = links, name

    def extendMarkdown(self, md):
        md.treeprocessors.register(_Pages(md, self.links, self.name), "physval-pages", 1)
