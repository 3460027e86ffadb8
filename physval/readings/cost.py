"""What a run costs: before it runs (`physval run --plan`), per engine and family, from
measured per-job costs; after it ran (the report's Cost section), where its time went.

The model. A job's cost is its whole time in a worker (`job_s`: building the scene and the
engine, stepping, recording, observing, judging), in seconds of one worker. Per engine and
family, measured jobs give the seconds per step of the engine's steps and its mean time per
job outside them; a planned job costs
    outside(engine, family) + per_step(engine, family) * steps(job),
with the engine's median over its families where the family was not measured on it (a new
family), and is unknown where the engine was not measured (a new engine): the plan counts
those jobs apart, so a new engine shows as an unpriced share, not as free. The measured
costs are the last run's (its results.csv in --out), else the table shipped with physval
(`costs.csv`: a default run on 2 cores, which `physval bench run` writes). The run's wall
time on N workers is the sum over jobs divided by N (thousands of jobs, the longest a
minute: the tail is small), plus the readings (cached per engine version: free after the
first run) and the report.

After the run, the time is split into phases: planning (before the first job), the
jobs (the workers' time in them: the engines' steps, and the rest of each job), the
engine-wide readings' jobs (which share the workers with the run's), the workers' time
outside any job (starting, waiting for the next job, results in transit: the per-job
overhead), and the report.
"""
from __future__ import annotations

import math
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import pandas as pd

from physval.report import fmt, md_table, write_atomic

TABLE = Path(__file__).with_name("costs.csv")  # per engine and family, a default run's (physval bench run)
# a row per engine and family, and one per variant for the jobs over the per-job limit
# (physval.core.plan.over_the_limit: measured over PER_JOB_LIMIT_S, or over half of it for a
# job already priced apart): priced apart, such a job waits for --on-demand without taking
# its family's other variants with it (variant empty: the family's row)
TABLE_COLUMNS = ["engine", "case", "variant", "jobs", "steps", "stepping_s", "job_s"]
BUDGET_S = 180.0       # the default run's budget: 3 minutes ...
BUDGET_WORKERS = 2     # ... on 2 cores (decision 10)


# --- measured per-job costs ------------------------------------------------------------------

PER_JOB_COLUMNS = ("job", "engine", "case", "variant", "steps", "wall_s", "job_s", "compile_s", "first_in_worker")


def per_job(rows) -> pd.DataFrame:
    """One row per job of a run's rows (results.csv or a store's): its key, engine, family,
    variant, steps, stepping time (wall_s), whole time (job_s), of it numba's compiling
    (compile_s), and whether it was its engine's first job in its worker (first_in_worker);
    each NaN in rows written before physval recorded it."""
    df = pd.DataFrame(list(rows)) if not isinstance(rows, pd.DataFrame) else rows
    if not len(df) or "job" not in df:
        return pd.DataFrame(columns=list(PER_JOB_COLUMNS))
    df = df.drop_duplicates("job")
    out = pd.DataFrame({"job": df["job"], "engine": df["engine"], "case": df["case"],
                        "variant": df["variant"].fillna("").astype(str) if "variant" in df else ""})
    for col in ("steps", "wall_s", "job_s", "compile_s", "first_in_worker"):
        out[col] = pd.to_numeric(df[col], errors="coerce") if col in df else math.nan
    return out.reset_index(drop=True)


def priceable(jobs: pd.DataFrame) -> pd.DataFrame:
    """The measured jobs (per_job) whose time is what they cost the next run. Left out, so
    that they price nothing (the table's earlier price for them stays): a job that spent
    time getting the reference's compiled code ready (compile_s > 0: the first run after
    installing physval or editing reference_impl, minutes of numba for a formulation's first
    jobs, or a wait for another process compiling it), and a job that was its engine's
    first in its worker (first_in_worker: its time holds the engine's start, e.g. Genesis'
    import, 14 s, or Warp's kernels compiled into an empty cache, 10-60 s): priced at that,
    it could go over the per-job limit and leave the next run that finds its rows stale."""
    keep = pd.Series(True, index=jobs.index)
    if "compile_s" in jobs:
        keep &= ~(jobs.compile_s > 0)
    if "first_in_worker" in jobs:
        keep &= ~(jobs.first_in_worker > 0)
    return jobs[keep]


