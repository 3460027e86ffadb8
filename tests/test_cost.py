"""The run's cost model: `physval run --plan` predicts per engine and family from measured
per-job costs (and counts an engine it has never measured apart), the report's Cost
section says where the time went, and `physval bench run` times a run cold and warm."""
from __future__ import annotations

import csv
import math
from pathlib import Path

import pandas as pd
import pytest

from physval.cli import main
from physval.readings import cost

ROOT = Path(__file__).resolve().parent.parent
FAKES = str(ROOT / "tests" / "fakes.py")
QUIET = ["--workers", "1", "--quiet"]


def test_a_job_costs_its_engines_time_outside_stepping_plus_its_steps_at_the_measured_rate():
    """2 jobs of 1000 steps took 3 s, 2 of them stepping: 1 ms a step and 0.5 s a job
    outside; a 500-step job of the family costs 1 s, of another family on that engine the
    engine's median, and on an engine never measured nothing known."""
    table = pd.DataFrame([{"engine": "e", "case": "c", "jobs": 2, "steps": 2000, "stepping_s": 2.0, "job_s": 3.0}])
    model = cost.Model.of(table, "a test")
    assert model.predict("e", "c", 500) == (1.0, "family")
    assert model.predict("e", "other", 500) == (1.0, "engine")
    s, how = model.predict("new", "c", 500)
    assert math.isnan(s) and how == "none"


def test_the_plan_prices_from_the_last_run_counts_an_unmeasured_engine_apart_and_changes_nothing(tmp_path, capsys):
    out = tmp_path / "out"
    engines = ["--adapter", f"{FAKES}:OtherFake", "--adapter", f"{FAKES}:HistoryFake"]
    assert main(["run", *engines, "--engines", "fake-2", "--cases", "central_impact", *QUIET, "--out", str(out)]) == 0
    capsys.readouterr()
    before = (out / "results.csv").read_bytes()
    assert main(["run", "--plan", *engines, "--engines", "fake-2,fake-history", "--cases",
                 "central_impact,incline_threshold", *QUIET, "--out", str(out)]) == 0
    text = capsys.readouterr().out
    assert (out / "results.csv").read_bytes() == before, "--plan runs nothing and rewrites nothing"
    assert f"predicted from the last run in {out}" in text
    lines = {line.split()[0]: line.split() for line in text.splitlines() if line.strip().startswith("fake-")}
    n_incline = len(__import__("physval.core", fromlist=["Context"]).Context().resolver()
                    .family("incline_threshold").variants)
    assert lines["fake-2"][1] == str(n_incline) and float(lines["fake-2"][2]) > 0 and lines["fake-2"][4] == "0"
    assert float(lines["fake-history"][2]) == 0 and int(lines["fake-history"][4]) == int(lines["fake-history"][1]) > 0
    assert "finished before" in text and "jobs with no measured cost (not counted)" in text


def test_a_plan_with_nothing_left_to_run_says_so_without_empty_tables():
    """Every job finished before: one line says 0 jobs, and no per-engine or per-family table of
    nothing follows (it printed pandas' 'Empty DataFrame')."""
    table = pd.DataFrame([{"engine": "e", "case": "c", "jobs": 2, "steps": 2000, "stepping_s": 2.0, "job_s": 3.0}])
    nothing = pd.DataFrame(columns=["engine", "case", "predicted_s", "how"])
    text = cost.plan_text(nothing, 2, cost.Model.of(table, "a test"))
    assert text.startswith("0 jobs; predicted from a test: 0 worker-seconds")
    assert "Empty DataFrame" not in text and "per engine:" not in text


