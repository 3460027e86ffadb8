"""The report of `physval run` (report.md and plots/) and the sections it is built from:
the summary (engines, then the reference formulations), known deviations with their recorded bands beside today's measurement,
failures, unsupported runs, one section per family (what it checks, where its closed form
comes from, every tolerance with its reason, a plot and a table of measured values),
the engine settings and the stepping cost. results.csv is the row store itself
(physval.core.store), finalised in job order.
"""
from __future__ import annotations

import json
import math
import re
from pathlib import Path

import numpy as np
import pandas as pd

from physval.core import COLUMNS
from physval.core.verdicts import VANISHED
from physval.reportkit import (STATUS_MARK, anchor, contents, deviation_summary, deviation_table, engine_versions, environment,
                               per_engine_counts,
                               fmt, frame, heading, md_table, problems_section, pyplot, save_figure, status_counts,
                               summary_matrix, unsupported_section, write_atomic)

FORMULATION_PREFIX = "reference-"  # the reference's other formulations, summarised apart from the engines


def engine_groups(df: pd.DataFrame) -> list[tuple[str, list[str]]]:
    engines = list(dict.fromkeys(df.engine))
    plain = [e for e in engines if not e.startswith(FORMULATION_PREFIX)]
    forms = [e for e in engines if e.startswith(FORMULATION_PREFIX)]
    return [(t, g) for t, g in (("Engines", plain), ("Reference formulations", forms)) if g]


def plot_summary(df: pd.DataFrame, engines: list[str], path: Path, title: str) -> None:
    """Heat map of the worst error/tolerance per family and engine (log colour scale)."""
    plt = pyplot()
    fams = sorted(df[df.engine.isin(engines)].case.unique())
    worst = np.full((len(fams), len(engines)), np.nan)
    for i, f in enumerate(fams):
        for j, e in enumerate(engines):
            vals = df[(df.case == f) & (df.engine == e)].over_tol.dropna()
            if len(vals):
                worst[i, j] = max(vals.max(), 1e-6)
    fig, ax = plt.subplots(figsize=(1.3 * len(engines) + 3.4, 0.42 * len(fams) + 1.8), layout="constrained")
    im = ax.imshow(np.log10(np.clip(worst, 1e-3, 1e3)), cmap="RdYlGn_r", vmin=-3, vmax=3, aspect="auto")
    ax.set_xticks(range(len(engines)), engines, rotation=30, ha="right")
    ax.set_yticks(range(len(fams)), fams, fontsize=8)
    for i in range(len(fams)):
        for j in range(len(engines)):
            text = "n/a" if np.isnan(worst[i, j]) else f"{worst[i, j]:.2g}"
            ax.text(j, i, text, ha="center", va="center", fontsize=7)
    fig.colorbar(im, ax=ax, label="log10(worst error / tolerance)")
    ax.set_title(f"{title}: worst error in tolerances (<1: within tolerance)", fontsize=10)
    save_figure(fig, path)


LABEL_EVERY_CELL_UP_TO = 300  # cells; a larger grid labels only the cells that are neither pass nor n/a,
LABELS_AT_MOST = 200          # the worst this many of them (each label costs ~2 ms to lay out and draw)