def per_family(jobs: pd.DataFrame, apart: frozenset = frozenset()) -> pd.DataFrame:
    """Measured jobs (per_job, with job_s) summed per engine and family, those over the
    per-job limit per engine, family and variant: the model's table. `apart`: the (engine,
    family, variant) an earlier table priced apart, which stay apart while over half the
    limit (physval.core.plan.over_the_limit)."""
    from physval.core.plan import over_the_limit
    m = jobs.dropna(subset=["job_s"])
    if "variant" in m:
        keep = [over_the_limit(s, k in apart) for s, k in zip(m.job_s, zip(m.engine, m.case, m.variant.astype(str)))]
        m = m.assign(variant=m.variant.where(pd.Series(keep, index=m.index, dtype=bool), ""))
    else:
        m = m.assign(variant="")
    g = m.groupby(["engine", "case", "variant"], sort=False)
    return pd.DataFrame({"jobs": g.size(), "steps": g.steps.sum(), "stepping_s": g.wall_s.sum(),
                         "job_s": g.job_s.sum()}).reset_index()[TABLE_COLUMNS]


def merged(jobs: pd.DataFrame, table: pd.DataFrame) -> pd.DataFrame:
    """The table of the measured `jobs` (per_job), with the rows of `table` (an earlier one)
    for what they did not measure: the families they did not run, and the variants priced
    apart that they did not run (a job over the limit waits for --on-demand, so a default
    run does not measure it again). A variant `table` prices apart and the jobs measured
    again stays apart while over half the limit (per_family)."""
    table = _with_variant(table)
    last = per_family(jobs, priced_apart(table))
    ran = set(zip(jobs.engine, jobs.case, jobs.variant.astype(str)))
    families = set(zip(last.engine, last.case))
    keep = [(e, c) not in families if not v else (e, c, v) not in ran
            for e, c, v in zip(table.engine, table.case, table.variant)]
    rest = table[keep]
    return pd.concat([last, rest[TABLE_COLUMNS]], ignore_index=True) if len(rest) else last


def priced_apart(table: pd.DataFrame) -> frozenset:
    """The (engine, family, variant) of the rows of `table` priced per variant."""
    t = _with_variant(table)
    return frozenset((e, c, v) for e, c, v in zip(t.engine, t.case, t.variant) if v)


def _with_variant(table: pd.DataFrame) -> pd.DataFrame:
    """A table with its variant column (empty: a family's row; tables before it had none)."""
    variant = table["variant"].fillna("").astype(str) if "variant" in table else ""
    return table.assign(variant=variant)


def load_table(path: Path = TABLE) -> pd.DataFrame:
    """The shipped table (empty if absent)."""
    if not Path(path).is_file():
        return pd.DataFrame(columns=TABLE_COLUMNS)
    return _with_variant(pd.read_csv(path))


def write_table(table: pd.DataFrame, path: Path) -> None:
    write_atomic(path, table[TABLE_COLUMNS].to_csv(index=False, float_format="%.5g"))


@dataclass
class Model:
    """Per engine and family (and variant, where priced apart): seconds per step and
    seconds per job outside stepping (see the module's notes)."""
    per_step: dict        # (engine, case) or (engine, case, variant) -> seconds per step
    outside: dict         # (engine, case) or (engine, case, variant) -> seconds per job outside stepping
    engine_step: dict     # engine -> median seconds per step over its families
    engine_outside: dict  # engine -> median seconds per job outside stepping
    source: str

    @classmethod
    def of(cls, table: pd.DataFrame, source: str) -> "Model":
        t = _with_variant(table)
        t = t[(t.jobs > 0) & t.job_s.notna()]
        keys = [(e, c, v) if v else (e, c) for e, c, v in zip(t.engine, t.case, t.variant)]
        per_step = {k: (w / n if n > 0 else 0.0) for k, w, n in zip(keys, t.stepping_s, t.steps)}
        outside = {k: max(0.0, (j - w) / n) for k, j, w, n in zip(keys, t.job_s, t.stepping_s, t.jobs)}
        by_engine: dict[str, tuple[list, list]] = {}
        for k, v in per_step.items():
            if len(k) == 2:  # the engine's families (a variant priced apart is no family's typical cost)
                by_engine.setdefault(k[0], ([], []))[0].append(v)
                by_engine[k[0]][1].append(outside[k])
        return cls(per_step, outside, {e: float(np.median(a)) for e, (a, _) in by_engine.items()},
                   {e: float(np.median(b)) for e, (_, b) in by_engine.items()}, source)

    def predict(self, engine: str, case: str, steps: int, variant: str = "") -> tuple[float, str]:
        """(seconds, how: 'variant' measured apart, 'family' measured on this engine, 'engine'
        (its other families) or 'none')."""
        if (engine, case, variant) in self.per_step:
            return self.outside[(engine, case, variant)] + self.per_step[(engine, case, variant)] * steps, "variant"
        if (engine, case) in self.per_step:
            return self.outside[(engine, case)] + self.per_step[(engine, case)] * steps, "family"
        if engine in self.engine_step:
            return self.engine_outside[engine] + self.engine_step[engine] * steps, "engine"
        return math.nan, "none"