def test_the_report_says_where_the_time_went_and_the_parts_add_up(tmp_path):
    out = tmp_path / "out"
    assert main(["run", "--adapter", f"{FAKES}:OtherFake", "--engines", "fake-2", "--cases", "central_impact",
                 *QUIET, "--out", str(out)]) == 0
    assert "## Cost" in (out / "report.md").read_text()
    parts = pd.read_csv(out / "cost.csv")
    phase = dict(zip(parts[parts.kind == "phase"].name, parts[parts.kind == "phase"].seconds))
    assert {"planning", "jobs and readings", "stepping", "recording", "rest of the jobs", "readings' jobs", "overhead",
            "report",
            "CPU of the workers", "CPU outside any job", "CPU of the main process"} <= set(phase)
    assert 0 <= phase["CPU outside any job"] < phase["CPU of the workers"]
    jobs = {r["job"]: r for r in csv.DictReader(open(out / "results.csv"))}
    job_s = sum(float(r["job_s"]) for r in jobs.values())
    stepping = sum(float(r["wall_s"] or 0) for r in jobs.values())
    assert math.isclose(phase["stepping"] + phase["recording"] + phase["rest of the jobs"], job_s, rel_tol=1e-6)
    assert phase["recording"] > 0 and phase["rest of the jobs"] > 0
    assert math.isclose(phase["stepping"], stepping, rel_tol=1e-6) and 0 < stepping < job_s
    assert math.isclose(phase["overhead"], 1 * phase["jobs and readings"] - job_s, rel_tol=1e-6, abs_tol=1e-9)
    (engine,) = parts[parts.kind == "engine"].itertuples()
    assert engine.name == "fake-2" and engine.jobs == len(jobs)


def test_bench_run_times_a_run_cold_then_warm_and_writes_the_cost_table(tmp_path):
    out = tmp_path / "bench"
    assert main(["bench", "run", "--adapter", f"{FAKES}:OtherFake", "--engines", "fake-2", "--cases",
                 "central_impact[e=0.5,m=1:*]", "--workers", "1", "--quiet", "--out", str(out)]) == 0
    df = pd.read_csv(out / "bench_run.csv")
    assert list(df.columns[:5]) == ["kind", "name", "of", "cold s", "warm s"]
    whole = df[df.kind == "whole"].iloc[0]
    assert whole["cold s"] > 0 and whole["warm s"] > 0
    assert set(df[df.kind == "engine"].name) == {"fake-2"}
    table = pd.read_csv(out / "costs.csv")
    assert list(table.columns) == cost.TABLE_COLUMNS and set(table.engine) == {"fake-2"} and table.jobs.sum() > 0
    assert "## run" in (out / "bench.md").read_text()


# --- the per-job limit: a job measured over it waits for --on-demand (physval.core.plan) --------

def _grasp_table(slow_variant: str, seconds: float) -> pd.DataFrame:
    """A synthetic cost table: reference-lemke's pinch_grasp measured per family at 0.1 s a
    job, and one variant measured apart at `seconds` (400 steps a job)."""
    return pd.DataFrame([
        {"engine": "reference-lemke", "case": "pinch_grasp", "variant": "", "jobs": 2, "steps": 800,
         "stepping_s": 0.18, "job_s": 0.2},
        {"engine": "reference-lemke", "case": "pinch_grasp", "variant": slow_variant, "jobs": 1, "steps": 400,
         "stepping_s": seconds - 0.01, "job_s": seconds}])


def test_a_job_measured_over_the_per_job_limit_waits_for_on_demand_and_its_family_stays():
    """One variant of a family measured at 60 s a job (over the 15 s limit) waits for
    --on-demand with the reason stated; the family's other variants, priced by the family's
    row, run; --on-demand runs it; an engine named runs it only with --on-demand too. Priced
    apart, it keeps waiting under the limit down to half of it (the hysteresis), and says so."""
    from physval.core import Context
    from physval.core.plan import PER_JOB_LIMIT_S, plan
    resolver = Context().resolver()
    variants = list(resolver.family("pinch_grasp").variants)
    slow = variants[-1]
    price = cost.pricer(resolver, cost.Model.of(_grasp_table(slow.id, 60.0), "a test"))
    for named in (False, True):
        jobs, later = plan({"pinch_grasp": variants}, ["reference-lemke"], resolver, named, price=price)
        assert [(j.variant.id, why) for j, why in later] == [
            (slow.id, f"waits for --on-demand: measured 60 s a job, over the per-job limit {PER_JOB_LIMIT_S:.0f} s "
                      "(priced apart: it runs again when measured under half of it, 7.5 s)")]
        assert {j.variant.id for j in jobs} == {v.id for v in variants} - {slow.id}
    jobs, later = plan({"pinch_grasp": variants}, ["reference-lemke"], resolver, False, on_demand=True, price=price)
    assert not later and {j.variant.id for j in jobs} == {v.id for v in variants}
    # priced apart and measured just under the limit: it still waits, until under half of it
    price = cost.pricer(resolver, cost.Model.of(_grasp_table(slow.id, 0.9 * PER_JOB_LIMIT_S), "a test"))
    later = plan({"pinch_grasp": variants}, ["reference-lemke"], resolver, False, price=price)[1]
    assert [(j.variant.id, why) for j, why in later] == [
        (slow.id, "waits for --on-demand: measured 13.5 s a job, under the per-job limit 15 s but priced apart "
                  "(once over it): it runs again when measured under half of it, 7.5 s")]
    price = cost.pricer(resolver, cost.Model.of(_grasp_table(slow.id, 0.45 * PER_JOB_LIMIT_S), "a test"))
    assert not plan({"pinch_grasp": variants}, ["reference-lemke"], resolver, False, price=price)[1]


