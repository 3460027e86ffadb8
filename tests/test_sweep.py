"""The sweep: points, batching for a cluster, streaming and resuming without losing or
redoing a point, a tiny sweep on a Dask LocalCluster, and the Pareto front and
convergence order on data whose answer is known."""
from __future__ import annotations

import math

import numpy as np
import pandas as pd
import pytest

from physval.core import Context, Job, execute, run_jobs
from physval.core.executor import MIN_BATCH_STEPS, DaskExecutor
from physval.core.session import Execution, run_stored
from physval.readings import sweep
from physval.readings.sweep import SWEEP_COLUMNS, convergence_order, pareto_front, point_table, write_report

RESOLVER = Context().resolver()
FAMS = RESOLVER.families
QUIET = Execution(progress=False)


def _tiny_points(family="central_impact", variant="e=0.5,m=1:3"):
    fam = FAMS[family]
    v = next(v for v in fam.variants if v.id == variant)
    return [Job(family, v, "reference", dt, None, probe="physval.readings.sweep:Timing", probe_args=(("repeats", 2),),
                warmup=10) for dt in (1 / 60, 1 / 240, 1e-3)]


def test_default_points_cover_six_time_steps_and_five_iteration_counts():
    chosen = sweep.sweep_variants(FAMS, ["resting_blocks"])
    pts = sweep.points(chosen, ["reference"], RESOLVER)
    dts = {p.dt for p in pts if p.iterations is None}
    its = {p.iterations for p in pts if p.iterations is not None}
    assert len(dts) >= 6 and max(dts) == pytest.approx(1 / 60) and min(dts) == pytest.approx(1e-4)
    assert len(its) >= 5
    assert len({p.key for p in pts}) == len(pts)


def test_an_accuracy_target_is_an_axis_of_its_own_at_the_family_dt(monkeypatch):
    """An engine whose Tunable names sweep values (Drake's CENIC: its accuracy target) gets a
    point per value at the family's dt and default iterations; the others get none."""
    import copy
    from adapters.base import Tunable
    fake = copy.copy(RESOLVER.adapter("reference"))
    fake.tunables = {**fake.tunables, "accuracy": Tunable(1e-9, 1.0, 1e-3, "error target", sweep=(1e-2, 1e-4))}
    plain = sweep.points(sweep.sweep_variants(FAMS, ["central_impact"]), ["reference"], RESOLVER)
    monkeypatch.setattr(RESOLVER, "adapter", lambda name: fake)
    pts = sweep.points(sweep.sweep_variants(FAMS, ["central_impact"]), ["reference"], RESOLVER)
    swept = [p for p in pts if p.options]
    assert not any(p.options for p in plain) and len(pts) == len(plain) + len(swept)
    assert {p.options for p in swept} == {(("accuracy", 1e-2),), (("accuracy", 1e-4),)}
    assert all(p.dt == FAMS[p.family].dt_for(p.variant.params) and p.iterations is None for p in swept)
    assert len({p.key for p in pts}) == len(pts)
    assert {sweep.setting_of(p.options) for p in swept} == {"accuracy=0.01", "accuracy=0.0001"}
    assert sweep.setting_of(()) == sweep.DEFAULT_SETTING


def test_cluster_batches_hold_enough_steps_to_outweigh_scheduling():
    pts = sweep.points(sweep.sweep_variants(FAMS, ["central_impact"]), ["reference"], RESOLVER)
    ex = DaskExecutor.__new__(DaskExecutor)  # batching needs no connection
    ex.ctx = Context()
    tasks = ex.batches(pts)
    assert sum(len(t) for t in tasks) == len(pts)
    from physval.core import steps_of
    for t in tasks[:-1]:
        assert sum(steps_of(p, FAMS[p.family]) * (1 + sweep.REPEATS) for p in t) >= MIN_BATCH_STEPS


def test_a_point_records_errors_and_the_minimum_of_its_repeats():
    (p, *_) = _tiny_points()
    rows = execute(p, RESOLVER)
    r = {**rows.rows[0], **rows.extra}
    walls = eval(r["repeat_wall_s"])
    # repeat_wall_s keeps each wall to 1e-9 s (sweep.py rounds it to 9 decimals), so the minimum
    # read back is within 0.5e-9 s of the one wall_per_sim_s was computed from: for walls of
    # 15 us that is 3e-5 of the value, above approx's default 1e-6 (a fresh clone's suite failed so)
    sim_s = (r["steps"] - r["warmup_steps"]) * p.dt
    assert len(walls) == 2 and r["wall_per_sim_s"] == pytest.approx(min(walls) / sim_s, rel=0, abs=0.5e-9 / sim_s)
    assert {x["status"] for x in rows.rows} == {"pass"} and r["iterations_asked"] == "default"


