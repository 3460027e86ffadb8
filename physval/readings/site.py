"""report.html: a run's report as a static site beside report.md, opened from disk (no
server, no network): the index (scorecard, summary, families, engines, failures,
implementation parity, environment), one page per family (what it checks, where its closed form comes from, every
tolerance with its reason, its heat map, the measured values) and one page per engine (its
scorecard row, known deviations with cause and band, failures, unsupported runs, knobs).
Every table sorts (click a heading) and the long ones filter (a box above them); a few
lines of script inlined in each page do it.

The site is drawn from the results frame alone (and the families' summary and source), so
it can be rebuilt from a results.csv: `python3 -m physval.readings.site FOLDER` (the plots
already in FOLDER/plots are shown, none are drawn). The pages are Jinja2 templates shipped
in physval/readings/templates/.
"""
from __future__ import annotations

import json
import re
import sys
from pathlib import Path

import pandas as pd

from physval.readings import scorecard
from physval.readings.results import INTRO, engine_groups, family_table, tolerance_reasons
from physval.reportkit import (STATUS_MARK, deviation_summary, deviation_table, engine_versions, environment, fmt,
                               frame, status_counts, summary_matrix, write_atomic)

SITE = "html"            # the folder beside report.html holding the family and engine pages
FILTER_FROM = 8          # rows: a table this long gets a filter box

SUMMARY_LEGEND = ("Each cell: status counts and the worst error in units of tolerance (below 1: within tolerance). "
                  "pass: within the tolerance; FAIL: outside it, or a known deviation that left its recorded band; "
                  "dev: a known engine shortfall within its band; n/a: the engine cannot represent the scene; "
                  "UNSTABLE: the state blew up; ERROR: an exception, named in results.csv.")


def slug(name: str) -> str:
    """A file name for an engine or family name (letters, digits, '-', '_', '.' kept)."""
    return re.sub(r"[^A-Za-z0-9_.-]", "_", name)


def _env():
    import jinja2
    return jinja2.Environment(loader=jinja2.PackageLoader("physval.readings", "templates"),
                              autoescape=True, trim_blocks=True, lstrip_blocks=True,
                              undefined=jinja2.StrictUndefined)


def _cell(value, href: str = "", cls: str = "") -> dict:
    return {"text": fmt(value), "href": href, "cls": cls}


def table(name: str, df: pd.DataFrame, links: dict[str, callable] | None = None,
          classes: dict[str, callable] | None = None) -> dict:
    """A frame as the template's table: `links` column -> value -> href, `classes` column ->
    value -> CSS class; a filter box once it is FILTER_FROM rows long."""
    links, classes = links or {}, classes or {}
    rows = [[_cell(v, links[c](v) if c in links else "", classes[c](v) if c in classes else "")
             for c, v in zip(df.columns, values)] for values in df.itertuples(index=False)]
    return {"id": name, "columns": [str(c) for c in df.columns], "rows": rows, "filter": len(rows) >= FILTER_FROM}


def _status_class(text) -> str:
    words = str(text).split()
    return f"s-{words[-1]}" if words and words[-1] in STATUS_MARK.values() else ""


def scorecard_table(card: pd.DataFrame, engine_href) -> dict:
    """Engines as rows, effects (and the other commands' readings) as columns; each cell
    its grade (coloured) and the text of report.md's cell."""
    if card.empty:  # a run with no rows (every job left out, e.g. on demand): no grades
        return {"id": "scorecard", "columns": ["engine"], "rows": [], "filter": False}
    card = card.assign(cell=[scorecard.cell(r, bold=False) for r in card.itertuples()])
    shown = [e for e in scorecard.columns() if (card[card.effect == e].cell != "-").any()]
    rows = []
    for engine, mine in card.groupby("engine", sort=False):
        by = {r.effect: r for r in mine.itertuples()}
        line = [_cell(engine, engine_href(engine))]
        for e in shown:
            r = by[e]
            line.append({"text": r.cell, "href": "", "cls": f"g-{r.grade}" if r.grade not in ("-", "") else ""})
        rows.append(line)
    return {"id": "scorecard", "columns": ["engine"] + shown, "rows": rows, "filter": False}


def parity_block(pairs: list, plot: str) -> dict | None:
    """The index's "Implementation parity": the pairs' table (each linking its parity.md), the
    plot and each pair's findings (physval.readings.parity)."""
    if not pairs:
        return None
    from physval.readings import parity
    found = []
    for p in pairs:
        text, causes = parity.findings(p.table, p.parts)
        found.append({"title": f"{p.b} against {p.a}", "text": text, "causes": causes})
    return {"legend": parity.LEGEND.replace("`", ""), "plot": plot, "pairs": found,
            "table": table("parity", parity.overview(pairs), links={"details": lambda d: d})}


def problems(df: pd.DataFrame) -> pd.DataFrame:
    bad = df[df.status.isin(["fail", "unstable", "error"])]
    return pd.DataFrame({"status": bad.status, "engine": bad.engine, "family": bad.case, "variant": bad.variant,
                         "metric": bad.metric, "expected": bad.expected, "measured": bad.measured,
                         "reason": bad.reason})


def _pages_in(folder: Path, keep: set[str]) -> None:
    """Remove pages of `folder` a former run wrote that this one does not (nothing links them)."""
    for old in folder.glob("*.html") if folder.is_dir() else ():
        if old.name not in keep:
            old.unlink()


