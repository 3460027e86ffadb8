"""The report of `physval run`: report.md and report.html (with plots/ and the pages beside
them) from the rows of a run, built from one declared list of sections (`SECTIONS`; an
interrupted run's: `INTERRUPTED`), each one object of the report kit (physval.report) that
reads the run once and renders to markdown and HTML: the scorecard and the engine closest to
physics per effect, the summary (engines, then the reference formulations), known
deviations with their recorded bands beside today's measurement, failures, unsupported
runs, the engine-wide readings, one page per family (what it checks, where its closed form
comes from, every tolerance with its reason, a plot and a table of measured values), the
engine settings, where the run's time went (physval.readings.cost) and the environment.
The heat maps (most of the report's time) are drawn while the sections render: in
processes of their own when the caller gives `draw_beside` (physval run does), else here
before them. results.csv is the row store itself
(physval.core.store), finalised in job order.

`python3 -m physval.readings.results FOLDER` rebuilds a folder's report from its results.csv
and the readings beside it, without running an engine.
"""
from __future__ import annotations

import json
import re
import sys
from dataclasses import dataclass, field
from functools import cached_property
from pathlib import Path

import pandas as pd

from physval.core import COLUMNS
from physval.core.verdicts import VANISHED
from physval.readings import (agreement, closest, cost, effective, invariance, laws, narrow_phase, parity, scorecard,
                              site)
from physval.readings.checks import (deviation_summary, deviation_table, engine_groups, engine_versions, family_table,
                                     frame, per_engine_counts, problems_section, status_class, status_counts,
                                     summary_matrix, tolerance_reasons, unsupported_section)
from physval.readings.heatmaps import plot_family, plot_summary
from physval.report import Html, Report, Section, anchor, environment, fmt, md_table, table, write_atomic

INTRO = ("physval runs analytic cases (closed-form answers with tolerances, each with its reason) on physics "
         "engines and judges every check. Read the scorecard first; each family's page (linked under Families) says "
         "what it checks and why its tolerances have their size.")


@dataclass
class Run:
    """What a run's report reads: its rows (`df`, the frame of physval.readings.checks), its
    folder, its families, the engine-wide readings it measured (`engine_wide`: effective,
    laws), the readings of other commands found beside it, the notes on known-deviation
    entries gone stale and on engines whose bands were measured on another release (`releases`:
    physval.core.deviations.release_notes), and whether it completed (an interrupted run draws no plots); for
    the Cost section, its rows as stored (`rows`: with their job keys) and its phases as
    physval run measured them (`phases`, physval.readings.cost.Phases; None: rebuilt)."""
    df: pd.DataFrame
    out: Path
    families: dict
    engine_wide: dict = field(default_factory=dict)
    beside: scorecard.Companions = field(default_factory=scorecard.Companions)
    stale: list[str] = field(default_factory=list)
    complete: bool = True
    rows: list = field(default_factory=list)
    phases: cost.Phases | None = None
    releases: dict[str, str] = field(default_factory=dict)  # engine -> "bands measured on ..., this run ..."

    @property
    def plots(self) -> Path | None:
        return self.out / "plots" if self.complete else None

    @cached_property
    def card(self) -> pd.DataFrame:
        return scorecard.measure(self.df, self.beside)

    @cached_property
    def runs(self) -> int:
        return self.df.groupby(["case", "variant", "engine"]).ngroups if len(self.df) else 0

    def engine_page(self, engine: str) -> str:
        """The link from report.html to an engine's page (the scorecard's engine names)."""
        return site.engine_page(engine)


def html_link(href: str) -> str:
    """A link of the report's markdown as the HTML pages link it: a family's page there."""
    m = re.fullmatch(r"families/(?P<name>[^/]+)\.md", href)
    return site.family_page(m["name"]) if m else href


