"""The engine scorecard: the first thing a run's report shows. Engines as rows, physical
effects as columns; each cell grades the checks of the families (or of their metrics) that
test that effect, by how far the engine is from physics, measured. This docstring is the
one place the rule is written; the report's legend is drawn from the same constants.

The grade of a cell, from its judged checks (pass, fail, deviation, unstable, error; a
reader can recompute it from results.csv: `over_tol` is |error| / tolerance of the check's
own kind, physval.readings.checks.frame):

    share  = checks within tolerance / checks judged
    miss   = the median error, in tolerances, of the checks that miss (the typical miss;
             a check that blew up or raised, or one that allows no error at all, a count
             or a yes/no, misses by an infinite amount)
    letter = A  every check within tolerance (share = 1: there is no miss)
             B  share >= 0.9       C  share >= 0.7       D  share >= 0.5       F  below
    digit  = the decade of the typical miss: 1 within 10 tolerances, 2 within 100,
             3 within 1000, 4 beyond

so a grade reads "B2": at least 90 % of the checks within tolerance, the typical miss
between 10 and 100 tolerances; "-": no check of this effect ran on the engine
(unsupported, or not selected). Grades order as A, B1, ..., B4, C1, ..., F4; engines of one
grade order by the larger share, then the smaller typical miss, the more checks judged and
the smaller cost (`run_cost`): that is each effect's ranking (`rank_key`; the `rank`
column of `measure`, physval.readings.closest). A failed check (outside its tolerance
and no known deviation, or a deviation that left its band) is a miss like any other here;
the cell counts it, and the report's failures section lists it.

Two columns grade checks by what they measure rather than by effect (`BY_MEASURE`):
*integration order* the checks whose tolerance is a time-stepping scheme's error bound, and
*invariance* the invariance battery's verdicts (physval.core.invariance: a scene run as
given and turned, moved, mirrored, scaled, built in another order, given as a hull or mesh,
on more threads, as a world of a batch, or saved and restored, each judged against what the
engine promises: bit-identical, or round-off at its float width). Their checks count under
no physical effect; the grade follows the same rule.

Three columns come from the other commands' readings where the run's output folder holds
them (`companions`): each effect's cell adds the cost at which the engine reaches the
tolerance on that effect's families (from `physval sweep`, in sweep/), *real-world error*
is the median corner error against the measured cube tosses with the engine's rank (from
`physval real`, in real/), *determinism* the share of the stress scenes that repeated bit
for bit, graded by the same letters (from `physval stress`, in stress/).

Each row of `measure` also carries the engine's rank on its effect (the ranking above) and
its own cost there, the median over the effect's runs of `wall_s / sim_s`: what
physval.readings.closest answers "which engine is closest to physics here" with.
"""
from __future__ import annotations

import math
import time
from dataclasses import dataclass, field
from fnmatch import fnmatchcase
from pathlib import Path

import numpy as np
import pandas as pd

from physval.report import Html, Section, companion_table, fmt, md_table, pyplot, rows_table, save_figure
from physval.report import cell as html_cell

INTEGRATION = "integration order"
INVARIANCE = "invariance"
# effect -> the (family, metric glob[, variant glob]) whose checks test it; a family may test
# several effects through different metrics (an incline holds a box: static; slides it:
# kinetic), and only some of its variants may test one (the grasp: below)
EFFECTS = {
    "restitution": (("central_impact", "*"), ("bounce_series", "*"), ("face_landing", "*"), ("slow_impact", "*"),
                    ("pair_restitution", "*")),
    "static friction": (("incline_threshold", "slides"), ("incline_threshold", "creep_rate"), ("creep", "*")),
    "kinetic friction": (("incline_threshold", "sliding_acceleration"), ("slide_to_stop", "*"),
                         ("friction_isotropy", "*"), ("pair_friction", "*"), ("cylinder_slide", "*")),
    "rolling": (("rolling_incline", "*"), ("slip_to_roll", "*"), ("rolling_shapes", "*")),
    "rolling resistance and torsion": (("rolling_resistance", "*"), ("spin_down", "*")),
    "resting and stacking": (("resting_blocks", "*"), ("stack_forces", "*"), ("stack_strike", "*"),
                             ("lying_cylinder", "*")),
    "simultaneous impacts": (("newtons_cradle", "*"), ("column_impact", "*")),
    "rotation and inertia": (("free_rigid_body", "*"), ("eccentric_impact", "*"), ("edge_landing", "*"),
                             ("tumbling_box", "*"), ("oblique_landing", "*"), ("brick_tumble", "*"),
                             ("prism_incline", "*")),
    "compliant contact": (("hertz_impact", "*"),),
    "joints": (("pendulum", "*"), ("double_pendulum", "*"), ("four_bar", "*"), ("rail_slide", "*"),
               ("hinged_rod_stop", "*"), ("limit_impact", "*")),
    # the determinate grasps: the ball (one point a pad) and the 2D block; the 3D block's face
    # contacts split the load indeterminately (cases/pinch_grasp.py), so its checks grade how a
    # solver picks a split, not the grasp's friction: the family's page shows them, no cell
    "grasp": (("pinch_grasp", "*", "*,ball"), ("pinch_grasp", "*", "*,2D")),
    "contact geometry": (("narrow_phase", "*"),),
    # the checks that measure an integrator's order, not physics (Check.measures =
    # "integrator"): graded here, whatever family they are in, and under no physical effect
    INTEGRATION: (),
    # the invariance battery's verdicts (Check.measures = "invariance": physval.core.invariance):
    # two runs physics says are the same, compared through a relation of cases.relations
    INVARIANCE: (),
    "stability": (("robustness_*", "*"),),
    "adapter contract": (("conformance", "*"),),
}
REAL, DETERMINISM = "real-world error", "determinism"  # columns from the real and stress readings
# the columns that grade the checks of one Check.measures (whatever their family) instead of an effect's
BY_MEASURE = {"integrator": INTEGRATION, "invariance": INVARIANCE}


