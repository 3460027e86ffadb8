"""The sweep: points, batching, streaming and resuming without losing or redoing a point,
a tiny sweep on a Dask LocalCluster, and the Pareto front and convergence order on data
whose answer is known."""
from __future__ import annotations

import math

import numpy as np
import pandas as pd
import pytest

from physval import sweep
from physval.runner import families
from physval.tradeoff import convergence_order, pareto_front, point_table, write_sweep_report
from tests.test_harness import FALL

FAMS = {**families(), "free_fall": FALL}


def _tiny_points(family="free_fall", variant="offset=0.0"):
    return [sweep.Point(family, variant, "reference", dt, None) for dt in (1 / 60, 1 / 240, 1e-3)]


def test_default_points_cover_six_time_steps_and_five_iteration_counts():
    pts = sweep.sweep_points({"resting_blocks": FAMS["resting_blocks"]}, ["reference"])
    dts = {p.dt for p in pts if p.iterations is None}
    its = {p.iterations for p in pts if p.iterations is not None}
    assert len(dts) >= 6 and max(dts) == pytest.approx(1 / 60) and min(dts) == pytest.approx(1e-4)
    assert len(its) >= 5
    assert len({p.key for p in pts}) == len(pts)


def test_tasks_hold_enough_steps_to_outweigh_scheduling():
    pts = sweep.sweep_points({"central_impact": FAMS["central_impact"]}, ["reference"])
    tasks = sweep.batches(pts, FAMS)
    assert sum(len(t) for t in tasks) == len(pts)
    for t in tasks[:-1]:
        assert sum(p.steps(FAMS[p.family]) for p in t) * (sweep.REPEATS + 1) >= sweep.MIN_TASK_STEPS


def test_a_point_records_errors_and_the_minimum_of_its_repeats():
    from adapters.registry import get
    (p, *_) = _tiny_points()
    rows = sweep.run_point(p, FALL, get("reference"), repeats=3)
    walls = eval(rows[0]["repeat_wall_s"])
    assert len(walls) == 3 and rows[0]["wall_per_sim_s"] == pytest.approx(
        min(walls) / ((rows[0]["steps"] - rows[0]["warmup_steps"]) * p.dt))
    assert {r["status"] for r in rows} == {"pass"} and rows[0]["iterations_asked"] == "default"


def test_an_interrupted_sweep_resumes_without_losing_or_redoing_points(tmp_path, monkeypatch):
    path = tmp_path / "sweep.csv"
    points = _tiny_points()
    store = sweep.Store(path, FAMS)
    assert sweep.run_sweep(points[:2], FAMS, store, progress=False) == 2
    # a kill in the middle of writing the third point: half a line at the end of the file
    with open(path, "a") as fh:
        fh.write("free_fall,offset=0.0,{},reference,0.0,0.001,")
    ran = []
    real = sweep.run_point
    monkeypatch.setattr(sweep, "run_point", lambda p, *a, **k: ran.append(p.key) or real(p, *a, **k))
    store = sweep.Store(path, FAMS)
    assert store.done == {p.key for p in points[:2]}
    assert sweep.run_sweep(points, FAMS, store, progress=False) == 1
    assert ran == [points[2].key]
    df = pd.read_csv(path)
    assert sorted(df.point.unique()) == sorted(p.key for p in points)
    assert len(df) == 2 * len(points)  # two checks per point, each point once
    assert sweep.run_sweep(points, FAMS, sweep.Store(path, FAMS), progress=False) == 0


def test_a_tiny_sweep_on_a_dask_local_cluster(tmp_path):
    distributed = pytest.importorskip("distributed")
    with distributed.LocalCluster(n_workers=1, threads_per_worker=1, processes=False,
                                  dashboard_address=None) as cluster:
        store = sweep.Store(tmp_path / "sweep.csv", FAMS)
        points = _tiny_points("central_impact", "e=0.5,m=1:3")  # workers find built-in families by name
        sweep.run_sweep(points, FAMS, store, scheduler=cluster.scheduler_address, progress=False)
    df = pd.read_csv(tmp_path / "sweep.csv")
    assert set(df.point) == {p.key for p in points}
    assert set(df.status) == {"pass"}


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
    from adapters.registry import get
    rows = []
    for p in _tiny_points():
        rows += sweep.run_point(p, FALL, get("reference"), repeats=1)
    df = pd.DataFrame(rows)
    write_sweep_report(df, FAMS, tmp_path)
    md = (tmp_path / "sweep_report.md").read_text()
    assert "to reach the case's tolerances it needs dt <=" in md
    assert (tmp_path / "plots" / "cost_free_fall_offset_0.0.png").exists()
    assert len(point_table(df, FAMS)) == 3
