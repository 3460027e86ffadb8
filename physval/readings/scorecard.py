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
"""
from __future__ import annotations

from fnmatch import fnmatchcase

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


def measure(df: pd.DataFrame) -> pd.DataFrame:
    """One row per (engine, effect): grade, checks within tolerance, checks judged, known
    deviations, failures, worst error in tolerances, and the families behind them."""
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
            rows.append({"engine": engine, "effect": effect, "grade": grade(part),
                         "within": int((part.status == "pass").sum()), "judged": len(part),
                         "deviations": int((part.status == "deviation").sum()),
                         "failures": int(part.status.isin(["fail", "unstable", "error"]).sum()),
                         "worst": float(part.over_tol.max()) if len(part) else float("nan"),
                         "families": ", ".join(sorted(part.case.unique()))})
    return pd.DataFrame(rows)


def cell(r) -> str:
    if r.grade == "-":
        return "-"
    return f"**{r.grade}** {r.within}/{r.judged}" + (f", worst {fmt(r.worst)} tol" if r.grade != "A" else "")


def section(card: pd.DataFrame) -> str:
    """The scorecard as markdown: a table of grades and, below it, how to read it."""
    if not len(card):
        return ""
    shown = card.assign(cell=[cell(r) for r in card.itertuples()])
    table = shown.pivot(index="engine", columns="effect", values="cell")
    table = table.loc[list(dict.fromkeys(card.engine)), [e for e in EFFECTS if e in table.columns]]
    table = table.loc[:, (table != "-").any(axis=0)]
    families = sorted({f for fs in card.families for f in fs.split(", ") if f})
    return "\n".join([
        "## Scorecard", "",
        "Each cell grades the checks of one physical effect on one engine: **A** every check within its "
        "tolerance; **B** no failure, the known deviations within 10 tolerances; **C** no failure, a known "
        "deviation beyond 10 tolerances; **F** a check failed, blew up or raised; - nothing of it ran. Beside the "
        "grade: checks within tolerance / checks judged, and the worst error in tolerances. Checks whose "
        "tolerance is an integration scheme's error bound (a second-order rotation step) measure the "
        "engine's integrator, not its physics: they are graded under *integration order* only. The effects' "
        "families: " + ", ".join(f"[{f}](families/{f}.md)" for f in families) + " (`physval.readings.scorecard."
        "EFFECTS` says which family and metric tests which effect).", "",
        md_table(table.reset_index()), ""])


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
                f", worst {fmt(part.over_tol.max())} tol" if g != "A" else "")
        rows.append(line)
    return "\n".join([
        "## Scorecard", "",
        "Each cell grades one family's checks on one engine: **A** every check within its tolerance; **B** no "
        "failure, the known deviations within 10 tolerances; **C** no failure, a known deviation beyond 10 "
        "tolerances; **F** a check failed, blew up or raised; - nothing of it ran. Beside the grade: checks within "
        "tolerance / checks judged, and the worst error in tolerances.", "",
        md_table(pd.DataFrame(rows)), ""])