def plot_family(df: pd.DataFrame, family: str, path: Path) -> None:
    """One row per check (variant: metric), one column per engine, coloured by the error in
    tolerances, each cell labelled with that number and the status. On a grid of more
    than LABEL_EVERY_CELL_UP_TO cells the passes and n/a cells go unlabelled (colour and
    blank say it; the family's table has the numbers), and at most LABELS_AT_MOST of them,
    the worst: drawing the text is most of the plot's time (3 of 5 s for 110 checks on 24
    engines, measured)."""
    plt = pyplot()
    sub = df[df.case == family]
    engines = list(dict.fromkeys(sub.engine))
    checks = list(dict.fromkeys(zip(sub.variant, sub.metric)))
    grid = np.full((len(checks), len(engines)), np.nan)
    label = [[""] * len(engines) for _ in checks]
    index = {c: i for i, c in enumerate(checks)}
    for r in sub.itertuples():
        i, j = index[(r.variant, r.metric)], engines.index(r.engine)
        if math.isfinite(r.over_tol):
            grid[i, j] = max(r.over_tol, 1e-6)
        elif r.status in ("fail", "deviation"):
            grid[i, j] = 1e3
        mark = STATUS_MARK[r.status]
        label[i][j] = f"{r.over_tol:.2g} {mark}" if math.isfinite(r.over_tol) else mark
    fig, ax = plt.subplots(figsize=(1.25 * len(engines) + 4.5, 0.24 * len(checks) + 1.6), layout="constrained")
    ax.imshow(np.log10(np.clip(grid, 1e-3, 1e3)), cmap="RdYlGn_r", vmin=-3, vmax=3, aspect="auto",
              interpolation="nearest")
    ax.set_xticks(range(len(engines)), engines, rotation=30, ha="right", fontsize=8)
    ax.set_yticks(range(len(checks)), [f"[{v}] {m}" for v, m in checks], fontsize=7)
    every = len(checks) * len(engines) <= LABEL_EVERY_CELL_UP_TO
    cells = [(index[(r.variant, r.metric)], engines.index(r.engine)) for r in sub.itertuples()
             if every or r.status not in ("pass", "unsupported")]
    capped = len(cells) > LABELS_AT_MOST
    if capped:  # the worst first, n/a cells last
        cells = sorted(cells, key=lambda c: -np.nan_to_num(grid[c], nan=-np.inf))[:LABELS_AT_MOST]
    for i, j in cells:
        ax.text(j, i, label[i][j], ha="center", va="center", fontsize=6)
    shown = ")" if every else "; pass and n/a cells unlabelled)"
    if capped:
        shown = f"; only the {LABELS_AT_MOST} worst cells labelled)"
    ax.set_title(f"{family}: error / tolerance per check (green < 1 <= red; pass, dev = known deviation, FAIL"
                 + shown, fontsize=9)
    save_figure(fig, path)


def family_table(df: pd.DataFrame, family: str) -> pd.DataFrame:
    sub = df[df.case == family]
    engines = list(dict.fromkeys(df.engine))
    lines: dict[tuple, dict] = {}
    for r in sub.itertuples():
        line = lines.get((r.variant, r.metric))
        if line is None:
            line = lines[(r.variant, r.metric)] = {
                "variant": r.variant, "metric": f"{r.metric} [{r.unit}]", "expected": fmt(r.expected),
                "tolerance": f"{fmt(r.tolerance)} {r.tolerance_kind}"}
        if r.engine not in line:
            shown = fmt(r.measured) if r.status in ("pass", "fail", "deviation") else ""
            line[r.engine] = f"{shown} {STATUS_MARK[r.status]}".strip()
    out = pd.DataFrame(list(lines.values()))
    return out[["variant", "metric", "expected", "tolerance"] + [e for e in engines if e in out.columns]] \
        if len(out) else out


def tolerance_reasons(df: pd.DataFrame, family: str) -> pd.DataFrame:
    """Each check's tolerance reason once (the size varies by variant, the reason is the same)."""
    sub = df[df.case == family].drop_duplicates(["metric", "tolerance_reason"])
    return pd.DataFrame({"metric": sub.metric, "tolerance": sub.tolerance_kind, "why this size": sub.tolerance_reason})