SHARES = (("A", 1.0), ("B", 0.9), ("C", 0.7), ("D", 0.5), ("F", 0.0))  # letter: the least share within
DECADES = (10.0, 100.0, 1000.0)  # tolerances: a typical miss within the first is digit 1, beyond the last 4
ORDER = ["A"] + [f"{letter}{d}" for letter, _ in SHARES[1:] for d in range(1, len(DECADES) + 2)]
JUDGED = ("pass", "fail", "deviation", "unstable", "error")


def effect_of(case: str, metric: str, variant: str = "") -> list[str]:
    """The effects a check of `case`'s `variant` on `metric` tests (EFFECTS)."""
    return [name for name, entries in EFFECTS.items() if any(_covers(e, case, metric, variant) for e in entries)]


def _covers(entry: tuple, case: str, metric: str, variant: str) -> bool:
    family, metrics, variants = (*entry, "*")[:3]  # no variant glob: every variant
    return fnmatchcase(case, family) and fnmatchcase(metric, metrics) and fnmatchcase(variant, variants)


def typical_miss(checks: pd.DataFrame) -> float:
    """The median error, in tolerances, of the checks that miss (NaN: none misses); one
    without an error (it blew up or raised) misses by an infinite amount."""
    misses = checks.over_tol[checks.status != "pass"].astype(float).fillna(math.inf)
    return float(np.median(misses)) if len(misses) else math.nan


def letter_of(share: float) -> str:
    return next(letter for letter, least in SHARES if share >= least)


def grade_of(share: float, miss: float) -> str:
    """The grade of a share within tolerance and a typical miss (the module's rule)."""
    letter = letter_of(share)
    return letter if letter == "A" else f"{letter}{1 + sum(miss > d for d in DECADES)}"


def grade(checks: pd.DataFrame) -> str:
    """The grade of a cell's checks (the module's rule); "-" where none is judged."""
    if not len(checks):
        return "-"
    judged = checks[checks.status.isin(JUDGED)]
    if not len(judged):
        return "-"
    return grade_of(float((judged.status == "pass").mean()), typical_miss(judged))


def rank_key(grade_: str, within: int, judged: int, miss: float, cost: float = math.nan) -> tuple:
    """The order of a ranking: the grade, then the larger share, the smaller typical miss,
    the more checks judged, the smaller cost (ms of wall time per simulated second); cells
    without a grade last."""
    if grade_ not in ORDER or not judged:
        return (len(ORDER), 0.0, 0.0, 0, 0.0)
    return (ORDER.index(grade_), -within / judged, 0.0 if math.isnan(miss) else miss, -judged,
            math.inf if math.isnan(cost) else cost)


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


def run_cost(part: pd.DataFrame) -> float:
    """The engine's own cost on these checks: the median over their runs of the wall time
    per simulated second (`wall_s / sim_s` of results.csv), in ms/s; NaN without timings."""
    if not {"variant", "wall_s", "sim_s"} <= set(part.columns):
        return math.nan
    runs = part.drop_duplicates(["case", "variant"])
    with np.errstate(divide="ignore", invalid="ignore"):
        per = pd.to_numeric(runs.wall_s, errors="coerce") / pd.to_numeric(runs.sim_s, errors="coerce")
    per = per[np.isfinite(per) & (per > 0)]
    return float(np.median(per) * 1e3) if len(per) else math.nan


