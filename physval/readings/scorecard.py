"""The engine scorecard: the first thing a run's report shows. Engines as rows, physical
effects as columns; each cell grades the checks of the families (or of their metrics) that
test that effect, so a reader sees at once which engine gets which physics right.

A cell's grade, from its checks (a reader can recompute it from results.csv):

    A  every check within its tolerance
    B  no failure; the known deviations (measured, with a recorded cause) all within
       10 tolerances
    C  no failure; a known deviation beyond 10 tolerances
    F  a check failed, blew up or raised (fail, unstable, error)
    -  no check of this effect ran on the engine (unsupported, or not selected)

beside the counts (within tolerance / all judged) and the worst error in tolerances.

Three columns come from the other commands' readings where the run's output folder holds
them (`companions`): each effect's cell adds the cost at which the engine reaches the
tolerance on that effect's families (from `physval sweep`, in sweep/), *real-world error*
is the median corner error against the measured cube tosses with the engine's rank (from
`physval real`, in real/), *determinism* whether every repeated scene repeated bit for bit
(from `physval stress`, in stress/: A, else C).
"""
from __future__ import annotations

import math
import time
from dataclasses import dataclass, field
from fnmatch import fnmatchcase
from pathlib import Path

import numpy as np
import pandas as pd

from physval.reportkit import fmt, md_table

INTEGRATION = "integration order"
# effect -> the (family, metric glob) pairs whose checks test it; a family may test several
# effects through different metrics (an incline holds a box: static; slides it: kinetic)
EFFECTS = {
    "restitution": (("central_impact", "*"), ("bounce_series", "*"), ("face_landing", "*"), ("slow_impact", "*"),
                    ("pair_restitution", "*")),
    "static friction": (("incline_threshold", "slides"), ("incline_threshold", "creep_rate"), ("creep", "*")),
    "kinetic friction": (("incline_threshold", "sliding_acceleration"), ("slide_to_stop", "*"),
                         ("friction_isotropy", "*"), ("pair_friction", "*")),
    "rolling": (("rolling_incline", "*"), ("slip_to_roll", "*")),
    "rolling resistance and torsion": (("rolling_resistance", "*"), ("spin_down", "*")),
    "resting and stacking": (("resting_blocks", "*"), ("stack_forces", "*"), ("stack_strike", "*")),
    "simultaneous impacts": (("newtons_cradle", "*"), ("column_impact", "*")),
    "rotation and inertia": (("free_rigid_body", "*"), ("eccentric_impact", "*"), ("edge_landing", "*"),
                             ("tumbling_box", "*"), ("oblique_landing", "*"), ("brick_tumble", "*")),
    "compliant contact": (("hertz_impact", "*"),),
    # the checks that measure an integrator's order, not physics (Check.measures =
    # "integrator"): graded here, whatever family they are in, and under no physical effect
    INTEGRATION: (),
    "stability": (("robustness_*", "*"),),
    "adapter contract": (("conformance", "*"),),
}
REAL, DETERMINISM = "real-world error", "determinism"  # columns from the real and stress readings
CLOSE = 10.0  # tolerances: a known deviation within this many is graded B, beyond it C
JUDGED = ("pass", "fail", "deviation", "unstable", "error")


def effect_of(case: str, metric: str) -> list[str]:
    return [name for name, pairs in EFFECTS.items()
            if any(fnmatchcase(case, f) and fnmatchcase(metric, m) for f, m in pairs)]


def grade(checks: pd.DataFrame) -> str:
    if not len(checks):
        return "-"
    if checks.status.isin(["fail", "unstable", "error"]).any():
        return "F"
    devs = checks[checks.status == "deviation"]
    if not len(devs):
        return "A"
    return "B" if devs.over_tol.max() <= CLOSE else "C"


@dataclass
class Companions:
    """The readings of other commands found beside a run: `physval sweep`'s summary (case,
    variant, engine, reach_cost_us_per_sim_s), `physval stress`'s determinism (engine,
    status) and `physval real`'s summary (engine, param_set, corner_mean_median), each with
    the file it came from (a sentence of the legend); and `physval parity`'s pairs (a report
    section of their own, not in the scorecard)."""
    sweep: pd.DataFrame | None = None
    determinism: pd.DataFrame | None = None
    real: pd.DataFrame | None = None
    sources: list[str] = field(default_factory=list)
    parity: list = field(default_factory=list)
    left_out: list[str] = field(default_factory=list)  # files found but not usable: one line each, why


# each companion: (attribute, file under a run's folder, the command that writes it, the columns read)
COMPANIONS = (("sweep", "sweep/sweep_summary.csv", "sweep", ("case", "engine", "reach_cost_us_per_sim_s")),
              ("determinism", "stress/determinism.csv", "stress", ("engine", "status")),
              ("real", "real/real_summary.csv", "real", ("engine", "param_set", "corner_mean_median")))