def summary_sections(df: pd.DataFrame, plots: Path, drawings: list | None = None) -> list[str]:
    """The summary tables; their heat maps drawn, or added to `drawings` (see draw)."""
    lines = ["## Summary", "",
             "Each cell: status counts and the worst error in units of tolerance (below 1: within tolerance). "
             "Statuses: **pass** within the tolerance; **FAIL** outside it, or a known deviation whose measured "
             "size left its recorded band; **dev** a known engine shortfall within its recorded band; **n/a** "
             "the engine cannot represent the scene; **UNSTABLE** the engine's state blew up; **ERROR** an "
             "exception, named in `results.csv`.", ""]
    several = df.case.nunique() > 1  # one family: its own section's heat map says it all
    for title, engines in engine_groups(df):
        slug = "summary" if title == "Engines" else "summary_formulations"
        lines += [f"### {title}", "", md_table(summary_matrix(df[df.engine.isin(engines)], engines)), ""]
        if several:
            _draw_or_add(drawings, plot_summary, (df[df.engine.isin(engines)], engines, plots / f"{slug}.png", title))
            lines += [f"![{title}](plots/{slug}.png)", ""]
    return lines


VANISHED_TITLE = "Known deviations that vanished"
_VANISHED_ENTRY = re.compile(rf"^{VANISHED}: (?P<entry>.*?) records ")


def vanished_rows(df: pd.DataFrame) -> pd.DataFrame:
    """The checks a known-deviation band records that now meet their closed form."""
    return df[(df.status == "pass") & df.reason.astype(str).str.startswith(VANISHED)]


def vanished_section(df: pd.DataFrame) -> list[str]:
    """The report's listing of known deviations that vanished (none: no section): the
    engine or its mapping changed, and the band, which no longer records anything the
    engine does, has to go."""
    gone = vanished_rows(df)
    if not len(gone):
        return []
    entry = gone.reason.map(lambda r: m["entry"] if (m := _VANISHED_ENTRY.match(r)) else "")
    return [f"## {VANISHED_TITLE}", "",
            f"Checks a known-deviation band records that now meet their closed form ({len(gone)}): the engine or "
            "its mapping changed. They pass; `physval known ENGINE --write` measures the engine's bands again (the "
            "entry goes or narrows), `physval run --fail-on vanished` makes a run exit 1 on them.", "",
            md_table(pd.DataFrame({
                "engine": gone.engine, "check": gone.case + "[" + gone.variant + "]:" + gone.metric,
                "expected": gone.expected.map(fmt), "measured": gone.measured.map(fmt),
                "recorded band": gone.band, "entry": entry})), ""]


def deviation_sections(df: pd.DataFrame, stale: list[str]) -> tuple[list[str], list[str]]:
    """(the report's section: counts per engine and cause, entries gone stale; the page
    deviations.md: every known deviation, band against measurement)."""
    intro = ("Each engine's known shortfalls (`adapters/xfails/<engine>.txt`, a plug-in's own file, or a "
             "`--known` file): one row per engine and cause. A measurement outside its band is a `FAIL` (the "
             "deviation changed); `physval known ENGINE` measures the bands again.")
    lines = ["## Known deviations", "", intro, ""]
    page = ["# Known deviations", "", intro, ""]
    if (df.status == "deviation").any():
        lines += [md_table(per_engine_counts(df, "deviation")), "",
                  "Each engine's causes, and every known deviation with the band its size was recorded in beside "
                  "the value measured now: [deviations.md](deviations.md).", ""]
        page += ["## Per engine and cause", "", md_table(deviation_summary(df)), "",
                 "## Every known deviation", "", md_table(deviation_table(df)), ""]
    else:
        lines += ["_(none in this run)_", ""]
    if stale:
        lines += ["Entries that no longer deviate or match nothing:", ""] + [f"- {s}" for s in stale] + [""]
    return lines, page