SUMMARY_LEGEND = (
    "Each cell: status counts and the worst error in units of tolerance (below 1: within tolerance). "
    "Statuses: **pass** within the tolerance; **FAIL** outside it, or a known deviation whose measured "
    "size left its recorded band; **dev** a known engine shortfall within its recorded band; **n/a** "
    "the engine cannot represent the scene; **UNSTABLE** the engine's state blew up; **ERROR** an "
    "exception, named in `results.csv`.")


@dataclass
class Group:
    """One table of the summary: its title, engines, file name and family x engine matrix,
    and the run's rows and plots folder (None: no heat map)."""
    title: str
    engines: list[str]
    slug: str
    matrix: pd.DataFrame
    df: pd.DataFrame
    plots: Path | None


class Summary(Section):
    """Family x engine status counts and worst errors: the engines, then the reference
    formulations, each with its heat map (one family: its own page's heat map says it all)."""

    def measure(self, run: Run) -> list[Group]:
        several = run.df.case.nunique() > 1
        return [Group(title, engines, "summary" if title == "Engines" else "summary_formulations",
                      summary_matrix(run.df[run.df.engine.isin(engines)], engines), run.df,
                      run.plots if several else None)
                for title, engines in engine_groups(run.df)]

    def markdown(self, groups: list[Group]) -> str:
        lines = ["## Summary", "", SUMMARY_LEGEND, ""]
        for g in groups:
            lines += [f"### {g.title}", "", md_table(g.matrix), ""]
            if g.plots is not None:  # drawn before (heat_maps)
                lines += [f"![{g.title}](plots/{g.slug}.png)", ""]
        return "\n".join(lines)

    def html(self, groups: list[Group], html: Html) -> str:
        parts = [html.markdown("\n".join(["## Summary", "", SUMMARY_LEGEND]), "summary")]
        for g in groups:
            parts += [html.markdown(f"### {g.title}", "summary"),
                      html.table(table(g.slug, g.matrix, links={"family": site.family_page},
                                       classes={e: status_class for e in g.engines}))]
            if g.plots is not None:
                parts.append(f'<img class="plot" src="plots/{g.slug}.png" alt="{g.title}: worst error in tolerances">')
        return "\n".join(parts)


class SummaryTable(Section):
    """An interrupted run's summary: the matrix of every engine, without heading or plot."""

    def measure(self, run: Run) -> pd.DataFrame:
        return summary_matrix(run.df) if len(run.df) else None

    def markdown(self, matrix: pd.DataFrame) -> str:
        return "\n".join([md_table(matrix), ""])

    def html(self, matrix: pd.DataFrame, html: Html) -> str:
        return html.table(table("summary", matrix, links={"family": site.family_page}))


VANISHED_TITLE = "Known deviations that vanished"
_VANISHED_ENTRY = re.compile(rf"^{VANISHED}: (?P<entry>.*?) records ")


def vanished_rows(df: pd.DataFrame) -> pd.DataFrame:
    """The checks a known-deviation band records that now meet their closed form (a fail
    where the measurement left the band, core.verdicts.judge)."""
    return df[df.status.isin(("pass", "fail")) & df.reason.astype(str).str.startswith(VANISHED)]


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
            "its mapping changed. Each is a fail where the measurement left its band (a change shows as a fail, "
            "whichever way it moved); `physval known ENGINE --write` measures the engine's bands again (the entry "
            "goes or narrows), `physval run --fail-on vanished` makes a run exit 1 on them.", "",
            md_table(pd.DataFrame({
                "engine": gone.engine, "check": gone.case + "[" + gone.variant + "]:" + gone.metric,
                "expected": gone.expected.map(fmt), "measured": gone.measured.map(fmt),
                "recorded band": gone.band, "entry": entry})), ""]


class Vanished(Section):
    def measure(self, run: Run) -> pd.DataFrame:
        return run.df

    def markdown(self, df: pd.DataFrame) -> str:
        return "\n".join(vanished_section(df))