def model_for(out: Path | None) -> Model:
    """The model from the last run's results.csv in `out` where it recorded job_s, with the
    shipped table for the engines and families it did not hold."""
    table = load_table()
    source = "the table shipped with physval (a default run on 2 cores)"
    path = Path(out) / "results.csv" if out is not None else None
    if path is not None and path.is_file():
        try:
            last = per_job(pd.read_csv(path, usecols=lambda c: c in PER_JOB_COLUMNS))
        except (OSError, ValueError, KeyError):
            last = per_job([])
        last = priceable(last.dropna(subset=["job_s"]))
        if len(last):
            both = merged(last, table)
            source = f"the last run in {out}" + (" and the shipped table"
                                                 if len(both) > len(per_family(last, priced_apart(table))) else "")
            table = both
    return Model.of(table, source)


def predictor(resolver, model: Model):
    """job -> (its steps, predicted worker-seconds (NaN: not measured), how the table found
    it): a variant's steps are counted once, not once per engine."""
    from physval.core.jobs import steps_of
    steps: dict = {}

    def predict(job) -> tuple[int, float, str]:
        at = (job.family, job.variant.id, job.dt)
        if at not in steps:
            try:
                steps[at] = steps_of(job, resolver.family(job.family))
            except Exception:
                steps[at] = 0
        return (steps[at], *model.predict(job.engine, job.family, steps[at], job.variant.id))
    return predict


def pricer(resolver, model: Model):
    """A job's predicted cost in worker-seconds (NaN: not measured) and whether the table
    prices it apart (its variant's row), as physval.core.plan takes them (`price`) to hold
    back the jobs over its per-job limit."""
    predict = predictor(resolver, model)

    def price(job) -> tuple[float, bool]:
        _, seconds, how = predict(job)
        return seconds, how == "variant"
    return price


# --- before the run: the plan ----------------------------------------------------------------

def plan(jobs: list, resolver, model: Model) -> pd.DataFrame:
    """One row per planned job: engine, family, steps, predicted seconds and how found."""
    predict = predictor(resolver, model)
    rows = []
    for j in jobs:
        steps, s, how = predict(j)
        rows.append({"engine": j.engine, "case": j.family, "steps": steps, "predicted_s": s, "from": how})
    return pd.DataFrame(rows, columns=["engine", "case", "steps", "predicted_s", "from"])


def longest_first(jobs: list, resolver, model: Model) -> list:
    """The jobs, those predicted longest first (unpriced ones first of all: they may be
    long): on N workers the last jobs to start are then the short ones, so no worker waits
    long for another to finish its last. Order only: a job computes the same wherever and
    whenever it runs (but DART's history, decision 7)."""
    planned = plan(jobs, resolver, model)
    cost = planned.predicted_s.fillna(math.inf).to_numpy()
    order = sorted(range(len(jobs)), key=lambda i: -cost[i])
    return [jobs[i] for i in order]


def plan_summary(planned: pd.DataFrame, workers: int, by: str = "engine") -> pd.DataFrame:
    """Predicted worker-seconds per engine (or family), largest first, with the share of
    the run and the jobs whose cost is unknown."""
    if not len(planned):
        return pd.DataFrame(columns=[by, "jobs", "worker s", "share", "unpriced jobs"])
    g = planned.groupby(by, sort=False)
    out = pd.DataFrame({"jobs": g.size(), "worker s": g.predicted_s.sum(min_count=1).fillna(0.0),
                        "unpriced jobs": g.predicted_s.apply(lambda s: int(s.isna().sum()))}).reset_index()
    total = out["worker s"].sum()
    out["share"] = out["worker s"] / total if total else 0.0
    return out.sort_values("worker s", ascending=False, kind="stable")[[by, "jobs", "worker s", "share",
                                                                        "unpriced jobs"]]