def test_a_finished_job_is_not_held_back_by_its_measured_cost(tmp_path, monkeypatch, capsys):
    """A job whose rows the run's store holds costs the run nothing, so the per-job limit
    spares it: measured over the limit in one run (the engine's import in a fresh worker, a
    loaded machine), it stays in the next and its rows are reused, not dropped from the store
    and the report (Genesis' 2D impacts, measured at 14.5-64 s a job beside a test suite, left
    the next run's report and were stepped again by the one after)."""
    from physval.core import Context
    from physval.core.plan import plan
    resolver = Context().resolver()
    variants = list(resolver.family("pinch_grasp").variants)
    slow = variants[-1]
    price = cost.pricer(resolver, cost.Model.of(_grasp_table(slow.id, 60.0), "a test"))
    key = next(j.key for j in plan({"pinch_grasp": variants}, ["reference-lemke"], resolver, False, on_demand=True)[0]
               if j.variant.id == slow.id)
    jobs, later = plan({"pinch_grasp": variants}, ["reference-lemke"], resolver, False, price=price,
                       finished=frozenset({key}))
    assert not later and {j.variant.id for j in jobs} == {v.id for v in variants}
    # through the command: a job in --out, priced at 60 s by the model, is reused, not left out
    out = tmp_path / "out"
    argv = ["run", "--cases", "central_impact[drop,e=0.5]", "--engines", "reference", "--readings", "none",
            "--workers", "1", "--out", str(out)]
    assert main(argv) == 0
    capsys.readouterr()
    table = pd.DataFrame([{"engine": "reference", "case": "central_impact", "variant": "drop,e=0.5", "jobs": 1,
                           "steps": 100, "stepping_s": 59.9, "job_s": 60.0}])
    monkeypatch.setattr(cost, "model_for", lambda out: cost.Model.of(table, "a test"))
    assert main(argv) == 0
    err = capsys.readouterr().err
    assert "0 to run" in err and "on-demand" not in err, err
    assert len(list(csv.DictReader(open(out / "results.csv")))) > 0


def test_the_per_job_limit_has_hysteresis_so_a_job_measured_near_it_stays_in_or_out():
    """A job measured between L/2 and L (Lemke's grasp at mu 1.02: 7.6 s a job in a quiet run,
    17.1 s in a loaded one) moves in or out of the default run only across that band: a new
    job waits only over L; one priced apart (the table's row of its variant) waits while
    over L/2. The table written from each regeneration (cost.merged, as `physval bench run`
    writes it) keeps a job apart by the same rule, so quiet and loaded measurements that
    alternate leave it where it was."""
    from physval.core.plan import PER_JOB_LIMIT_S as L, leaves_out
    from tests.fakes import FakeAdapter
    from tests.helpers import variant_scene
    slide, _ = variant_scene("slide_to_stop", "mu=0.5,v0=2")

    def waits(seconds: float, apart: bool) -> bool:
        return leaves_out(FakeAdapter(), frozenset({"friction"}), slide, cost=seconds, apart=apart) is not None

    quiet, loaded, fast = 7.6 / 15 * L, 17.1 / 15 * L, 0.45 * L
    assert not waits(quiet, False) and waits(loaded, False) and not waits(L, False), "new: over L"
    assert waits(quiet, True) and waits(loaded, True) and not waits(fast, True), "priced apart: over L/2"

    def run(seconds: float) -> pd.DataFrame:  # one regeneration's measured jobs: a fast variant and the one near L
        return pd.DataFrame([{"job": "a", "engine": "e", "case": "c", "variant": "fast", "steps": 100,
                              "wall_s": 0.5, "job_s": 0.6},
                             {"job": "b", "engine": "e", "case": "c", "variant": "near", "steps": 100,
                              "wall_s": seconds - 0.1, "job_s": seconds}])

    table = cost.per_family(run(quiet))
    history = []
    for seconds in (quiet, loaded, quiet, loaded, quiet, fast, quiet):
        table = cost.merged(run(seconds), table)
        history.append(bool(cost.priced_apart(table)))
    # in (under L, new) -> out (over L) -> stays out while over L/2 -> in (under L/2) -> stays in under L
    assert history == [False, True, True, True, True, False, False]
    assert cost.priced_apart(cost.merged(run(loaded), table)) == {("e", "c", "near")}