def companions(out: Path) -> Companions:
    """The sweep, stress, real and parity readings in sweep/, stress/, real/ and parity/ under
    `out` (the commands' default folders beside a run's), whichever exist. A file that
    cannot be read as the table its command writes (empty, damaged, another program's) is
    left out and named in `left_out`, so that it costs its column, not the report."""
    from physval.readings import parity
    left_out = []
    found = Companions(parity=parity.beside(out, left_out), left_out=left_out)
    for attr, path, command, columns in COMPANIONS:
        file = Path(out) / path
        if file.is_file():
            table = companion_table(file, command, columns)
            if isinstance(table, str):
                left_out.append(f"{file}: {table}")
                continue
            setattr(found, attr, table)
            when = time.strftime("%Y-%m-%d", time.gmtime(file.stat().st_mtime))
            found.sources.append(f"`physval {command}` of {when} ({path})")
    return found


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


def reach_cost(sweep: pd.DataFrame | None, engine: str, families: list[str]) -> str:
    """The cost at which `engine` reaches the tolerance on every swept variant of `families`
    (the dearest variant's cheapest setting), or how many variants never reach it."""
    if sweep is None:
        return ""
    mine = sweep[(sweep.engine == engine) & sweep.case.isin(families)]
    if not len(mine):
        return ""
    cost = pd.to_numeric(mine.reach_cost_us_per_sim_s, errors="coerce")
    reached = cost[np.isfinite(cost)]
    if len(reached) < len(mine):
        return f"tol in {len(reached)}/{len(mine)} swept"
    return f"tol at {fmt(reached.max() / 1e3)} ms/s"


def real_errors(real: pd.DataFrame | None) -> dict[str, str]:
    """Per engine of the real tier: its median corner error (cube widths) at the parameters
    the real report ranks it by, and that rank (physval.readings.real.ranking)."""
    if real is None:
        return {}
    from physval.readings.real import ranking
    ranked = ranking(real)
    return {engine: f"{fmt(value)}, rank {rank}/{len(ranked)}"
            for rank, (engine, _, value) in enumerate(ranked, 1) if math.isfinite(value)}


def measure(df: pd.DataFrame, beside: Companions | None = None) -> pd.DataFrame:
    """One row per (engine, effect): grade, checks within tolerance, checks judged, known
    deviations, failures, worst error in tolerances, the families behind them, and from the
    readings `beside` the run the cost of reaching the tolerance (`cost`) and the text of
    the real-world and determinism columns (`text`)."""
    beside = beside or Companions()
    real = real_errors(beside.real)
    judged = df[df.status.isin(JUDGED)]
    rows = []
    effects = {k: effect_of(*k) for k in set(zip(judged.case, judged.metric))}
    order = (judged.measures == "integrator").to_numpy() if "measures" in judged else np.zeros(len(judged), bool)
    for engine in dict.fromkeys(df.engine):
        mine_at = (judged.engine == engine).to_numpy()
        mine = judged[mine_at]
        integrator = order[mine_at]
        for effect in EFFECTS:
            if effect == INTEGRATION:
                part = mine[integrator]
            else:
                part = mine[np.array([effect in effects[(c, m)] for c, m in zip(mine.case, mine.metric)], dtype=bool)
                            & ~integrator]
            families = sorted(part.case.unique())
            rows.append({"engine": engine, "effect": effect, "grade": grade(part),
                         "within": int((part.status == "pass").sum()), "judged": len(part),
                         "deviations": int((part.status == "deviation").sum()),
                         "failures": int(part.status.isin(["fail", "unstable", "error"]).sum()),
                         "worst": float(part.over_tol.max()) if len(part) else float("nan"),
                         "worst_text": worst_of(part),
                         "families": ", ".join(families),
                         "cost": reach_cost(beside.sweep, engine, families) if effect != INTEGRATION else "",
                         "text": ""})
        rows += [_companion(engine, REAL, "", real.get(engine, "")),
                 _determinism(engine, beside.determinism)]
    return pd.DataFrame(rows)


def worst_of(part: pd.DataFrame) -> str:
    """The worst error in tolerances; where that is a check that allows no error at all (a
    count or a yes/no, tolerance 0: its error in tolerances is infinite), that check's value
    against the one asked instead. Checks without an error (a job that raised or blew up) have
    none to show: their count is the failures column's."""
    if not part.over_tol.notna().any():
        return ""
    worst = part.loc[part.over_tol.idxmax()]
    if np.isinf(worst.over_tol):
        return f"worst {worst.metric} {fmt(worst.measured)} for {fmt(worst.expected)}"
    return f"worst {fmt(worst.over_tol)} tol"


def _companion(engine: str, effect: str, grade_: str, text: str) -> dict:
    return {"engine": engine, "effect": effect, "grade": grade_ if text else "-", "within": 0, "judged": 0,
            "deviations": 0, "failures": 0, "worst": float("nan"), "worst_text": "", "families": "", "cost": "",
            "text": text}