def release_notice(releases: dict[str, str]) -> list[str]:
    """One line under the opening count if some engine ran another release than its bands were
    measured on (the Known deviations section lists them)."""
    if not releases:
        return []
    return [f"Known deviations measured on another release than this run's: "
            + "; ".join(f"{e} ({note})" for e, note in releases.items()) + ".", ""]


def vanished_notice(df: pd.DataFrame) -> list[str]:
    """The report's opening line on known deviations that vanished (none: no line)."""
    if not (n := len(vanished_rows(df))):
        return []
    return [f"**Known deviations that vanished: {n}** (their checks are back within tolerance: the engine or its "
            f"mapping changed): [{VANISHED_TITLE.lower()}](#{anchor(VANISHED_TITLE)}).", ""]


DEVIATIONS_INTRO = (
    "Each engine's known shortfalls (`adapters/xfails/<engine>.txt`, a plug-in's own file, or a "
    "`--known` file): one row per engine and cause. A measurement outside its band is a `FAIL` (the "
    "deviation changed); `physval known ENGINE` measures the bands again.")


class KnownDeviations(Section):
    """Counts per engine and cause, and the entries gone stale; every deviation is on
    deviations.md (`deviations_page`)."""

    def measure(self, run: Run) -> Run:
        return run

    def markdown(self, run: Run) -> str:
        lines = ["## Known deviations", "", DEVIATIONS_INTRO, ""]
        if (run.df.status == "deviation").any():
            lines += [md_table(per_engine_counts(run.df, "deviation")), "",
                      "Each engine's causes, and every known deviation with the band its size was recorded in "
                      "beside the value measured now: [deviations.md](deviations.md).", ""]
        else:
            lines += ["_(none in this run)_", ""]
        if run.releases:
            lines += release_lines(run.releases)
        if run.stale:
            lines += ["Entries that no longer deviate or match nothing:", ""] + [f"- {s}" for s in run.stale] + [""]
        return "\n".join(lines)


def release_lines(releases: dict[str, str]) -> list[str]:
    """The engines whose known deviations were measured on another release than the one that
    ran: a `fail` of theirs may be the release's (physval.core.deviations.release_notes)."""
    return (["Engines that ran another release than their known deviations were measured on (their bands "
             "still judge them: a `FAIL` of a recorded deviation may be the release's; `physval known ENGINE "
             "--write` measures the bands on this one):", ""]
            + [f"- {engine}: {note}" for engine, note in releases.items()] + [""])


def deviations_page(df: pd.DataFrame) -> str:
    page = ["# Known deviations", "", DEVIATIONS_INTRO, ""]
    if (df.status == "deviation").any():
        page += ["## Per engine and cause", "", md_table(deviation_summary(df)), "",
                 "## Every known deviation", "", md_table(deviation_table(df)), ""]
    return "\n".join(page)


class Problems(Section):
    def measure(self, run: Run) -> pd.DataFrame:
        return run.df

    def markdown(self, df: pd.DataFrame) -> str:
        return "\n".join(problems_section(df))


class Unsupported(Section):
    """The runs an engine cannot represent: counts per engine; the reasons are on unsupported.md."""

    def measure(self, run: Run) -> pd.DataFrame:
        return run.df[run.df.status == "unsupported"]

    def markdown(self, df: pd.DataFrame) -> str:
        return "\n".join([
            "## Unsupported", "", "Checks each engine cannot represent (a 3D scene in a 2D engine, `mu_s != mu_k` "
            "in an engine with one friction coefficient, ...); every reason: [unsupported.md](unsupported.md).", "",
            md_table(per_engine_counts(df, "unsupported")), ""])


@dataclass
class Written:
    """A reading's rows and the folder its section writes its CSV and plot into."""
    rows: object
    out: Path

    def __len__(self) -> int:
        return len(self.rows)


@dataclass(frozen=True)
class InFolder(Section):
    """A reading whose section writes its rows and plot beside the report:
    `module.section(rows, out)`, the rows being `rows(run)` (None: not read in this run)."""
    module: object
    rows: object

    def measure(self, run: Run) -> Written | None:
        rows = self.rows(run)
        return None if rows is None else Written(rows, run.out)

    def markdown(self, got: Written) -> str:
        return self.module.section(got.rows, got.out)