def family_sections(df: pd.DataFrame, families: dict, plots: Path,
                    drawings: list | None = None) -> tuple[list[str], dict[str, str]]:
    """(the report's index of families, one line each; {family: its page families/<name>.md}):
    what it checks, where its closed form comes from, every tolerance with its reason, the
    heat map (drawn, or added to `drawings`: see draw) and the measured values."""
    lines = ["## Families", "", "One page per family: what it checks, where its closed form comes from, every "
             "tolerance with its reason, a heat map of every check per engine, and the measured values.", ""]
    index, pages = [], {}
    for name in sorted(df.case.unique()):
        fam = families.get(name)
        mine = df[df.case == name]
        _draw_or_add(drawings, plot_family, (mine, name, plots / f"{name}.png"))
        page = [f"# {name}", "", "[back to the report](../report.md)", ""]
        if fam is not None:
            page += [f"{fam.summary[:1].upper() + fam.summary[1:]}." if fam.summary else "", "",
                     f"Closed form: {fam.source}." if fam.source else "", ""]
        page += [f"Effects simulated: {mine.iloc[0].effects or 'none'}.", "", "Tolerances:", "",
                 md_table(tolerance_reasons(df, name)), "", f"![{name}](../plots/{name}.png)", "",
                 "Measured values:", "", md_table(family_table(df, name)), ""]
        pages[name] = "\n".join(page)
        index.append({"family": f"[{name}](families/{name}.md)", "what it checks": fam.summary if fam else "",
                      "checks": len(mine), "statuses": status_counts(mine)})
    return lines + [md_table(pd.DataFrame(index)), ""], pages


def unsupported_counts(df: pd.DataFrame) -> list[str]:
    """The report's section on runs an engine cannot represent: counts per engine; the
    reasons are on unsupported.md."""
    if not (df.status == "unsupported").any():
        return []
    return ["## Unsupported", "", "Checks each engine cannot represent (a 3D scene in a 2D engine, `mu_s != mu_k` "
            "in an engine with one friction coefficient, ...); every reason: [unsupported.md](unsupported.md).", "",
            md_table(per_engine_counts(df, "unsupported")), ""]


def settings_section(df: pd.DataFrame) -> tuple[list[str], list[str]]:
    """(the report's pointer; the page knobs.md: the knobs each adapter set)."""
    intro = ("The knobs each adapter set (engine's own names), from one run per engine; every run's "
             "record is in `knobs.json` (each engine's distinct records once), named by the `knobs` column of "
             "`results.csv`.")
    page = ["# Engine settings", "", intro, ""]
    for eng, grp in df[df.knobs != ""].groupby("engine", sort=False):
        page += [f"## {eng}", "", f"Effects simulated in that run: {grp.iloc[0].effects_simulated}.", "", "```",
                 json.dumps(json.loads(grp.iloc[0].knobs), indent=1, sort_keys=True), "```", ""]
    return ["## Engine settings", "", intro + " Every engine's: [knobs.md](knobs.md).", ""], page


# --- drawing the plots ----------------------------------------------------------------------

def _draw_or_add(drawings: list | None, fn, args: tuple) -> None:
    if drawings is None:
        fn(*args)
    else:
        drawings.append((fn, args))


def drawn(drawing: tuple) -> None:
    """Draw one plot: (function, arguments); a module-level function, so a worker process
    can draw it (physval.core.session.map_calls)."""
    fn, args = drawing
    fn(*args)


def draw_here(drawings: list) -> None:
    """Draw the plots one after the other in this process."""
    for d in drawings:
        drawn(d)


# --- the report --------------------------------------------------------------------------

INTRO = ("physval runs analytic cases (closed-form answers with tolerances, each with its reason) on physics "
         "engines and judges every check. Read the scorecard first; each family's page (linked under Families) says "
         "what it checks and why its tolerances have their size.")