def _determinism(engine: str, det: pd.DataFrame | None) -> dict:
    """How many of the stress scenes the engine ran repeated bit for bit (a scene it cannot
    represent, a 3D one for a 2D engine, is no repeat it missed)."""
    mine = det[(det.engine == engine) & (det.status != "unsupported")] if det is not None else ()
    if not len(mine):
        return _companion(engine, DETERMINISM, "", "")
    same = int((mine.status == "deterministic").sum())
    return _companion(engine, DETERMINISM, "A" if same == len(mine) else "C",
                      f"{same}/{len(mine)} repeat")


def cell(r, bold: bool = True) -> str:
    """A cell's text: the grade (in bold in markdown), the counts, the worst error, the cost."""
    if r.grade == "-" and not r.text:
        return "-"
    g = f"**{r.grade}**" if bold and r.grade else r.grade
    if r.text:
        return f"{g} {r.text}".strip()
    text = f"{g} {r.within}/{r.judged}" + (f", {r.worst_text}" if r.grade != "A" else "")
    return text + (f"; {r.cost}" if r.cost else "")


def legend(beside: Companions | None = None) -> str:
    """How to read the scorecard (the markdown and the HTML share it)."""
    text = ("Each cell grades the checks of one physical effect on one engine: **A** every check within its "
            "tolerance; **B** no failure, the known deviations within 10 tolerances; **C** no failure, a known "
            "deviation beyond 10 tolerances; **F** a check failed, blew up or raised; - nothing of it ran. Beside "
            "the grade: checks within tolerance / checks judged, and the worst error in tolerances (where the worst is a "
            "check that allows no error, a count or a yes/no, its value against the one asked). Checks whose "
            "tolerance is an integration scheme's error bound (a second-order rotation step) measure the "
            "engine's integrator, not its physics: they are graded under *integration order* only.")
    if beside is not None and beside.sources:
        text += (" From the readings beside this run (" + "; ".join(beside.sources) + "): after the counts, "
                 "*tol at X ms/s* is the cost at which the engine reaches the tolerance on every swept variant of "
                 "the effect's families (the dearest variant at its cheapest setting, in milliseconds of wall time "
                 "per simulated second; *tol in k/n swept*: only k of the n variants reach it at any setting); "
                 "*real-world error* is the median over test tosses of the mean corner error against the measured "
                 "cube tosses, in cube widths, at the engine's fitted parameters, and its rank; *determinism*, how "
                 "many of the stress scenes repeated bit for bit (A all, C not all).")
    return text


def section(card: pd.DataFrame, beside: Companions | None = None) -> str:
    """The scorecard as markdown: a table of grades and, below it, how to read it."""
    if not len(card):
        return ""
    shown = card.assign(cell=[cell(r) for r in card.itertuples()])
    table = shown.pivot(index="engine", columns="effect", values="cell")
    table = table.loc[list(dict.fromkeys(card.engine)), [e for e in columns() if e in table.columns]]
    table = table.loc[:, (table != "-").any(axis=0)]
    families = sorted({f for fs in card.families for f in fs.split(", ") if f})
    return "\n".join([
        "## Scorecard", "", legend(beside) + " The effects' families: "
        + ", ".join(f"[{f}](families/{f}.md)" for f in families) + " (`physval.readings.scorecard."
        "EFFECTS` says which family and metric tests which effect).", "",
        md_table(table.reset_index()), ""])


def columns() -> list[str]:
    """The scorecard's columns in order: the effects, then the other commands' readings."""
    return [*EFFECTS, REAL, DETERMINISM]


def by_family(df: pd.DataFrame) -> str:
    """A scorecard of families rather than effects (engines as rows, each family a column,
    graded as above): the one-screen opening of a report whose families all test one effect
    (stress: every robustness family tests stability)."""
    judged = df[df.status.isin(JUDGED)]
    if not len(judged):
        return ""
    families = sorted(judged.case.unique())
    rows = []
    for engine in dict.fromkeys(df.engine):
        mine = judged[judged.engine == engine]
        line = {"engine": engine}
        for fam in families:
            part = mine[mine.case == fam]
            g = grade(part)
            line[fam] = "-" if g == "-" else f"**{g}** {int((part.status == 'pass').sum())}/{len(part)}" + (
                f", {worst_of(part)}" if g != "A" else "")
        rows.append(line)
    return "\n".join([
        "## Scorecard", "",
        "Each cell grades one family's checks on one engine: **A** every check within its tolerance; **B** no "
        "failure, the known deviations within 10 tolerances; **C** no failure, a known deviation beyond 10 "
        "tolerances; **F** a check failed, blew up or raised; - nothing of it ran. Beside the grade: checks within "
        "tolerance / checks judged, and the worst error in tolerances (where the worst is a check that allows no "
        "error, a count or a yes/no, its value against the one asked).", "",
        md_table(pd.DataFrame(rows)), ""])
