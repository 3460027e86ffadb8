"""Error against cost from a sweep: Pareto fronts, convergence orders, plots, the report.

A point's accuracy is its worst check in units of that check's tolerance *at the family's
default dt*: one fixed yardstick across the sweep (some tolerances scale with dt, which
would otherwise move the goalposts). "Reaching the tolerance" means that worst error <= 1.
"""
from __future__ import annotations

import math
import re
from pathlib import Path

import numpy as np
import pandas as pd

from cases.family import CaseFamily
from physval.report import _md_table, _plt, _save, write_atomic

FLOOR = 1e-12  # errors below this (in tolerances) are round-off: left out of slope fits


def point_table(df: pd.DataFrame, fams: dict[str, CaseFamily]) -> pd.DataFrame:
    """One row per sweep point: settings, cost and worst error in default-dt tolerances."""
    out = []
    for key, grp in df.groupby("point", sort=False):
        first = grp.iloc[0]
        fam = fams[first.case]
        v = next(v for v in fam.variants if v.id == first.variant)
        yard = {c.metric: c for c in fam.expect(v.params, fam.dt_for(v.params))}
        ok = grp.status.isin(["pass", "fail", "deviation"])
        worst = math.nan
        if ok.all():
            errs = []
            for r in grp.itertuples():
                c = yard[r.metric]
                e = r.abs_error if c.kind == "abs" else r.rel_error
                errs.append(e / c.tolerance if c.tolerance > 0 else (0.0 if e == 0 else math.inf))
            worst = max(errs)
        out.append({"point": key, "case": first.case, "variant": first.variant, "engine": first.engine,
                    "dt": float(first["dt"]), "iterations": str(first.iterations_asked),
                    "iterations_in_force": str(first.iterations),
                    "cost_us_per_sim_s": float(first.wall_per_sim_s) * 1e6, "worst_over_tol": worst,
                    "status": "ok" if ok.all() else grp.status.iloc[0],
                    "reason": "" if ok.all() else grp.reason.iloc[0]})
    return pd.DataFrame(out)


def pareto_front(points: pd.DataFrame) -> pd.DataFrame:
    """The points no cheaper point beats in accuracy: the cheapest way to each accuracy."""
    good = points[np.isfinite(points.worst_over_tol) & np.isfinite(points.cost_us_per_sim_s)]
    front, best = [], math.inf
    for r in good.sort_values(["cost_us_per_sim_s", "worst_over_tol"]).itertuples():
        if r.worst_over_tol < best:
            front.append(r.Index)
            best = r.worst_over_tol
    return good.loc[front]


def _default_iterations(pts: pd.DataFrame) -> pd.DataFrame:
    return pts[pts.iterations == "default"]


def convergence_order(pts: pd.DataFrame) -> float:
    """Slope of log(worst error) against log(dt) over the dt axis (default iterations);
    NaN when fewer than three points are above round-off."""
    axis = _default_iterations(pts)
    axis = axis[np.isfinite(axis.worst_over_tol) & (axis.worst_over_tol > FLOOR)]
    if axis["dt"].nunique() < 3:
        return math.nan
    return float(np.polyfit(np.log(axis["dt"]), np.log(axis.worst_over_tol), 1)[0])


def summary(points: pd.DataFrame) -> pd.DataFrame:
    """Per case variant and engine: order, best accuracy, and the cheapest setting that
    reaches the tolerance."""
    out = []
    for (case, variant, engine), pts in points.groupby(["case", "variant", "engine"], sort=False):
        usable = pts[np.isfinite(pts.worst_over_tol)]
        reach = usable[usable.worst_over_tol <= 1.0].sort_values("cost_us_per_sim_s")
        row = {"case": case, "variant": variant, "engine": engine, "order": convergence_order(pts),
               "best_over_tol": usable.worst_over_tol.min() if len(usable) else math.nan,
               "points": len(pts), "failed_points": int((pts.status != "ok").sum())}
        if len(reach):
            r = reach.iloc[0]
            row.update(reach_dt=r["dt"], reach_iterations=r.iterations, reach_cost_us_per_sim_s=r.cost_us_per_sim_s)
        out.append(row)
    return pd.DataFrame(out)


def sentence(s) -> str:
    what = f"`{s.case}[{s.variant}]` on **{s.engine}**"
    if isinstance(s.get("reach_dt"), float) and math.isfinite(s.reach_dt):
        its = "" if s.reach_iterations == "default" else f" with {s.reach_iterations} iterations"
        return (f"- {what}: to reach the case's tolerances it needs dt <= {s.reach_dt:.3g} s{its}, "
                f"at {s.reach_cost_us_per_sim_s:,.0f} us per simulated second.")
    if math.isfinite(s.best_over_tol):
        return f"- {what}: no setting reached the tolerances; the best came within {s.best_over_tol:.3g} tolerances."
    return f"- {what}: no point completed."


# --- plots --------------------------------------------------------------------------------