def plan_text(planned: pd.DataFrame, workers: int, model: Model, readings: str = "") -> str:
    """What `physval run --plan` prints: the run's predicted cost per engine and its
    largest families, the wall time on `workers` workers, and the budget."""
    total = float(planned.predicted_s.sum())
    unpriced = int(planned.predicted_s.isna().sum())
    wall = total / max(1, workers)
    lines = [f"{len(planned)} jobs; predicted from {model.source}: {total:.0f} worker-seconds, "
             f"about {_minutes(wall)} on {workers} worker{'s' if workers != 1 else ''}"
             + (f"; {unpriced} jobs with no measured cost (not counted)" if unpriced else ""),
             f"budget of a default run: {_minutes(BUDGET_S)} on {BUDGET_WORKERS} cores "
             f"({BUDGET_S * BUDGET_WORKERS:.0f} worker-seconds): "
             + ("within it" if total <= BUDGET_S * BUDGET_WORKERS and not unpriced
                else f"{total / (BUDGET_S * BUDGET_WORKERS):.0%} of it" + (" before the unpriced jobs" if unpriced else ""))]
    if readings:
        lines.append(readings)
    if len(planned):  # (nothing to run: no tables of nothing)
        lines += ["", "per engine:", _text_table(plan_summary(planned, workers, "engine")), "",
                  "largest families:", _text_table(plan_summary(planned, workers, "case").head(12))]
    return "\n".join(lines)


def left_out(later) -> pd.DataFrame:
    """The runs a run left for --on-demand ((job, why) pairs, physval.core.plan), one row per
    engine and reason: how many, of which families."""
    rows: dict = {}
    for job, why in later:
        n, families = rows.setdefault((job.engine, why), [0, {}])
        rows[(job.engine, why)][0] = n + 1
        families[job.family] = None
    return pd.DataFrame([{"engine": e, "runs": n, "families": ", ".join(f), "why": why}
                         for (e, why), (n, f) in rows.items()], columns=["engine", "runs", "families", "why"])


def left_out_text(later) -> str:
    """`left_out` as lines: 'engine: n runs of families: why'."""
    return "\n".join(f"  {r.engine}: {r.runs} run{'s' if r.runs != 1 else ''} of {r.families}: {r.why}"
                     for r in left_out(later).itertuples())


def _minutes(s: float) -> str:
    return f"{s:.0f} s" if s < 120 else f"{s / 60:.1f} min"


def _text_table(df: pd.DataFrame) -> str:
    shown = df.copy()
    shown["worker s"] = shown["worker s"].map(lambda v: f"{v:.1f}")
    shown["share"] = shown["share"].map(lambda v: f"{v:.1%}")
    return shown.to_string(index=False)


# --- after the run: where the time went ------------------------------------------------------

@dataclass
class Phases:
    """The run's wall-clock phases and its workers' use, as physval run measured them."""
    planning_s: float = 0.0     # start to the first job handed out (imports, plan, store)
    pool_s: float = 0.0         # the workers' phase: first job to last result
    ahead_s: float = 0.0        # of the workers' time in it, compiling ahead beside the jobs (physval.core.ahead)
    report_started: float = math.nan  # time.monotonic() when the report began
    workers: int = 1
    jobs: int = 0               # the run's jobs run now
    job_s: float = 0.0          # their whole time in workers
    compile_s: float = 0.0      # of it, numba getting the reference's compiled code ready
    run_s: float = 0.0          # of it, their runs (stepping and recording each step)
    stepping_s: float = 0.0     # of that, the engines' steps
    reading_jobs: int = 0
    reading_s: float = 0.0      # the readings' jobs' time in workers
    worker_cpu_s: float = math.nan  # the workers' CPU, user + system (local workers)
    job_cpu_s: float = math.nan     # of it, in the jobs (the run's and the readings'): the rest is per-job overhead
    later: tuple = ()               # (job, why) of the runs left for --on-demand (physval.core.plan)

    @property
    def outside_s(self) -> float:
        """The workers' time in their phase outside any job or compiling (starting, idle,
        results in transit)."""
        return self.pool_s * self.workers - self.job_s - self.reading_s - self.ahead_s


COST_COLUMNS = ["kind", "name", "seconds", "of", "jobs", "steps", "us_per_step", "note"]