def measure(df: pd.DataFrame, beside: Companions | None = None) -> pd.DataFrame:
    """One row per (engine, effect): grade, checks within tolerance, checks judged, their
    share, the typical miss, known deviations, failures, worst error in tolerances, the
    families behind them, the run's own cost (`ms_per_s`), the rank among the engines on
    that effect (1 the closest), and from the readings `beside` the run the cost of reaching
    the tolerance (`cost`) and the text of the real-world and determinism columns (`text`)."""
    beside = beside or Companions()
    real = real_errors(beside.real)
    judged = df[df.status.isin(JUDGED)]
    rows = []
    variants = judged.variant.astype(str) if "variant" in judged else pd.Series("", index=judged.index)
    effects = {k: effect_of(*k) for k in set(zip(judged.case, judged.metric, variants))}
    measures = judged.measures.fillna("physics").to_numpy() if "measures" in judged else np.full(len(judged), "physics")
    for engine in dict.fromkeys(df.engine):
        mine_at = (judged.engine == engine).to_numpy()
        mine = judged[mine_at]
        column = np.array([BY_MEASURE.get(m, "") for m in measures[mine_at]], dtype=object)
        for effect in EFFECTS:
            if effect in BY_MEASURE.values():
                part = mine[column == effect]
            else:
                part = mine[np.array([effect in effects[k] for k in zip(mine.case, mine.metric, variants[mine_at])],
                                     dtype=bool) & (column == "")]
            families = sorted(part.case.unique())
            within = int((part.status == "pass").sum())
            rows.append({"engine": engine, "effect": effect, "grade": grade(part),
                         "within": within, "judged": len(part), "share": within / len(part) if len(part) else math.nan,
                         "miss": typical_miss(part),
                         "deviations": int((part.status == "deviation").sum()),
                         "failures": int(part.status.isin(["fail", "unstable", "error"]).sum()),
                         "worst": float(part.over_tol.max()) if len(part) else float("nan"),
                         "worst_text": worst_of(part),
                         "families": ", ".join(families),
                         "ms_per_s": run_cost(part) if len(part) else math.nan,
                         "cost": reach_cost(beside.sweep, engine, families) if effect not in BY_MEASURE.values()
                         else "",
                         "text": ""})
        rows += [_companion(engine, REAL, "", real.get(engine, "")),
                 _determinism(engine, beside.determinism)]
    card = pd.DataFrame(rows)
    if len(card):
        card["rank"] = 0
        for _, grp in card.groupby("effect", sort=False):
            order_ = sorted(grp.index, key=lambda i: rank_key(*card.loc[i, ["grade", "within", "judged", "miss", "ms_per_s"]]))
            card.loc[order_, "rank"] = range(1, len(order_) + 1)
    return card


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


def _companion(engine: str, effect: str, grade_: str, text: str, within: int = 0, judged: int = 0) -> dict:
    return {"engine": engine, "effect": effect, "grade": grade_ if text else "-", "within": within, "judged": judged,
            "share": within / judged if judged else math.nan, "miss": math.nan, "deviations": 0, "failures": 0, "worst": float("nan"),
            "worst_text": "", "families": "", "ms_per_s": math.nan, "cost": "", "text": text}


def _determinism(engine: str, det: pd.DataFrame | None) -> dict:
    """How many of the stress scenes the engine ran repeated bit for bit, graded by the share
    (a scene it cannot represent, a 3D one for a 2D engine, is no repeat it missed)."""
    mine = det[(det.engine == engine) & (det.status != "unsupported")] if det is not None else ()
    if not len(mine):
        return _companion(engine, DETERMINISM, "", "")
    same = int((mine.status == "deterministic").sum())
    return _companion(engine, DETERMINISM, letter_of(same / len(mine)), f"{same}/{len(mine)} repeat", same, len(mine))


def miss_text(r) -> str:
    """The typical miss of a cell as text ("" where nothing misses)."""
    if r.grade in ("A", "-", "") or math.isnan(r.miss):
        return ""
    return f"typical miss {fmt(r.miss)} tol" if math.isfinite(r.miss) else "typical miss inf"