def cross_engine(run: Run) -> pd.DataFrame:
    return agreement.measure(run.df, {n for n, f in run.families.items() if f.cross_engine})


class Families(Section):
    """The index of families, one line each, linking each family's page (`family_page`)
    (each family's heat map is drawn before: heat_maps)."""

    def measure(self, run: Run) -> Run:
        return run

    def markdown(self, run: Run) -> str:
        df, index = run.df, []
        for name in sorted(df.case.unique()):
            fam, mine = run.families.get(name), df[df.case == name]
            index.append({"family": f"[{name}](families/{name}.md)", "what it checks": fam.summary if fam else "",
                          "checks": len(mine), "statuses": status_counts(mine)})
        return "\n".join(["## Families", "", "One page per family: what it checks, where its closed form comes from, "
                          "every tolerance with its reason, a heat map of every check per engine, and the measured "
                          "values.", "", md_table(pd.DataFrame(index)), ""])


def family_page(df: pd.DataFrame, name: str, fam) -> str:
    """families/<name>.md: what it checks, where its closed form comes from, every tolerance
    with its reason, the heat map and the measured values."""
    mine = df[df.case == name]
    page = [f"# {name}", "", "[back to the report](../report.md)", ""]
    if fam is not None:
        page += [f"{fam.summary[:1].upper() + fam.summary[1:]}." if fam.summary else "", "",
                 f"Closed form: {fam.source}." if fam.source else "", ""]
    page += [f"Effects simulated: {mine.iloc[0].effects or 'none'}.", "", "Tolerances:", "",
             md_table(tolerance_reasons(df, name)), "", f"![{name}](../plots/{name}.png)", "",
             "Measured values:", "", md_table(family_table(df, name)), ""]
    return "\n".join(page)


SETTINGS_INTRO = ("The knobs each adapter set (engine's own names), from one run per engine; every run's "
                  "record is in `knobs.json` (each engine's distinct records once), named by the `knobs` column of "
                  "`results.csv`.")


class Settings(Section):
    def measure(self, run: Run) -> Run:
        return run

    def markdown(self, run: Run) -> str:
        return "\n".join(["## Engine settings", "", SETTINGS_INTRO + " Every engine's: [knobs.md](knobs.md).", ""])


def knobs_page(df: pd.DataFrame) -> str:
    """knobs.md: the knobs each adapter set."""
    page = ["# Engine settings", "", SETTINGS_INTRO, ""]
    for eng, grp in df[df.knobs != ""].groupby("engine", sort=False):
        page += [f"## {eng}", "", f"Effects simulated in that run: {grp.iloc[0].effects_simulated}.", "", "```",
                 json.dumps(json.loads(grp.iloc[0].knobs), indent=1, sort_keys=True), "```", ""]
    return "\n".join(page)


def heat_maps(run: Run) -> list[tuple]:
    """The heat maps the report shows, each (function, arguments) for `drawn`: the summary's
    (Summary's groups) and one per family; none for an interrupted run."""
    if run.plots is None:
        return []
    maps = [(plot_summary, (g.df[g.df.engine.isin(g.engines)], g.engines, g.plots / f"{g.slug}.png", g.title))
            for g in Summary().measure(run) if g.plots is not None]
    return maps + [(plot_family, (run.df[run.df.case == name], name, run.plots / f"{name}.png"))
                   for name in sorted(run.df.case.unique())]


def drawn(drawing: tuple) -> None:
    """Draw one plot: (function, arguments). (Not on the run's workers: a drawing's data
    sent to a worker that was sending its own result back blocked both ends of the pipe,
    and the default run hung after its last job. draw_beside's processes are their own,
    and its pool sends and receives on threads of its own.)"""
    fn, args = drawing
    fn(*args)