def measure(rows, phases: Phases | None = None) -> pd.DataFrame:
    """Where the run's time went: one row per phase (kind 'phase'; with `phases`), then one
    per engine (kind 'engine'): its jobs, steps, median us per step, and their whole time
    in workers (every job of the run, a reused one with the time it took then)."""
    import time
    out = []
    jobs = per_job(rows)
    if phases is not None:
        available = phases.pool_s * phases.workers
        outside = phases.outside_s
        n = phases.jobs + phases.reading_jobs

        report_s = time.monotonic() - phases.report_started if math.isfinite(phases.report_started) else math.nan
        out += [
            ("planning", phases.planning_s, "wall", math.nan, "imports, the plan, the results store; the workers "
                                                                "start meanwhile"),
            ("jobs and readings", phases.pool_s, "wall", n, f"on {phases.workers} workers: {available:.1f} "
                                                            "worker-seconds"),
            *([("compiling ahead", phases.ahead_s, "worker", math.nan,
                "the workers compiling, side by side and beside the other engines' jobs, what the run's engines "
                "compile on first use and the cache lacked (the reference's step: the first run after an install "
                "or an edit of reference_impl); that engine's jobs wait for it")] if phases.ahead_s else []),
            ("stepping", phases.stepping_s, "worker", phases.jobs, "the engines' own steps in the run's jobs"),
            floor_row(jobs),
            ("recording", phases.run_s - phases.stepping_s, "worker", phases.jobs,
             "each step's state (and contact forces where read) copied out, blow-up checks"),
            ("rest of the jobs", phases.job_s - phases.run_s, "worker", phases.jobs,
             f"building scenes and engines, observing, judging: {_ms(phases.job_s - phases.run_s, phases.jobs)} "
             "per job"),
            ("compiling", phases.compile_s, "worker", phases.jobs,
             "of the jobs' time (in their steps and builds), numba compiling the reference's code, loading it "
             "from its cache or waiting for another process compiling it: the first run after an install or an "
             "edit of reference_impl"),
            ("readings' jobs", phases.reading_s, "worker", phases.reading_jobs,
             "the engine-wide readings' jobs run now (cached per engine version)"),
            ("overhead", outside, "worker", n, f"workers outside any job (starting, idle, results in transit): "
                                               f"{_ms(outside, n)} per job"),
            ("all but stepping", outside + phases.job_s - phases.stepping_s, "worker", phases.jobs,
             f"the workers' time in the run beyond its steps (recording, the rest of the jobs, overhead): "
             f"{_ms(outside + phases.job_s - phases.stepping_s, phases.jobs)} per job"),
            ("report", report_s, "wall", math.nan, "the report's sections, plots and pages before this one"),
            ("CPU of the workers", phases.worker_cpu_s, "cpu", n, "user + system, their start included"),
            ("CPU outside any job", phases.worker_cpu_s - phases.job_cpu_s, "cpu", n,
             f"the workers' CPU beyond their jobs' (starting, taking jobs, sending rows): "
             f"{_ms(phases.worker_cpu_s - phases.job_cpu_s, n)} per job; unlike the overhead in worker time, "
             "no load on the machine inflates it"),
            ("CPU of the main process", time.process_time(), "cpu", math.nan,
             "user + system: planning, storing rows, the report so far"),
        ]
    df = pd.DataFrame([{"kind": "phase", "name": name, "seconds": sec, "of": of, "jobs": jobs, "steps": math.nan,
                        "us_per_step": math.nan, "note": note} for name, sec, of, jobs, note in out],
                      columns=COST_COLUMNS)
    if phases is not None and phases.later:  # kind 'later': the runs left for --on-demand, per engine and reason
        left = left_out(phases.later)
        df = pd.concat([df, pd.DataFrame({"kind": "later", "name": left.engine, "seconds": math.nan, "of": "",
                                          "jobs": left.runs, "steps": math.nan, "us_per_step": math.nan,
                                          "note": left.families + ": " + left.why})[COST_COLUMNS]],
                       ignore_index=True)
    stepped = jobs[jobs.steps > 0]
    if len(jobs):
        g = jobs.groupby("engine", sort=False)
        per_step = (stepped.wall_s / stepped.steps * 1e6).groupby(stepped.engine).median()
        eng = pd.DataFrame({"kind": "engine", "name": list(g.groups), "seconds": g.job_s.sum(min_count=1).values,
                            "of": "worker", "jobs": g.size().values, "steps": g.steps.sum().values,
                            "us_per_step": [per_step.get(e, math.nan) for e in g.groups],
                            "note": [f"{w:.1f} s stepping" for w in g.wall_s.sum().values]})
        eng = eng.sort_values("seconds", ascending=False, kind="stable", na_position="last")
        df = pd.concat([df, eng], ignore_index=True) if len(df) else eng.reset_index(drop=True)
    return df