def write(out: Path, df: pd.DataFrame, families: dict, command: str = "", interrupted: str = "",
          beside: scorecard.Companions | None = None) -> Path:
    """report.html in `out` and its pages in out/html/; returns report.html's path.
    `interrupted`: what an interrupted run is missing, said on every page (its plots, drawn
    when the run completes, are not shown: those in the folder may be an earlier run's)."""
    out = Path(out)
    env = _env()
    env.globals["interrupted"] = interrupted
    engines = list(dict.fromkeys(df.engine))
    names = sorted(df.case.unique())

    def plot(name: str, root: str) -> str:
        """The link to plots/<name>.png from a page at `root`, if the run drew it."""
        return f"{root}plots/{name}.png" if not interrupted and (out / "plots" / f"{name}.png").is_file() else ""

    def engine_href(root):
        return lambda e: f"{root}{SITE}/engines/{slug(e)}.html"

    def family_href(root):
        return lambda f: f"{root}{SITE}/families/{slug(f)}.html"

    card = scorecard.measure(df, beside)
    runs = df.groupby(["case", "variant", "engine"]).ngroups if len(df) else 0
    counts = f"{len(df)} checks from {runs} runs: {status_counts(df)}."

    summaries = []
    for title, group in engine_groups(df):
        name = "summary" if title == "Engines" else "summary_formulations"
        matrix = summary_matrix(df[df.engine.isin(group)], group)
        summaries.append({"title": title, "plot": plot(name, ""),
                          "table": table(name, matrix, links={"family": family_href("")},
                                         classes={e: _status_class for e in group})})
    index = pd.DataFrame([{"family": n, "what it checks": getattr(families.get(n), "summary", ""),
                           "checks": int((df.case == n).sum()), "statuses": status_counts(df[df.case == n])}
                          for n in names])
    versions, devs = engine_versions(df), df[df.status == "deviation"]
    per_engine = pd.DataFrame([{"engine": e, "version": versions.get(e, ""), "checks": int((df.engine == e).sum()),
                                "statuses": status_counts(df[df.engine == e]),
                                "deviation causes": devs[devs.engine == e].known_deviation.nunique(),
                                "worst deviation (tol)": devs[devs.engine == e].over_tol.max()}
                               for e in engines])
    pages = {out / "report.html": env.get_template("index.html").render(
        title="physval report", root="", command=command, intro=INTRO, counts=counts,
        scorecard_legend=scorecard.legend(beside).replace("**", ""), summary_legend=SUMMARY_LEGEND,
        scorecard=scorecard_table(card, engine_href("")), summaries=summaries,
        families=table("families", index, links={"family": family_href("")}),
        engines=table("engines", per_engine, links={"engine": engine_href("")}),
        problems=table("problems", problems(df), links={"family": family_href(""), "engine": engine_href("")}),
        parity=parity_block(beside.parity if beside else [], plot("parity", "")),
        environment=table("environment", environment(engine_versions(df))))}

    root = "../../"
    for name in names:
        fam, mine = families.get(name), df[df.case == name]
        summary = getattr(fam, "summary", "")
        measured = family_table(df, name)
        pages[out / SITE / "families" / f"{slug(name)}.html"] = env.get_template("family.html").render(
            title=name, root=root, summary=summary[:1].upper() + summary[1:] + "." if summary else "",
            source=getattr(fam, "source", ""), effects=mine.iloc[0].effects or "none", counts=status_counts(mine),
            tolerances=table("tolerances", tolerance_reasons(df, name)),
            plot=plot(name, root),
            measured=table("measured", measured, classes={e: _status_class for e in engines}))

    for engine in engines:
        mine = df[df.engine == engine]
        knobbed = mine[mine.knobs != ""]
        first = knobbed.iloc[0] if len(knobbed) else None
        devs = deviation_table(mine).drop(columns="engine")
        causes = deviation_summary(mine)
        causes = causes.drop(columns="engine") if len(causes) else causes
        unsupported = mine[mine.status == "unsupported"].drop_duplicates(["case", "reason"])
        pages[out / SITE / "engines" / f"{slug(engine)}.html"] = env.get_template("engine.html").render(
            title=engine, root=root, version=mine.iloc[0].engine_version, counts=status_counts(mine),
            scorecard=scorecard_table(card[card.engine == engine], engine_href(root)),
            causes=table("causes", causes), deviations=table("deviations", devs),
            problems=table("problems", problems(mine).drop(columns="engine"), links={"family": family_href(root)}),
            unsupported=table("unsupported", pd.DataFrame({"family": unsupported.case, "reason": unsupported.reason}),
                              links={"family": family_href(root)}),
            knobs=json.dumps(json.loads(first.knobs), indent=1, sort_keys=True) if first is not None else "",
            knob_case=f"{first.case}[{first.variant}]" if first is not None else "",
            knob_effects=first.effects_simulated if first is not None else "")

    _pages_in(out / SITE / "families", {p.name for p in pages if p.parent.name == "families"})
    _pages_in(out / SITE / "engines", {p.name for p in pages if p.parent.name == "engines"})
    for path, text in pages.items():
        write_atomic(path, text)
    return out / "report.html"


def rebuild(folder: Path) -> Path:
    """report.html of a result folder, from its results.csv (and the built-in families)."""
    from cases.registry import builtin_families
    from physval.core import COLUMNS
    from physval.core.store import read_results
    return write(folder, frame(read_results(folder), COLUMNS), builtin_families())


if __name__ == "__main__":
    folder = Path(sys.argv[1] if len(sys.argv) > 1 else "reports")
    try:
        found = (folder / "results.csv").is_file()
    except OSError as exc:
        found, why = False, f"cannot be read ({exc.strerror})"
    else:
        why = "no such folder" if not folder.is_dir() else "no results.csv in this folder (a `physval run --out` folder holds one)"
    if not found:
        print(f"python -m physval.readings.site: error: {folder}: {why}", file=sys.stderr)
        sys.exit(2)
    print(f"wrote {rebuild(folder)}")