def draw_here(drawings: list) -> None:
    """Draw the plots one after the other in this process (returns nothing to wait for)."""
    for d in drawings:
        drawn(d)


def draw_beside(drawings: list, processes: int | None = None):
    """Start drawing the plots in `processes` processes of their own (default: one per CPU
    this process may use) and return a function that waits until they are drawn (and
    raises what a drawing raised). Meanwhile this process renders the report's sections:
    the heat maps were 70 % of the report's time (39 families' and 2 summaries' of the
    default run: 60 of its 88 s), drawn one after the other before the sections."""
    if len(drawings) < 2:
        return draw_here(drawings)
    from concurrent.futures import ProcessPoolExecutor
    import multiprocessing
    import os
    from physval.core.executor import default_start_method, start_fork_server
    method = default_start_method()
    start_fork_server(method)
    if processes is None:
        processes = len(os.sched_getaffinity(0)) if hasattr(os, "sched_getaffinity") else os.cpu_count() or 1
    pool = ProcessPoolExecutor(max_workers=max(1, min(processes, len(drawings))),
                               mp_context=multiprocessing.get_context(method))
    from concurrent.futures.process import BrokenProcessPool
    ordered = sorted(drawings, key=_size, reverse=True)  # the largest first: the last to start is a small one
    futures = [pool.submit(drawn, d) for d in ordered]

    def wait(abandon: bool = False) -> None:
        """`abandon`: the report stopped (an interrupt): drop what is not drawn yet. A
        drawing whose process died (the pool broke: killed, out of memory) is drawn here."""
        if abandon:
            pool.shutdown(wait=False, cancel_futures=True)
            return
        try:
            for d, f in zip(ordered, futures):
                try:
                    f.result()
                except BrokenProcessPool:
                    drawn(d)
        finally:
            pool.shutdown(cancel_futures=True)
    return wait


def _size(drawing: tuple) -> int:
    """A drawing's data in rows (its time grows with it)."""
    return max((len(a) for a in drawing[1] if isinstance(a, pd.DataFrame)), default=0)


class Environment(Section):
    def measure(self, run: Run) -> pd.DataFrame:
        return run.df

    def markdown(self, df: pd.DataFrame) -> str:
        return "\n".join(["## Environment", "", md_table(environment(engine_versions(df))), ""])


# --- the report: its sections in order ----------------------------------------------------

SECTIONS = (
    scorecard.Scorecard(),
    closest.Closest(),
    Vanished(),
    Summary(),
    KnownDeviations(),
    Problems(),
    Unsupported(),
    invariance,
    InFolder(effective, lambda run: run.engine_wide.get("effective")),
    InFolder(agreement, cross_engine),
    InFolder(parity, lambda run: run.beside.parity),
    InFolder(laws, lambda run: run.engine_wide.get("laws")),
    InFolder(narrow_phase, lambda run: narrow_phase.measure(run.df)),
    Families(),
    Settings(),
    InFolder(cost, lambda run: cost.measured(run.rows, run.phases, run.out)),  # last but one: its report time covers the others
    Environment(),
)
INTERRUPTED = (SummaryTable(), Vanished(), Problems())  # an interrupted run's report: what is known so far


