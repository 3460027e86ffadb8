"""`physval sweep`: what accuracy costs in time.

For each case family (its `sweep_variants`) and engine, vary the time step and, where the
engine has one, the solver iteration count and its accuracy target (an error-controlled
integrator's, as Drake's CENIC: the values its `Tunable.sweep` names, at the family's dt);
at each point record every check's error
exactly as in the case's verdicts and the honest cost: wall time of stepping only per
simulated second, scene construction and a warm-up excluded, the minimum over repeats.

Every point is a job of the core (physval.core), so it runs on local workers or a Dask
cluster, a crashing point costs only its own rows, and rows stream to `sweep.csv`: the
same command run again recomputes no finished point.

Error against cost: a point's accuracy is its worst check in units of that check's
tolerance *at the family's default dt*: one fixed yardstick across the sweep (some
tolerances scale with dt, which would otherwise move the goalposts). "Reaching the
tolerance" means that worst error <= 1.
"""
from __future__ import annotations

import json
import math
import re
import time
from pathlib import Path

import numpy as np
import pandas as pd

from physval.core import COLUMNS, Job, Probe, steps_of
from physval.core.plan import leaves_out
from physval.report import engine_styles, heading, md_table, pyplot, save_figure, write_atomic

# Time steps from 1/60 s (games) down to 1e-4 s (six values, about log-spaced).
DTS = (1 / 60, 1 / 120, 1 / 240, 1e-3, 3e-4, 1e-4)
# Solver iterations from starved to generous; engines without the setting get one value.
ITERATIONS = (1, 2, 5, 10, 50)
REPEATS = 3
FLOOR = 1e-12  # errors below this (in tolerances) are round-off: left out of slope fits
SWEEP_COLUMNS = COLUMNS + ["iterations_asked", "setting_asked", "warmup_steps", "repeat_wall_s", "wall_per_sim_s"]
DEFAULT_SETTING = "default"  # a point at the engine's own options (no swept Tunable)