def test_an_interrupted_sweep_resumes_without_losing_or_redoing_points(tmp_path, monkeypatch):
    path = tmp_path / "sweep.csv"
    points = _tiny_points()
    res, _ = run_stored(points[:2], Context(), path, SWEEP_COLUMNS, QUIET)
    assert res.ran == 2
    # a kill in the middle of writing the third point: half a line at the end of the file
    with open(path, "a") as fh:
        fh.write("central_impact,e=0.5,m=1:3,{},reference,0.0,0.001,")
    res, store = run_stored(points, Context(), path, SWEEP_COLUMNS, QUIET)
    assert (res.ran, res.reused) == (1, 2)
    df = pd.read_csv(path)
    assert sorted(df.job.unique()) == sorted(p.key for p in points)
    assert len(df) == 4 * len(points)  # four checks per point, each point once
    res, _ = run_stored(points, Context(), path, SWEEP_COLUMNS, QUIET)
    assert (res.ran, res.reused) == (0, 3)


def test_a_changed_code_fingerprint_recomputes_the_stored_points(tmp_path, monkeypatch):
    path = tmp_path / "sweep.csv"
    points = _tiny_points()[:1]
    run_stored(points, Context(), path, SWEEP_COLUMNS, QUIET)
    from physval.core import store
    monkeypatch.setattr(store, "fingerprint", lambda extra=(): "0123456789abcdef")
    res, _ = run_stored(points, Context(), path, SWEEP_COLUMNS, QUIET)
    assert (res.ran, res.reused) == (1, 0)


def test_a_tiny_sweep_on_a_dask_local_cluster():
    distributed = pytest.importorskip("distributed")
    with distributed.LocalCluster(n_workers=1, threads_per_worker=1, processes=False,
                                  dashboard_address=None) as cluster:
        points = _tiny_points()  # workers find built-in families by name
        res = run_jobs(points, Context(), scheduler=cluster.scheduler_address, progress=False)
    assert set(res.rows) == {p.key for p in points}
    assert {r["status"] for rows in res.rows.values() for r in rows} == {"pass"}
    assert all(rows[0]["wall_per_sim_s"] > 0 for rows in res.rows.values())


def _synthetic(order: float) -> pd.DataFrame:
    dts = np.array([1 / 60, 1 / 120, 1 / 240, 1e-3, 3e-4, 1e-4])
    return pd.DataFrame({"dt": dts, "iterations": "default", "worst_over_tol": 3.0 * dts**order,
                         "cost_us_per_sim_s": 50.0 / dts, "status": "ok"})


@pytest.mark.parametrize("order", [1.0, 2.0, 0.5])
def test_convergence_order_is_the_slope_of_log_error_against_log_dt(order):
    assert convergence_order(_synthetic(order)) == pytest.approx(order, rel=1e-9)


def test_exact_results_have_no_order():
    pts = _synthetic(1.0)
    pts["worst_over_tol"] = 0.0
    assert math.isnan(convergence_order(pts))


def test_pareto_front_keeps_only_the_cheapest_way_to_each_accuracy():
    pts = pd.DataFrame({"cost_us_per_sim_s": [1, 2, 3, 4, 5], "worst_over_tol": [10, 12, 5, 5, 1],
                        "dt": 1e-3, "iterations": "default", "status": "ok"})
    front = pareto_front(pts)
    assert list(front.cost_us_per_sim_s) == [1, 3, 5]


def test_the_report_answers_in_a_sentence_per_case(tmp_path):
    res, store = run_stored(_tiny_points(), Context(), tmp_path / "sweep.csv", SWEEP_COLUMNS, QUIET)
    rows = store.finalize([p.key for p in _tiny_points()])
    write_report(rows, FAMS, tmp_path)
    md = (tmp_path / "sweep_report.md").read_text()
    assert "to reach the case's tolerances it needs dt <=" in md
    assert md.index("## Summary") < md.index("## Answers")  # one screen before the detail
    assert (tmp_path / "plots" / "cost_central_impact_e_0.5_m_1_3.png").exists()
    assert len(point_table(pd.DataFrame(rows), FAMS)) == 3


@pytest.mark.parametrize("engines", [["fake-crash"], ["fake-crash", "reference"]])
def test_a_variant_whose_points_all_failed_is_reported_and_plotted_without_them(engines, tmp_path):
    """An engine that raises in every run: its points are listed as not completed, in the
    first run and in every rerun (which reads them back from sweep.csv); plots show the
    points that completed, if any."""
    from pathlib import Path
    from physval.cli import main
    fakes = Path(__file__).resolve().parent / "fakes.py"
    argv = ["sweep", "--adapter", f"{fakes}:CrashingFake", "--engines", *engines, "--cases", "central_impact[e=0.5,m=1:3]",
            "--repeats", "1", "--workers", "1", "--quiet", "--out", str(tmp_path)]
    for attempt in ("first run", "rerun"):
        assert main(argv) == 0, attempt
        md = (tmp_path / "sweep_report.md").read_text()
        assert "`central_impact[e=0.5,m=1:3]` on **fake-crash**: no point completed." in md
        failed = md.split("## Points that did not complete", 1)[1]
        assert failed.count("| fake-crash |") == len(sweep.DTS) and "RuntimeError: engine crashed" in failed
        crashed = pd.read_csv(tmp_path / "sweep_points.csv").query("engine == 'fake-crash'")
        assert list(crashed.iterations) == ["default"] * len(sweep.DTS), "what each point asked for"
        plotted = "reference" in engines
        assert (tmp_path / "plots" / "cost_central_impact_e_0.5_m_1_3.png").exists() == plotted, attempt
        assert ("No point of this variant completed on any engine" in md) != plotted