def test_the_table_prices_a_job_over_the_limit_apart_and_keeps_it_until_measured_again():
    """per_family puts a job over the limit in its own row (its variant), so the family's row
    prices the others; merged keeps an earlier table's variant row while a run does not
    measure that variant again (a default run leaves it for --on-demand), and drops it when
    one does."""
    jobs = pd.DataFrame([{"job": "a", "engine": "e", "case": "c", "variant": "fast", "steps": 100, "wall_s": 0.5,
                          "job_s": 0.6},
                         {"job": "b", "engine": "e", "case": "c", "variant": "slow", "steps": 100, "wall_s": 30.0,
                          "job_s": 31.0}])
    table = cost.per_family(jobs)
    assert sorted(zip(table.variant, table.jobs, table.job_s)) == [("", 1, 0.6), ("slow", 1, 31.0)]
    model = cost.Model.of(table, "a test")
    assert model.predict("e", "c", 100, "slow") == (pytest.approx(31.0), "variant")
    assert model.predict("e", "c", 100, "fast") == (pytest.approx(0.6), "family")
    assert model.predict("e", "other", 100) == (pytest.approx(0.6), "engine"), "a variant apart is no family's cost"
    default_run = jobs[jobs.variant == "fast"].assign(job_s=0.7)
    kept = cost.merged(default_run, table)
    assert sorted(zip(kept.variant, kept.job_s)) == [("", 0.7), ("slow", 31.0)]
    again = cost.merged(jobs.assign(job_s=[0.7, 2.0]), table)
    assert sorted(zip(again.variant, again.jobs, again.job_s)) == [("", 2, 2.7)]


def test_the_runs_left_for_on_demand_are_said_per_engine_with_why_in_the_plan_and_the_cost_section():
    from physval.core import Context
    from physval.core.plan import plan
    resolver = Context().resolver()
    variants = list(resolver.family("pinch_grasp").variants)
    price = cost.pricer(resolver, cost.Model.of(_grasp_table(variants[-1].id, 60.0), "a test"))
    _, later = plan({"pinch_grasp": variants}, ["reference-lemke"], resolver, False, price=price)
    text = cost.left_out_text(later)
    assert text == ("  reference-lemke: 1 run of pinch_grasp: waits for --on-demand: measured 60 s a job, over the "
                    "per-job limit 15 s (priced apart: it runs again when measured under half of it, 7.5 s)")
    section = cost.section(cost.measure([], cost.Phases(later=tuple(later))))
    assert "Runs left for --on-demand (1;" in section and "measured 60 s a job" in section