def warmup_steps(n: int) -> int:
    """Steps left out of the timing: the first 5 %, at least 10 (caches, lazy set-up)."""
    return min(n - 1, max(10, n // 20))


class Timing(Probe):
    """The minimum stepping time over `repeats` runs of the same point (the recorded run is
    the first), per simulated second of the timed steps."""

    def __init__(self, job: Job):
        self.repeats = int(dict(job.probe_args).get("repeats", REPEATS))
        self.warmup = job.warmup
        self.asked = "default" if job.iterations is None else job.iterations
        self.setting = setting_of(job.options)

    def after(self, run, sim, rebuild) -> dict:
        walls = [run.wall_s]
        for _ in range(self.repeats - 1):
            with rebuild() as again:
                for _ in range(self.warmup):
                    again.step()
                t0 = time.perf_counter()
                for _ in range(run.steps - self.warmup):
                    again.step()
                walls.append(time.perf_counter() - t0)
        timed = (run.steps - self.warmup) * run.trajectory.dt
        return {"iterations_asked": self.asked, "setting_asked": self.setting, "warmup_steps": self.warmup, "repeat_wall_s": json.dumps([round(w, 9) for w in walls]),
                "wall_per_sim_s": min(walls) / timed}


def setting_of(options) -> str:
    """A point's swept engine setting as text ("accuracy=1e-06"), DEFAULT_SETTING for none."""
    return ";".join(f"{k}={v:g}" for k, v in options) or DEFAULT_SETTING


def points(chosen: dict, engines: list[str], resolver, full: bool = False, dts=DTS, iterations=ITERATIONS,
           repeats: int = REPEATS, named: bool = False) -> list[Job]:
    """Every point of the sweep as a job. By default two axes through each engine's
    defaults: dt over `dts` at the default iterations, and iterations over `iterations` at
    the family's dt, and each swept engine setting (`Tunable.sweep`: an accuracy target) over
    its values at the family's dt; `full` takes the whole dt x iterations grid. Points an
    engine cannot represent, or (unless the engines were `named`) declares too slow for a
    default run, are left out."""
    out = []
    for name, variants in chosen.items():
        fam = resolver.family(name)
        for eng in engines:
            try:
                adapter = resolver.adapter(eng)
            except Exception:
                continue
            its = list(iterations) if adapter.capabilities.iterations else []
            for v in variants:
                scene = fam.scene(v.params)
                if adapter.capabilities.cannot_run(scene, fam.needs_of(v.params)) or \
                        (not named and leaves_out(adapter, fam.tags, scene, named=True)):
                    continue
                grid = {(dt, None) for dt in dts}
                grid |= {(dt, it) for dt in dts for it in its} if full else {(fam.dt_for(v.params), it) for it in its}
                grid = {(dt, it, ()) for dt, it in grid}
                grid |= {(fam.dt_for(v.params), None, ((knob, float(x)),))
                         for knob, t in adapter.tunables.items() for x in t.sweep}
                for dt, it, opts in sorted(grid, key=lambda g: (-g[0], g[1] or 0, g[2])):
                    job = Job(name, v, eng, dt, it, opts, probe=f"{__name__}:Timing", probe_args=(("repeats", repeats),))
                    out.append(Job(name, v, eng, dt, it, opts, probe=job.probe, probe_args=job.probe_args,
                                   warmup=warmup_steps(steps_of(job, fam))))
    return out


def sweep_variants(families: dict, names: list[str]) -> dict:
    return {n: [v for v in families[n].all_variants
                if v.id in (families[n].sweep_variants or (families[n].variants[0].id,))] for n in names}


# --- analysis -------------------------------------------------------------------------------

def point_table(df: pd.DataFrame, fams: dict) -> pd.DataFrame:
    """One row per sweep point: settings, cost and worst error in default-dt tolerances."""
    out = []
    for key, grp in df.groupby("job", sort=False):
        first = grp.iloc[0]
        fam = fams[first.case]
        params = json.loads(first.params)
        yard = {c.metric: c for c in fam.expect(params, fam.dt_for(params))}
        ok = grp.status.isin(["pass", "fail", "deviation"])
        worst = math.nan
        if ok.all():
            errs = []
            for r in grp.itertuples():
                c = yard[r.metric]
                e = float(r.abs_error) if c.kind == "abs" else float(r.rel_error)
                errs.append(e / c.tolerance if c.tolerance > 0 else (0.0 if e == 0 else math.inf))
            worst = max(errs)
        cost = pd.to_numeric(first.get("wall_per_sim_s", math.nan), errors="coerce")
        out.append({"point": key, "case": first.case, "variant": first.variant, "engine": first.engine,
                    "dt": float(first["dt"]), "iterations": _asked(first), "setting": _setting(first),
                    "iterations_in_force": str(first.iterations),
                    "cost_us_per_sim_s": float(cost) * 1e6, "worst_over_tol": worst,
                    "status": "ok" if ok.all() else grp.status.iloc[0],
                    "reason": "" if ok.all() else grp.reason.iloc[0]})
    return pd.DataFrame(out)


def _asked(row) -> str:
    """The iterations a point asked for: its probe's record, or for a point that did not
    run (its probe never read anything) the iterations its rows were made with."""
    asked = row.get("iterations_asked", "")
    if pd.isna(asked) or asked == "":
        asked = row.iterations if not pd.isna(row.iterations) and row.iterations != "" else "default"
    return str(asked)


def _setting(row) -> str:
    asked = row.get("setting_asked", "")
    return DEFAULT_SETTING if pd.isna(asked) or asked == "" else str(asked)


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
    """The dt axis: the points at the engine's default iterations and settings."""
    setting = pts.setting if "setting" in pts else DEFAULT_SETTING
    return pts[(pts.iterations == "default") & (setting == DEFAULT_SETTING)]


def completed(pts: pd.DataFrame) -> pd.DataFrame:
    """The points with an error and a cost to plot (not those whose runs failed)."""
    return pts[np.isfinite(pts.worst_over_tol) & np.isfinite(pts.cost_us_per_sim_s)]


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
            row.update(reach_dt=r["dt"], reach_iterations=r.iterations, reach_cost_us_per_sim_s=r.cost_us_per_sim_s,
                       reach_setting=r.get("setting", DEFAULT_SETTING))
        out.append(row)
    return pd.DataFrame(out)


def _reached(s) -> str:
    """A summary cell: the cheapest dt (and its cost) that reaches the tolerances, else how
    close the best point came."""
    if isinstance(s.get("reach_dt"), float) and math.isfinite(s.reach_dt):
        its = "" if s.reach_iterations == "default" else f", {s.reach_iterations} it."
        its += "" if s.get("reach_setting", DEFAULT_SETTING) in (DEFAULT_SETTING, None) else f", {s.reach_setting}"
        return f"dt <= {s.reach_dt:.3g} s{its}: {s.reach_cost_us_per_sim_s:,.0f} us"
    if math.isfinite(s.best_over_tol):
        return f"never; best {s.best_over_tol:.3g} tol"
    return "no point completed"


def summary_table(summ: pd.DataFrame) -> pd.DataFrame:
    """Engines as rows, case variants as columns: the one-screen opening of the report."""
    cells = summ.assign(where=summ.case + "[" + summ.variant + "]", cell=[_reached(s) for _, s in summ.iterrows()])
    table = cells.pivot(index="engine", columns="where", values="cell")
    table = table.loc[list(dict.fromkeys(summ.engine)), list(dict.fromkeys(cells["where"]))].fillna("-")
    return table.reset_index()


def sentence(s) -> str:
    what = f"`{s.case}[{s.variant}]` on **{s.engine}**"
    if isinstance(s.get("reach_dt"), float) and math.isfinite(s.reach_dt):
        its = "" if s.reach_iterations == "default" else f" with {s.reach_iterations} iterations"
        its += "" if s.get("reach_setting", DEFAULT_SETTING) in (DEFAULT_SETTING, None) else f" at {s.reach_setting}"
        return (f"- {what}: to reach the case's tolerances it needs dt <= {s.reach_dt:.3g} s{its}, "
                f"at {s.reach_cost_us_per_sim_s:,.0f} us per simulated second.")
    if math.isfinite(s.best_over_tol):
        return f"- {what}: no setting reached the tolerances; the best came within {s.best_over_tol:.3g} tolerances."
    return f"- {what}: no point completed."


# --- plots and report ---------------------------------------------------------------------

def plot_cost(points: pd.DataFrame, case: str, variant: str, path: Path) -> None:
    """Error against cost, log-log, one line per engine along its dt axis; iteration points
    as open markers; each engine's Pareto front dashed. Points that did not complete are
    left out (the report lists them)."""
    plt = pyplot()
    sub = completed(points[(points.case == case) & (points.variant == variant)])
    fig, ax = plt.subplots(figsize=(8.2, 4.6), layout="constrained")
    styles = engine_styles(sub.engine.unique())
    for eng, pts in sub.groupby("engine", sort=False):
        colour = styles[eng]["color"]
        axis = _default_iterations(pts).sort_values("dt", ascending=False)
        ax.plot(axis.cost_us_per_sim_s, np.clip(axis.worst_over_tol, FLOOR, None), "-", label=eng, ms=4,
                **styles[eng])
        swept = pts.setting != DEFAULT_SETTING if "setting" in pts else pd.Series(False, index=pts.index)
        its = pts[~pts.index.isin(axis.index) & ~swept]
        ax.plot(its.cost_us_per_sim_s, np.clip(its.worst_over_tol, FLOOR, None), "s", mfc="none", color=colour, ms=5)
        setting = pts[swept].sort_values("cost_us_per_sim_s")
        ax.plot(setting.cost_us_per_sim_s, np.clip(setting.worst_over_tol, FLOOR, None), "^:", mfc="none",
                color=colour, ms=5, lw=0.8)
        front = pareto_front(pts)
        ax.plot(front.cost_us_per_sim_s, np.clip(front.worst_over_tol, FLOOR, None), "--", color=colour, lw=0.8)
    ax.axhline(1.0, color="black", lw=0.8, ls=":")
    ax.set_xscale("log")
    ax.set_yscale("log")
    ax.set_xlabel("cost: wall us per simulated second (stepping only, min of repeats)")
    ax.set_ylabel("worst error / tolerance")
    ax.set_title(f"{case}[{variant}]: error against cost\n(filled: dt axis; open squares: iterations; "
                 "open triangles: accuracy target; dashed: Pareto front)",
                 fontsize=9)
    ax.legend(fontsize=7, loc="center left", bbox_to_anchor=(1.01, 0.5))  # beside: up to ~20 engines
    save_figure(fig, path)


def plot_convergence(points: pd.DataFrame, case: str, variant: str, path: Path) -> None:
    """Error against dt, log-log, with each engine's fitted slope in the legend. Points
    that did not complete are left out (the report lists them)."""
    plt = pyplot()
    sub = completed(points[(points.case == case) & (points.variant == variant)])
    fig, ax = plt.subplots(figsize=(8.2, 4.6), layout="constrained")
    styles = engine_styles(sub.engine.unique())
    for eng, pts in sub.groupby("engine", sort=False):
        axis = _default_iterations(pts).sort_values("dt")
        order = convergence_order(pts)
        label = f"{eng} (slope {order:.2f})" if math.isfinite(order) else f"{eng} (exact or too few points)"
        ax.plot(axis["dt"], np.clip(axis.worst_over_tol, FLOOR, None), "-", label=label, ms=4, **styles[eng])
    ax.axhline(1.0, color="black", lw=0.8, ls=":")
    ax.set_xscale("log")
    ax.set_yscale("log")
    ax.set_xlabel("time step dt (s)")
    ax.set_ylabel("worst error / tolerance")
    ax.set_title(f"{case}[{variant}]: error against time step (default iterations)", fontsize=9)
    ax.legend(fontsize=7, loc="center left", bbox_to_anchor=(1.01, 0.5))  # beside: up to ~20 engines
    save_figure(fig, path)


def _column(table: pd.DataFrame, name: str, fmt: str) -> pd.Series:
    """A summary column as text; "-" where there is no number (no point completed, no
    setting reached the tolerances, or no row has the column at all)."""
    values = table[name] if name in table else pd.Series(math.nan, index=table.index)
    return values.map(lambda x: format(x, fmt) if isinstance(x, (int, float)) and math.isfinite(x) else "-")


def write_report(rows: list[dict], fams: dict, out: Path, command: str = "", complete: bool = True) -> pd.DataFrame:
    out = Path(out)
    df = pd.DataFrame(rows)
    pts = point_table(df, fams) if len(df) else pd.DataFrame(
        columns=["point", "case", "variant", "engine", "dt", "iterations", "setting", "cost_us_per_sim_s", "worst_over_tol",
                 "status", "reason"])
    write_atomic(out / "sweep_points.csv", pts.to_csv(index=False))
    summ = summary(pts) if len(pts) else pd.DataFrame()
    write_atomic(out / "sweep_summary.csv", summ.to_csv(index=False))
    lines = heading("physval sweep: what accuracy costs in time", command,
                    "" if complete else "the sweep was interrupted.")
    lines += [f"{len(pts)} points ({(pts.status == 'ok').sum()} completed) over "
              f"{pts.groupby(['case', 'variant']).ngroups if len(pts) else 0} case variants and "
              f"{pts.engine.nunique() if len(pts) else 0} engines. "
              "Cost is wall time of stepping only per simulated second (construction and a warm-up excluded, "
              "minimum over repeats). Error is each point's worst check in units of its tolerance at the "
              "family's default dt; every check's own error is in `sweep.csv`.", ""]
    if len(summ):
        lines += ["## Summary", "", "Each cell: the cheapest time step (and iterations or accuracy target, where not the default) "
                  "whose every check is within its tolerance, and its cost in microseconds of wall time per "
                  "simulated second; `never`: no setting reached the tolerances, and how close the best came.", "",
                  md_table(summary_table(summ)), ""]
    lines += ["## Answers", ""] + [sentence(s) for _, s in summ.iterrows()] + [""]
    for (case, variant), grp in (pts.groupby(["case", "variant"], sort=False) if len(pts) and complete else []):
        slug = re.sub(r"[^A-Za-z0-9._-]+", "_", f"{case}_{variant}").strip("_")
        lines += [f"## {case}[{variant}]", ""]
        if len(completed(grp)):
            plot_cost(pts, case, variant, out / "plots" / f"cost_{slug}.png")
            plot_convergence(pts, case, variant, out / "plots" / f"dt_{slug}.png")
            lines += [f"![error against cost](plots/cost_{slug}.png)", f"![error against dt](plots/dt_{slug}.png)", ""]
        else:
            lines += ["No point of this variant completed on any engine: nothing to plot (see the points that "
                      "did not complete, below).", ""]
        part = summ[(summ.case == case) & (summ.variant == variant)]
        shown = pd.DataFrame({
            "engine": part.engine,
            "order (slope of log error vs log dt)": _column(part, "order", ".2f"),
            "best error/tol": _column(part, "best_over_tol", ".3g"),
            "cheapest dt reaching tol": _column(part, "reach_dt", ".3g"),
            "its cost (us/sim s)": _column(part, "reach_cost_us_per_sim_s", ",.0f")})
        lines += [md_table(shown), ""]
    bad = pts[pts.status != "ok"] if len(pts) else pts
    if len(bad):
        lines += ["## Points that did not complete", "",
                  md_table(bad[["engine", "case", "variant", "dt", "iterations", "setting", "status", "reason"]]), ""]
    write_atomic(out / "sweep_report.md", "\n".join(lines))
    return summ