def write_run_report(rows: list[dict], out: Path, families: dict, command: str = "", complete: bool = True,
                     planned: int | None = None, engine_wide: dict | None = None, stale: list[str] = (),
                     phases: cost.Phases | None = None, draw=draw_here, releases: dict[str, str] | None = None) -> None:
    """report.md, report.html and their pages for the rows of a run; `complete` False: an
    interrupted run's report (marked so, without plots). `engine_wide`: the engine-wide
    readings measured (effective, laws) and `beside`, the readings of other commands found
    beside the run (physval.readings.scorecard.companions). `stale`: notes on known-deviation
    entries; `releases`: engine -> note, for the engines that ran another release than their
    bands were measured on. `phases`: the run's time as physval run measured it, for the Cost section.
    `draw(drawings)` draws the heat maps, a list of (function, arguments), or starts drawing
    them and returns a function that waits for them (draw_beside: physval run's), called
    once the sections are written."""
    out = Path(out)
    wide = dict(engine_wide or {})
    beside = wide.pop("beside", None) or scorecard.Companions()
    run = Run(frame(rows, COLUMNS), out, families, wide, beside, list(stale), complete, list(rows), phases,
              dict(releases or {}))
    missing = "" if complete else f"the run was interrupted after {run.runs} of {planned} runs"
    report = Report("physval report", SECTIONS if complete else INTERRUPTED, command,
                    interrupted=missing + (". Finished runs are kept and not recomputed; plots are drawn when it "
                                           "completes." if missing else ""),
                    opening=[INTRO, "", f"{len(run.df)} checks from {run.runs} runs: {status_counts(run.df)}.", ""]
                    + vanished_notice(run.df) + release_notice(run.releases), contents=complete)
    html = Html("physval.readings", links=html_link)
    if complete:
        write_pages(out, {"deviations.md": deviations_page(run.df), "knobs.md": knobs_page(run.df),
                          "unsupported.md": "\n".join(["# Unsupported runs", ""] + unsupported_section(run.df)[2:])},
                    {f"{name}.md": family_page(run.df, name, families.get(name)) for name in sorted(run.df.case.unique())})
    maps = heat_maps(run)
    waiting = None
    if maps:
        run.plots.mkdir(parents=True, exist_ok=True)
        waiting = draw(maps)
    try:
        report.write(out, run, html)
        if len(run.df):
            site.write(out, run.df, families, run.card, html, interrupted=f"{missing}; finished runs are kept and "
                       "not recomputed." if missing else "", releases=run.releases)
    except BaseException:
        if waiting is not None:
            waiting(abandon=True)
        raise
    if waiting is not None:
        waiting()


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


def rebuild(folder: Path, command: str | None = None) -> Path:
    """A result folder's report (report.md, report.html, plots/ and pages) from its
    results.csv, the engine-wide readings its last report wrote (effective_parameters.csv,
    laws.csv) and the readings of other commands beside it; the built-in families and the
    known deviations of the installed engines. `command`: the one the report names
    (default: the one the folder's report.md names). No engine runs."""
    from cases.registry import builtin_families
    from physval.core import Context
    from physval.core.deviations import release_notes, stale_entries
    from physval.core.store import read_results
    folder = Path(folder)
    rows = read_results(folder)
    if command is None:
        command = previous_command(folder / "report.md")
    wide = {name: got for name, got in (("effective", effective.read(folder)), ("laws", laws.read(folder)))
            if got is not None}
    wide["beside"] = scorecard.companions(folder)
    df, resolver = frame(rows, COLUMNS), Context().resolver()
    write_run_report(rows, folder, builtin_families(), command=command, engine_wide=wide,
                     stale=stale_entries(df, resolver), releases=release_notes(df, resolver))
    return folder / "report.md"


def previous_command(report: Path) -> str:
    """The command a report names on its `Command:` line ("" if none, or no report)."""
    if report.is_file():
        for line in report.read_text().splitlines()[:6]:
            if m := re.fullmatch(r"Command: `(.*)`", line):
                return m[1]
    return ""


def main(argv: list[str]) -> int:
    folder = Path(argv[0] if argv else "reports")
    try:
        found = (folder / "results.csv").is_file()
    except OSError as exc:
        found, why = False, f"cannot be read ({exc.strerror})"
    else:
        why = ("no such folder" if not folder.is_dir()
               else "no results.csv in this folder (FOLDER: a folder `physval run --out` wrote)")
    if not found:
        print(f"python -m physval.readings.results: error: {folder}: {why}", file=sys.stderr)
        return 2
    report = rebuild(folder)
    print(f"wrote {report}, {report.with_suffix('.html')}, {folder / 'plots'}/")
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