def is_reference(engine: str) -> bool:
    """A formulation of the reference (reference_impl: physval's own code, which physval can make faster)."""
    return engine == "reference" or engine.startswith("reference-")


def floor_row(jobs: pd.DataFrame) -> tuple:
    """The Cost section's floor (decision 10: where an engine's own stepping is the floor,
    the report says so with figures): the steps of every engine but the reference's
    formulations, summed over all the run's jobs (those it reused at the time they took),
    against the default run's budget. No speed-up of physval's own code goes under it."""
    theirs = jobs[~jobs.engine.map(is_reference)] if len(jobs) else jobs
    seconds = float(theirs.wall_s.sum()) if len(theirs) else 0.0
    budget = BUDGET_S * BUDGET_WORKERS
    return ("engines' own steps", seconds, "worker", len(theirs),
            f"the steps of every engine but the reference's formulations (physval's own code), over all the run's "
            f"jobs: {_minutes(seconds / BUDGET_WORKERS)} of wall time on {BUDGET_WORKERS} cores before anything "
            f"else, {seconds / budget:.0%} of the default run's budget ({_minutes(BUDGET_S)}): the floor no "
            "speed-up of physval's code goes under")


def measured(rows, phases: Phases | None, out: Path) -> pd.DataFrame:
    """`measure` of a run as it ends (`phases` given), or, rebuilding a report from its
    folder (no phases), the engines measured again from the rows and the phases as the run
    wrote them in its cost.csv: a rebuilt report says where that run's time went."""
    df = measure(rows, phases)
    if phases is not None or not (Path(out) / "cost.csv").is_file():
        return df
    try:
        before = pd.read_csv(Path(out) / "cost.csv")
    except (OSError, ValueError, pd.errors.ParserError):
        return df
    if list(before.columns) != COST_COLUMNS:
        return df
    return pd.concat([before[before.kind.isin(["phase", "later"])], df], ignore_index=True)


def _ms(seconds: float, jobs: int) -> str:
    return f"{1e3 * seconds / jobs:.1f} ms" if jobs else "-"


def section(df: pd.DataFrame, out: Path | None = None) -> str:
    """The report's Cost section: the phases, then each engine's share."""
    if out is not None:
        write_atomic(Path(out) / "cost.csv", df.to_csv(index=False))
    phases, engines, later = df[df.kind == "phase"], df[df.kind == "engine"], df[df.kind == "later"]
    if not len(engines) and not len(phases):
        return ""
    lines = ["## Cost", "",
             "Where this run's time went (`physval/readings/cost.py`; also `cost.csv`). `physval run --plan` predicts a "
             "run's cost before it runs, per engine and family; `physval bench run` times the default run cold and "
             "warm.", ""]
    if len(phases):
        lines += ["Wall-clock phases, and within the jobs' phase the workers' time: the engines' steps, the rest "
                  "of each job, the readings' jobs (which share the workers with the run's) and what the workers "
                  "spent outside any job.", "",
                  md_table(pd.DataFrame({"where": phases.name, "seconds": phases.seconds.map(fmt),
                                         "of": phases["of"].map({"wall": "wall clock", "worker": "worker time", "cpu": "CPU time"}),
                                         "note": phases.note})), ""]
    if len(engines):
        total = engines.seconds.sum()
        lines += ["Per engine: its jobs' whole time in a worker (building, stepping, recording, judging) and its "
                  "steps' median cost.", "",
                  md_table(pd.DataFrame({
                      "engine": engines.name, "worker s": engines.seconds.map(fmt),
                      "share": (engines.seconds / total).map(lambda v: f"{v:.1%}" if v == v else "") if total else "",
                      "jobs": engines.jobs.astype(int), "steps": engines.steps.astype("Int64"),
                      "us per step (median over jobs)": engines.us_per_step.map(fmt), "stepping": engines.note})), ""]
    if len(later):
        lines += [f"Runs left for --on-demand ({int(later.jobs.sum())}; `physval run --on-demand` runs them):", "",
                  md_table(pd.DataFrame({"engine": later.name, "runs": later.jobs.astype(int),
                                         "families: why": later.note})), ""]
    return "\n".join(lines)