def write_run_report(rows: list[dict], out: Path, families: dict, command: str = "", complete: bool = True,
                     planned: int | None = None, engine_wide: dict | None = None, stale: list[str] = (),
                     phases=None, draw=draw_here) -> None:
    """report.md and plots/ for the rows of a run; `complete` False: an interrupted run's
    report (marked so, without plots). `stale`: notes on known-deviation entries.
    `phases`: the run's time as physval run measured it (physval.readings.cost.Phases),
    for the Cost section. `draw(drawings)`: draws the summary and family heat maps, a list
    of (function, arguments) (physval run draws them on its workers, side by side)."""
    out = Path(out)
    df = frame(rows, COLUMNS)
    runs = df.groupby(["case", "variant", "engine"]).ngroups if len(df) else 0
    head = heading("physval report", command,
                   "" if complete else f"the run was interrupted after {runs} of {planned} runs. Finished runs are "
                                        "kept and not recomputed; plots are drawn when it completes.")
    head += [INTRO, "", f"{len(df)} checks from {runs} runs: {status_counts(df)}.", ""]
    from physval.readings import site
    if n_vanished := len(vanished_rows(df)):
        head += [f"**Known deviations that vanished: {n_vanished}** (their checks now pass: the engine or its "
                 f"mapping changed): [{VANISHED_TITLE.lower()}](#{anchor(VANISHED_TITLE)}).", ""]
    if not complete:
        body = [md_table(summary_matrix(df)), ""] if len(df) else []
        body += vanished_section(df) + problems_section(df)
        write_atomic(out / "report.md", "\n".join(head + body))
        if len(df):
            site.write(out, df, families, command, interrupted=f"the run was interrupted after {runs} of {planned} "
                                                              "runs; finished runs are kept and not recomputed.")
        return
    plots = out / "plots"
    deviations, deviation_page = deviation_sections(df, list(stale))
    from physval.readings import scorecard
    beside = engine_wide.get("beside") if engine_wide else None  # the sweep, stress and real readings found beside
    drawings: list = []
    sections = [scorecard.section(scorecard.measure(df, beside), beside), "\n".join(vanished_section(df)),
                "\n".join(summary_sections(df, plots, drawings)),
                "\n".join(deviations),
                "\n".join(problems_section(df)),
                "\n".join(unsupported_counts(df))]
    from physval.readings import agreement, effective, laws
    engine_wide = engine_wide or {}
    if "effective" in engine_wide:
        sections.append(effective.section(engine_wide["effective"], out))
    agree = agreement.measure(df, {n for n, f in families.items() if f.cross_engine})
    if len(agree):
        sections.append(agreement.section(agree, out))
    if beside is not None and beside.parity:
        from physval.readings import parity
        sections.append(parity.section(beside.parity, out))
    if "laws" in engine_wide:
        sections.append(laws.section(engine_wide["laws"], out))
    family_index, family_pages = family_sections(df, families, plots, drawings)
    draw(drawings)
    settings, knobs_page = settings_section(df)
    cost_at = len(sections) + 2
    sections += ["\n".join(family_index), "\n".join(settings), "",
                 "\n".join(["## Environment", "", md_table(environment(engine_versions(df))), ""])]
    write_pages(out, {"deviations.md": "\n".join(deviation_page), "knobs.md": "\n".join(knobs_page),
                      "unsupported.md": "\n".join(["# Unsupported runs", ""] + unsupported_section(df)[2:])},
                {f"{name}.md": text for name, text in family_pages.items()})
    from physval.readings import cost
    sections[cost_at] = cost.section(cost.measure(rows, phases), out)  # last: its report time covers the rest
    sections = [s for s in sections if s.strip()]
    write_atomic(out / "report.md", "\n".join(head + [contents(sections)] + sections))
    site.write(out, df, families, command, beside=beside)


def write_pages(out: Path, pages: dict[str, str], family_pages: dict[str, str]) -> None:
    """The report's detail pages beside report.md, and families/<name>.md for this run's
    families (pages of families this run did not hold are removed: the index links none)."""
    for name, text in pages.items():
        write_atomic(out / name, text)
    folder = out / "families"
    for old in folder.glob("*.md") if folder.is_dir() else ():
        if old.name not in family_pages:
            old.unlink()
    for name, text in family_pages.items():
        write_atomic(folder / name, text)