def plot_cost(points: pd.DataFrame, case: str, variant: str, path: Path) -> None:
    """Error against cost, log-log, one line per engine along its dt axis; iteration points
    as open markers; each engine's Pareto front dashed."""
    plt = _plt()
    sub = points[(points.case == case) & (points.variant == variant)]
    fig, ax = plt.subplots(figsize=(6.4, 4.4))
    for i, (eng, pts) in enumerate(sub.groupby("engine", sort=False)):
        colour = f"C{i}"
        axis = _default_iterations(pts).sort_values("dt", ascending=False)
        y = np.clip(axis.worst_over_tol, FLOOR, None)
        ax.plot(axis.cost_us_per_sim_s, y, "o-", color=colour, label=eng, ms=4)
        its = pts[~pts.index.isin(axis.index)]
        ax.plot(its.cost_us_per_sim_s, np.clip(its.worst_over_tol, FLOOR, None), "s", mfc="none", color=colour, ms=5)
        front = pareto_front(pts)
        ax.plot(front.cost_us_per_sim_s, np.clip(front.worst_over_tol, FLOOR, None), "--", color=colour, lw=0.8)
    ax.axhline(1.0, color="black", lw=0.8, ls=":")
    ax.set_xscale("log")
    ax.set_yscale("log")
    ax.set_xlabel("cost: wall us per simulated second (stepping only, min of repeats)")
    ax.set_ylabel("worst error / tolerance")
    ax.set_title(f"{case}[{variant}]: error against cost\n(circles: dt axis; squares: iterations; dashed: Pareto front)", fontsize=9)
    ax.legend(fontsize=8)
    fig.tight_layout()
    _save(fig, path)


def plot_convergence(points: pd.DataFrame, case: str, variant: str, path: Path) -> None:
    """Error against dt, log-log, with each engine's fitted slope in the legend."""
    plt = _plt()
    sub = points[(points.case == case) & (points.variant == variant)]
    fig, ax = plt.subplots(figsize=(6.4, 4.4))
    for i, (eng, pts) in enumerate(sub.groupby("engine", sort=False)):
        axis = _default_iterations(pts).sort_values("dt")
        order = convergence_order(pts)
        label = f"{eng} (slope {order:.2f})" if math.isfinite(order) else f"{eng} (exact or too few points)"
        ax.plot(axis["dt"], np.clip(axis.worst_over_tol, FLOOR, None), "o-", color=f"C{i}", label=label, ms=4)
    ax.axhline(1.0, color="black", lw=0.8, ls=":")
    ax.set_xscale("log")
    ax.set_yscale("log")
    ax.set_xlabel("time step dt (s)")
    ax.set_ylabel("worst error / tolerance")
    ax.set_title(f"{case}[{variant}]: error against time step (default iterations)", fontsize=9)
    ax.legend(fontsize=8)
    fig.tight_layout()
    _save(fig, path)


def write_sweep_report(df: pd.DataFrame, fams: dict[str, CaseFamily], out: Path, command: str = "") -> pd.DataFrame:
    out = Path(out)
    points = point_table(df, fams)
    write_atomic(out / "sweep_points.csv", points.to_csv(index=False))
    summ = summary(points)
    write_atomic(out / "sweep_summary.csv", summ.to_csv(index=False))
    lines = ["# physval sweep: what accuracy costs in time", ""]
    if command:
        lines += [f"Command: `{command}`", ""]
    lines += [f"{len(points)} points ({(points.status == 'ok').sum()} completed) over "
              f"{points.groupby(['case', 'variant']).ngroups} case variants and {points.engine.nunique()} engines. "
              "Cost is wall time of stepping only per simulated second (construction and a warm-up excluded, "
              "minimum over repeats). Error is each point's worst check in units of its tolerance at the "
              "family's default dt; every check's own error is in `sweep.csv`.", "",
              "## Answers", ""]
    lines += [sentence(s) for _, s in summ.iterrows()] + [""]
    for (case, variant), _ in points.groupby(["case", "variant"], sort=False):
        slug = re.sub(r"[^A-Za-z0-9._-]+", "_", f"{case}_{variant}").strip("_")
        plot_cost(points, case, variant, out / "plots" / f"cost_{slug}.png")
        plot_convergence(points, case, variant, out / "plots" / f"dt_{slug}.png")
        part = summ[(summ.case == case) & (summ.variant == variant)].copy()
        shown = pd.DataFrame({
            "engine": part.engine,
            "order (slope of log error vs log dt)": part.order.map(lambda x: f"{x:.2f}" if math.isfinite(x) else "-"),
            "best error/tol": part.best_over_tol.map(lambda x: f"{x:.3g}"),
            "cheapest dt reaching tol": part.get("reach_dt", pd.Series(dtype=float)).map(
                lambda x: f"{x:.3g}" if isinstance(x, float) and math.isfinite(x) else "-"),
            "its cost (us/sim s)": part.get("reach_cost_us_per_sim_s", pd.Series(dtype=float)).map(
                lambda x: f"{x:,.0f}" if isinstance(x, float) and math.isfinite(x) else "-")})
        lines += [f"## {case}[{variant}]", "", f"![error against cost](plots/cost_{slug}.png)",
                  f"![error against dt](plots/dt_{slug}.png)", "", _md_table(shown), ""]
    bad = points[points.status != "ok"]
    if len(bad):
        lines += ["## Points that did not complete", "",
                  _md_table(bad[["engine", "case", "variant", "dt", "iterations", "status", "reason"]]), ""]
    write_atomic(out / "sweep_report.md", "\n".join(lines))
    return summ