def cell(r, bold: bool = True) -> str:
    """A cell's text: the grade (in bold in markdown), the counts, the typical miss, the cost."""
    if r.grade == "-" and not r.text:
        return "-"
    g = f"**{r.grade}**" if bold and r.grade else r.grade
    if r.text:
        return f"{g} {r.text}".strip()
    miss = miss_text(r)
    text = f"{g} {r.within}/{r.judged}" + (f", {miss}" if miss else "")
    return text + (f"; {r.cost}" if r.cost else "")


def rule(of: str = "effect") -> str:
    """The grading rule in words, from the constants that apply it; a cell grades one `of`."""
    letters = "; ".join(f"**{letter}** at least {least * 100:.0f} %" for letter, least in SHARES[1:-1])
    decades = ", ".join(f"{i} within {d:g}" for i, d in enumerate(DECADES, 1))
    return (f"A cell's grade says how far the engine is from physics on that {of}: its letter is the share of "
            f"checks within tolerance (**A** all of them; {letters}; **{SHARES[-1][0]}** less), its digit the "
            f"decade of the typical miss, the median error of the checks that miss, in tolerances ({decades}, "
            f"{len(DECADES) + 1} beyond; a check that blew up or raised, or a count or yes/no that allows no "
            f"error, misses by an infinite amount). So **{SHARES[1][0]}2** is at least {SHARES[1][1] * 100:.0f} % "
            f"within tolerance with misses of typically {DECADES[0]:g} to {DECADES[1]:g} tolerances; - nothing of "
            f"it ran. Grades order A, {ORDER[1]}, ..., {ORDER[-1]}; one grade's engines by the larger share, then "
            f"the smaller miss, the more checks judged, the smaller cost.")


def legend(beside: Companions | None = None) -> str:
    """How to read the scorecard (the markdown and the HTML share it)."""
    text = (rule() + " Beside the grade: checks within tolerance / checks judged, and the typical miss. Checks "
            "whose tolerance is an integration scheme's error bound (a second-order rotation step) measure the "
            "engine's integrator, not its physics: they are graded under *integration order* only; *invariance* "
            "grades the invariance battery (the same scene turned, moved, mirrored, scaled, reordered, run on more "
            "threads, as a world of a batch or saved and restored, against the engine's promise: bit-identical or "
            "round-off at its float width). The rule is "
            "`physval.readings.scorecard`'s docstring; every number comes from `results.csv`.")
    if beside is not None and beside.sources:
        text += (" From the readings beside this run (" + "; ".join(beside.sources) + "): after the counts, "
                 "*tol at X ms/s* is the cost at which the engine reaches the tolerance on every swept variant of "
                 "the effect's families (the dearest variant at its cheapest setting, in milliseconds of wall time "
                 "per simulated second; *tol in k/n swept*: only k of the n variants reach it at any setting); "
                 "*real-world error* is the median over test tosses of the mean corner error against the measured "
                 "cube tosses, in cube widths, at the engine's fitted parameters, and its rank; *determinism*, how "
                 "many of the stress scenes repeated bit for bit, graded by the same letters.")
    return text


def grid(card: pd.DataFrame) -> pd.DataFrame:
    """Engines as rows, the scorecard's columns that hold a grade anywhere, each cell's text."""
    shown = card.assign(cell=[cell(r) for r in card.itertuples()])
    table = shown.pivot(index="engine", columns="effect", values="cell")
    table = table.loc[list(dict.fromkeys(card.engine)), [e for e in columns() if e in table.columns]]
    return table.loc[:, (table != "-").any(axis=0)]


def section(card: pd.DataFrame, beside: Companions | None = None, picture: str = "") -> str:
    """The scorecard as markdown: a table of grades and, below it, how to read it."""
    if not len(card):
        return ""
    families = sorted({f for fs in card.families for f in fs.split(", ") if f})
    return "\n".join([
        "## Scorecard", "", legend(beside) + " The effects' families: "
        + ", ".join(f"[{f}](families/{f}.md)" for f in families) + " (`physval.readings.scorecard."
        "EFFECTS` says which family, metric and variants test which effect).", "",
        md_table(grid(card).reset_index()), ""] + ([f"![Scorecard]({picture})", ""] if picture else []))