def test_one_rule_says_what_a_run_leaves_out_and_why():
    """physval.core.plan.leaves_out, which plan, relation_jobs and the tests that follow a
    default run call: a family outside the engine's default tags is out unless the engine is
    named (its compliant-law variants in, with default_laws), even on demand; a run the
    engine declares on demand, or one measured over the limit, waits for --on-demand."""
    from dataclasses import replace
    from physval.core.plan import PER_JOB_LIMIT_S, leaves_out
    from tests.fakes import CoreOnDemandFake, FakeAdapter
    from tests.helpers import variant_scene
    plain, core = FakeAdapter(), CoreOnDemandFake()
    slide, _ = variant_scene("slide_to_stop", "mu=0.5,v0=2")
    hooke, _ = variant_scene("hertz_impact", "r=0.1:0.05,hooke")
    other, mine = frozenset({"friction"}), frozenset({"core"})
    assert leaves_out(plain, other, slide) is None
    assert "runs the families tagged core unless named" in leaves_out(core, other, slide, on_demand=True)
    assert leaves_out(core, other, slide, named=True) == "waits for --on-demand: " + core.on_demand(slide)
    assert leaves_out(core, other, slide, named=True, on_demand=True) is None
    assert leaves_out(core, mine, slide) is None, "its default families run in every run"
    core.capabilities = replace(core.capabilities, contact_laws=frozenset({"hooke"}))
    assert leaves_out(core, other, hooke, on_demand=True) is None, "a variant of a law it models (default_laws)"
    core.default_laws = False
    assert leaves_out(core, other, hooke, on_demand=True) is not None
    assert leaves_out(plain, other, slide, cost=PER_JOB_LIMIT_S) is None
    assert "over the per-job limit" in leaves_out(plain, other, slide, cost=PER_JOB_LIMIT_S + 1)
    assert leaves_out(plain, other, slide, cost=PER_JOB_LIMIT_S + 1, on_demand=True) is None


def test_a_job_that_compiled_the_reference_or_started_its_engine_prices_nothing_and_the_earlier_price_stays(
        tmp_path):
    """The last run's jobs price the next run, except those that spent time compiling the
    reference (compile_s > 0: a first run after installing or editing reference_impl) and
    those that were their engine's first in their worker (first_in_worker: the engine's
    import and kernel compiles): a family's price is its other jobs', and a variant priced
    apart whose job compiled keeps the table's earlier price (its compile would put it over
    the per-job limit)."""
    table = pd.DataFrame([{"engine": "e", "case": "c", "variant": "", "jobs": 2, "steps": 200, "stepping_s": 1.0,
                           "job_s": 1.2},
                          {"engine": "e", "case": "c", "variant": "slow", "jobs": 1, "steps": 100,
                           "stepping_s": 9.9, "job_s": 10.0}])
    with open(tmp_path / "results.csv", "w", newline="") as fh:
        w = csv.DictWriter(fh, ["job", "engine", "case", "variant", "steps", "wall_s", "job_s", "compile_s",
                                "first_in_worker"])
        w.writeheader()
        w.writerows([{"job": "a", "engine": "e", "case": "c", "variant": "v1", "steps": 100, "wall_s": 95.0,
                      "job_s": 96.0, "compile_s": 95.2, "first_in_worker": 0},   # compiled in its first step
                     {"job": "b", "engine": "e", "case": "c", "variant": "v2", "steps": 100, "wall_s": 0.5,
                      "job_s": 0.6, "compile_s": 0.0, "first_in_worker": 0},
                     {"job": "c", "engine": "e", "case": "c", "variant": "slow", "steps": 100, "wall_s": 40.0,
                      "job_s": 41.0, "compile_s": 31.0, "first_in_worker": 0},
                     {"job": "d", "engine": "e", "case": "c", "variant": "v3", "steps": 100, "wall_s": 0.5,
                      "job_s": 14.6, "compile_s": 0.0, "first_in_worker": 1}])  # the engine's import
    import unittest.mock as mock
    with mock.patch.object(cost, "load_table", return_value=table):
        model = cost.model_for(tmp_path)
    assert model.predict("e", "c", 100, "v1") == (pytest.approx(0.6), "family")
    assert model.predict("e", "c", 100, "slow") == (pytest.approx(10.0), "variant")
    jobs = cost.per_job(pd.read_csv(tmp_path / "results.csv"))
    assert list(cost.priceable(jobs).job) == ["b"]
    assert list(cost.priceable(jobs.drop(columns=["compile_s", "first_in_worker"])).job) == ["a", "b", "c", "d"], \
        "rows from before compile_s and first_in_worker"


