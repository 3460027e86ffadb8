"""The pages of report.html beside it, in html/: one page per family (what it checks, where
its closed form comes from, every tolerance with its reason, its heat map, the measured
values) and one page per engine (its scorecard row, known deviations with cause and band,
failures, unsupported runs, knobs). report.html itself is the report's sections
(physval.readings.results). Every table sorts (click a heading) and the long ones filter (a
box above them). The pages are Jinja2 templates in physval/readings/templates/, extending
the report kit's base.html.

The pages are drawn from the results frame alone (and the families' summary and source), so
they can be rebuilt from a results.csv: `python3 -m physval.readings.results FOLDER` (the
plots already in FOLDER/plots are shown, none are drawn).
"""
from __future__ import annotations

import json
import re
from pathlib import Path

import pandas as pd

from physval.readings import scorecard
from physval.readings.checks import (deviation_summary, deviation_table, family_table, status_class, status_counts,
                                     tolerance_reasons)
from physval.report import Html, table, write_atomic

SITE = "html"  # the folder beside report.html holding the family and engine pages


def slug(name: str) -> str:
    """A file name for an engine or family name (letters, digits, '-', '_', '.' kept)."""
    return re.sub(r"[^A-Za-z0-9_.-]", "_", name)


def family_page(family: str, root: str = "") -> str:
    """The link to a family's page from a page at `root` ("" for report.html)."""
    return f"{root}{SITE}/families/{slug(family)}.html"


def engine_page(engine: str, root: str = "") -> str:
    return f"{root}{SITE}/engines/{slug(engine)}.html"


def problems(df: pd.DataFrame) -> pd.DataFrame:
    bad = df[df.status.isin(["fail", "unstable", "error"])]
    return pd.DataFrame({"status": bad.status, "family": bad.case, "variant": bad.variant, "metric": bad.metric,
                         "expected": bad.expected, "measured": bad.measured, "reason": bad.reason})


def _pages_in(folder: Path, keep: set[str]) -> None:
    """Remove pages of `folder` a former run wrote that this one does not (nothing links them)."""
    for old in folder.glob("*.html") if folder.is_dir() else ():
        if old.name not in keep:
            old.unlink()


def write(out: Path, df: pd.DataFrame, families: dict, card: pd.DataFrame, html: Html,
          interrupted: str = "", releases: dict[str, str] | None = None) -> None:
    """The family and engine pages of a run's rows in out/html/ (`card`: its scorecard,
    physval.readings.scorecard.measure). `interrupted`: what an interrupted run is missing,
    said on every page (its plots, drawn when the run completes, are not shown: those in
    the folder may be an earlier run's). `releases`: engine -> the note that its known
    deviations were measured on another release (physval.core.deviations.release_notes)."""
    out = Path(out)
    engines = list(dict.fromkeys(df.engine))
    root = "../../"

    def plot(name: str) -> str:
        """The link to plots/<name>.png from a page, if the run drew it."""
        return f"{root}plots/{name}.png" if not interrupted and (out / "plots" / f"{name}.png").is_file() else ""

    def family_href(f):
        return family_page(f, root)

    pages = {}
    for name in sorted(df.case.unique()):
        fam, mine = families.get(name), df[df.case == name]
        summary = getattr(fam, "summary", "")
        pages[out / family_page(name)] = html.page(
            "family.html", title=name, root=root, interrupted=interrupted,
            summary=summary[:1].upper() + summary[1:] + "." if summary else "",
            source=getattr(fam, "source", ""), effects=mine.iloc[0].effects or "none", counts=status_counts(mine),
            tolerances=table("tolerances", tolerance_reasons(df, name)), plot=plot(name),
            measured=table("measured", family_table(df, name), classes={e: status_class for e in engines}))

    for engine in engines:
        mine = df[df.engine == engine]
        knobbed = mine[mine.knobs != ""]
        first = knobbed.iloc[0] if len(knobbed) else None
        causes = deviation_summary(mine)
        unsupported = mine[mine.status == "unsupported"].drop_duplicates(["case", "reason"])
        pages[out / engine_page(engine)] = html.page(
            "engine.html", title=engine, root=root, interrupted=interrupted, version=mine.iloc[0].engine_version,
            release=(releases or {}).get(engine, ""),
            counts=status_counts(mine),
            scorecard=scorecard.table_of(card[card.engine == engine], lambda e: engine_page(e, root)),
            causes=table("causes", causes.drop(columns="engine") if len(causes) else causes),
            deviations=table("deviations", deviation_table(mine).drop(columns="engine")),
            problems=table("problems", problems(mine), links={"family": family_href}),
            unsupported=table("unsupported", pd.DataFrame({"family": unsupported.case, "reason": unsupported.reason}),
                              links={"family": family_href}),
            knobs=json.dumps(json.loads(first.knobs), indent=1, sort_keys=True) if first is not None else "",
            knob_case=f"{first.case}[{first.variant}]" if first is not None else "",
            knob_effects=first.effects_simulated if first is not None else "")

    _pages_in(out / SITE / "families", {p.name for p in pages if p.parent.name == "families"})
    _pages_in(out / SITE / "engines", {p.name for p in pages if p.parent.name == "engines"})
    for path, text in pages.items():
        write_atomic(path, text)