def table_of(card: pd.DataFrame, engine_page=None, name: str = "scorecard") -> dict:
    """The scorecard as a page's table: engines as rows (each linking its page), effects (and
    the other commands' readings) as columns; each cell its grade (coloured by its letter),
    the text of report.md's cell, and its rank on the effect as its sort key, so a click on
    an effect's heading orders the engines from the closest to physics."""
    if card.empty:  # a run with no rows (every job left out, e.g. on demand): no grades
        return rows_table(name, ["engine"], [])
    card = card.assign(cell=[cell(r, bold=False) for r in card.itertuples()])
    shown = [e for e in columns() if (card[card.effect == e].cell != "-").any()]
    rows = []
    for engine, mine in card.groupby("engine", sort=False):
        by = {r.effect: r for r in mine.itertuples()}
        line = [html_cell(engine, engine_page(engine) if engine_page else "")]
        for e in shown:
            r = by[e]
            graded = r.grade not in ("-", "")
            line.append(html_cell(r.cell, cls=f"g-{r.grade[0]}" if graded else "",
                                  key=int(r.rank) if graded else len(ORDER) * 100))
        rows.append(line)
    return rows_table(name, ["engine"] + shown, rows)


def plot(card: pd.DataFrame, path: Path) -> None:
    """The scorecard as a picture: engines as rows, effects as columns, each cell coloured
    by its grade (green A to red F4) and labelled with it and its counts."""
    plt = pyplot()
    graded = card[card.effect.isin(EFFECTS) | (card.effect == DETERMINISM)]
    effects = [e for e in columns() if e in set(graded[graded.grade.isin(ORDER)].effect)]
    engines = list(dict.fromkeys(graded.engine))
    where = {(r.engine, r.effect): r for r in graded.itertuples()}
    value = np.full((len(engines), len(effects)), np.nan)
    fig, ax = plt.subplots(figsize=(1.05 * len(effects) + 2.6, 0.34 * len(engines) + 1.6), layout="constrained")
    for i, engine in enumerate(engines):
        for j, effect in enumerate(effects):
            r = where.get((engine, effect))
            if r is None or r.grade not in ORDER:
                ax.text(j, i, "-", ha="center", va="center", fontsize=7, color="#888")
                continue
            value[i, j] = ORDER.index(r.grade)
            label = f"{r.grade} {r.within}/{r.judged}"
            ax.text(j, i, label, ha="center", va="center", fontsize=6.5)
    ax.imshow(value, cmap="RdYlGn_r", vmin=0, vmax=len(ORDER) - 1, aspect="auto", interpolation="nearest")
    ax.set_xticks(range(len(effects)), effects, rotation=30, ha="right", fontsize=8)
    ax.set_yticks(range(len(engines)), engines, fontsize=8)
    bands = ", ".join(f"{letter} >= {least * 100:.0f} %" for letter, least in SHARES[1:-1])
    ax.set_title(f"Scorecard: grade per effect (letter: share of checks within tolerance, A all, {bands}; "
                 "digit: decade of the typical miss in tolerances)", fontsize=8)
    save_figure(fig, path)


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
            miss = typical_miss(part)
            line[fam] = "-" if g == "-" else f"**{g}** {int((part.status == 'pass').sum())}/{len(part)}" + (
                f", typical miss {fmt(miss)} tol" if g != "A" else "")
        rows.append(line)
    return "\n".join([
        "## Scorecard", "", "Each cell grades one family's checks on one engine. " + rule("family")
        + " Beside the grade: checks within tolerance / checks judged, and the typical miss.", "",
        md_table(pd.DataFrame(rows)), ""])


# --- the report's sections ---------------------------------------------------------------

@dataclass
class Card:
    """What the scorecard's sections show: the grades (`measure`), the readings beside the
    run, the plots folder the picture goes to (None: no picture) and each engine's page."""
    grades: pd.DataFrame
    beside: Companions
    plots: Path | None = None
    engine_page: object = None

    def __len__(self) -> int:
        return len(self.grades)


class Scorecard(Section):
    """The report's first section: the grades, their picture and how to read them. Its
    source names the run's rows (`df`), its grades (`card`: `measure(df, beside)`), the
    readings `beside` it, its `plots` folder and each engine's page (`engine_page`)."""

    def measure(self, run) -> Card:
        return Card(run.card, run.beside, run.plots, run.engine_page)

    def markdown(self, card: Card) -> str:
        picture = ""
        if card.plots is not None and (card.grades.grade.isin(ORDER)).any():
            plot(card.grades, card.plots / "scorecard.png")
            picture = "plots/scorecard.png"
        return section(card.grades, card.beside, picture)

    def html(self, card: Card, html: Html) -> str:
        head = html.markdown("\n".join(["## Scorecard", "", legend(card.beside)]), "scorecard")
        drawn = card.plots is not None and (card.plots / "scorecard.png").is_file()
        img = '<img class="plot" src="plots/scorecard.png" alt="Scorecard: grade per engine and effect">' if drawn else ""
        return head + html.table(table_of(card.grades, card.engine_page)) + img