def test_a_jobs_rows_carry_the_seconds_it_spent_compiling_the_reference(monkeypatch):
    """perform reads reference_impl.compiled.compiling_seconds before and after a job: what
    the job spent getting the reference's code ready is its rows' compile_s (here a clock
    that a compile of 2.5 s moves during the job), and a job that compiled nothing has 0."""
    import sys
    import types

    from physval.core import Context
    from physval.core.jobs import Job, perform
    clock = types.SimpleNamespace(seconds=10.0)
    fake = types.ModuleType("reference_impl.compiled")
    fake.compiling_seconds = lambda: clock.seconds
    monkeypatch.setitem(sys.modules, "reference_impl.compiled", fake)
    resolver = Context().resolver()
    fam = resolver.family("central_impact")
    variant = fam.variants[0]
    import physval.core.jobs as jobs_module
    execute = jobs_module.execute

    def compiling(job, res):
        clock.seconds += 2.5 if job.engine == "mujoco" else 0.0
        return execute(job, res)
    monkeypatch.setattr(jobs_module, "execute", compiling)
    for engine, seconds in (("mujoco", 2.5), ("reference", 0.0)):
        rows = perform(Job(fam.name, variant, engine, fam.dt_for(variant.params)), resolver).rows
        assert rows and {r["compile_s"] for r in rows} == {seconds}, engine


def test_the_first_job_of_an_engine_in_a_process_is_marked_as_such(monkeypatch):
    """perform marks the rows of the first job of each engine it runs (first_in_worker 1:
    its time holds the engine's start), and those of the engine's later jobs 0."""
    from physval.core import Context
    import physval.core.jobs as jobs_module
    monkeypatch.setattr(jobs_module, "_engines_started", set())
    resolver = Context().resolver()
    fam = resolver.family("central_impact")
    marks = []
    for engine, variant in (("reference", fam.variants[0]), ("mujoco", fam.variants[0]),
                            ("reference", fam.variants[1]), ("mujoco", fam.variants[1])):
        rows = jobs_module.perform(jobs_module.Job(fam.name, variant, engine, fam.dt_for(variant.params)), resolver).rows
        marks.append({r["first_in_worker"] for r in rows})
    assert marks == [{1}, {1}, {0}, {0}]


def test_a_variant_priced_apart_is_measured_again_by_the_cost_table_writer(tmp_path):
    """`physval bench run` writes the table from a default run, which leaves a variant priced
    apart for --on-demand: measured_apart runs it on its own, so its price is measured afresh
    (the earlier table's 125 s for a Lemke grasp stayed for good; it runs in 2-7 s now)."""
    import os
    from physval.readings.bench import measured_apart
    apart = pd.DataFrame([{"engine": "reference", "case": "central_impact", "variant": "drop,e=0.5", "jobs": 1,
                           "steps": 1, "stepping_s": 99.0, "job_s": 99.0}])
    env = {**os.environ, "PHYSVAL_CACHE_DIR": str(tmp_path / "cache")}
    again = measured_apart(apart, 1, tmp_path / "runs", env)
    assert list(zip(again.engine, again.case, again.variant)) == [("reference", "central_impact", "drop,e=0.5")]
    assert 0 < again.job_s.iloc[0] < 99.0 and again.steps.iloc[0] > 1
    table = cost.merged(again, apart)  # under half the per-job limit: priced with its family again
    assert list(table.variant) == [""] and table.job_s.iloc[0] == again.job_s.iloc[0]


def test_the_cost_section_states_the_engines_own_steps_as_the_floor():
    """Decision 10: the run's Cost section says how much of the budget the engines' own steps
    take before anything physval does; the reference's formulations are physval's own code,
    so they are not part of that floor."""
    rows = [{"job": "a", "engine": "drake", "case": "c", "variant": "v", "steps": 100, "wall_s": 300.0, "job_s": 320.0},
            {"job": "b", "engine": "mujoco", "case": "c", "variant": "v", "steps": 100, "wall_s": 60.0, "job_s": 61.0},
            {"job": "c", "engine": "reference-lemke", "case": "c", "variant": "v", "steps": 100, "wall_s": 500.0,
             "job_s": 510.0},
            {"job": "d", "engine": "reference", "case": "c", "variant": "v", "steps": 100, "wall_s": 40.0,
             "job_s": 41.0}]
    df = cost.measure(rows, cost.Phases(workers=2))
    (floor,) = df[(df.kind == "phase") & (df.name == "engines' own steps")].itertuples()
    assert floor.seconds == 360.0 and floor.jobs == 2
    assert "3.0 min of wall time on 2 cores" in floor.note and "100% of the default run's budget" in floor.note
