"""The report kit every report is built from: a report is a declared list of sections, each
one object that measures or reads its rows once and renders them to markdown and HTML
(sections.py); markdown pieces (text.py), HTML pages and tables (html.py, templates/),
figures (figures.py), the environment table (environment.py), and atomic file writes.
The kit knows nothing of the rest of physval: readings and commands build on it."""
from physval.files import write_atomic
from physval.report.environment import environment
from physval.report.figures import MARKERS, engine_styles, pyplot, save_figure
from physval.report.html import Html, cell, rows_table, table
from physval.report.sections import Reading, Rendered, Report, Section, as_section, render
from physval.report.text import (anchor, companion_table, contents, first_clause, fmt, heading, md_table, titles,
                                 write_csv)

__all__ = ["write_atomic", "environment", "MARKERS", "engine_styles", "pyplot", "save_figure", "Html", "cell",
           "rows_table", "table", "Reading", "Rendered", "Report", "Section", "as_section", "render", "anchor",
           "companion_table", "contents", "first_clause", "fmt", "heading", "md_table", "titles", "write_csv"]
