"""The parameters each engine really uses: asked vs measured.

For several requested values, measure on each engine
- restitution: the rebound ratio of a dropped ball (central_impact's drop scene and
  observable);
- static friction: the break-away angle of a box on an incline, found by bisection on
  incline_threshold's scene (sliding = accelerating), reported as tan(angle);
- kinetic friction: from the sliding acceleration 10 deg above the threshold,
  mu_k = tan(theta) - a / (g cos(theta)).
A mismatch is a finding for the report, not a verdict: these rows have no tolerance.

Every run is a job of the core (physval.core), so the bisection's steps for all engines
and coefficients run side by side as waves of jobs (`waves`; `physval run` runs them on its
own workers beside its jobs, `stream`), and every job is cached per engine version in the
cache folder (physval.core.store.cache_dir): a second run measures nothing.
"""
from __future__ import annotations

import json
import math
from pathlib import Path

import pandas as pd

from cases import central_impact, incline_threshold
from cases.family import Variant
from physval.core import COLUMNS, Job, Probe
from physval.core.session import Execution, Stream, run_plan, stored
from physval.core.store import cache_dir
from physval.report import fmt, md_table, pyplot, save_figure, write_atomic

DT = 1e-3
RESTITUTIONS = (0.2, 0.5, 0.8, 1.0)
FRICTIONS = (0.2, 0.5, 0.8)
BISECTIONS = 12  # 20 deg bracket / 2^12: the break-away angle to 0.005 deg, tan to ~1e-4
# Sliding means accelerating: creep of a sticking box is a constant mm/s at worst, while
# 0.04 deg above the threshold a box accelerates at about 0.007 m/s^2. (The case's own
# verdict, 1 cm in 1 s, would put the threshold about 0.1 deg late: +0.002 in tan.)
A_SLIDING = 1e-3  # m/s^2: tan(theta) resolved to A / (g cos theta) ~ 1e-4
COLUMNS_OBSERVED = COLUMNS + ["observed"]


class Observed(Probe):
    """Returns everything the family's observer measured (not only its checked metrics)."""

    def __init__(self, job: Job):
        from cases.registry import builtin_families
        self.family = builtin_families()[job.family]
        self.params = job.variant.params

    def after(self, run, sim, rebuild) -> dict:
        values = self.family.observe(run.trajectory, self.params)
        return {"observed": json.dumps({k: float(v) for k, v in values.items()})}


PROBE = f"{__name__}:Observed"


def _job(family, params: dict, engine: str) -> Job:
    return Job(family.name, Variant(family.name, family.variant_id(params), params), engine, DT, probe=PROBE)


def _observed(rows: list[dict], metric: str) -> float:
    """The observed `metric` of a job's rows, NaN if the job did not complete."""
    for r in rows:
        if r.get("observed"):
            return float(json.loads(r["observed"]).get(metric, math.nan))
    return math.nan


def _why_not(rows: list[dict]) -> str:
    for r in rows:
        if not r.get("observed"):
            return f"{r['status']}: {r['reason']}"
    return ""


def measure(engines: list[str], ctx, families=None, execution: Execution = Execution(), **_) -> pd.DataFrame | None:
    """Asked-vs-measured rows for each engine (None if interrupted)."""
    return run_plan(waves(engines, ctx), ctx, cache_dir() / STORE, COLUMNS_OBSERVED, execution, label=LABEL)


def stream(engines: list[str], ctx, families=None) -> Stream:
    """The reading as a stream of the command's executor (physval.core.session.run_streams):
    its waves run beside the command's own jobs; its value is measure()'s."""
    return stored(waves(engines, ctx), ctx, cache_dir() / STORE, COLUMNS_OBSERVED, label=LABEL, first=True)


STORE = "effective.csv"
LABEL = "asked vs measured"


def waves(engines: list[str], ctx):
    """The reading's plan: the bisection's probes wave by wave (each wave's angles follow
    from the last wave's rows), the restitution and kinetic-friction runs with the first;
    returns the asked-vs-measured rows."""
    resolver = ctx.resolver()
    dims = {}
    for e in engines:
        try:
            dims[e] = 3 if 3 in resolver.adapter(e).capabilities.dimensions else 2
        except Exception:
            continue
    jobs_e = {(e, x): _job(central_impact.FAMILY, {"setup": "drop", "e": x, "h": central_impact.H, "dim": d}, e)
              for e, d in dims.items() for x in RESTITUTIONS}
    jobs_k = {(e, mu): _job(incline_threshold.FAMILY, {"mu_s": mu, "mu_k": mu, "offset_deg": 10.0, "dim": d}, e)
              for e, d in dims.items() for mu in FRICTIONS}
    bracket = {(e, mu): [-10.0, 10.0] for e in dims for mu in FRICTIONS}
    results = {}
    for wave in range(BISECTIONS):
        probes = {}
        for (e, mu), (lo, hi) in bracket.items():
            params = {"mu_s": mu, "mu_k": mu, "offset_deg": 0.5 * (lo + hi), "dim": dims[e]}
            probes[(e, mu)] = _job(incline_threshold.FAMILY, params, e)
        jobs = list(probes.values()) + (list(jobs_e.values()) + list(jobs_k.values()) if wave == 0 else [])
        rows = yield jobs
        results.update(rows)
        for key, job in probes.items():
            a = _observed(rows[job.key], "sliding_acceleration")
            mid = 0.5 * sum(bracket[key])
            bracket[key][1 if a > A_SLIDING else 0] = mid
    out = []
    for e in dims:
        note = f"dt = {DT:g} s, {dims[e]}D"
        for x in RESTITUTIONS:
            rows = results[jobs_e[(e, x)].key]
            value = _observed(rows, "rebound_ratio")
            out.append(_row(e, "restitution e", x, value, "rebound ratio of a dropped ball; " + note, rows))
        for mu in FRICTIONS:
            lo, hi = bracket[(e, mu)]
            value = math.tan(math.atan(mu) + math.radians(0.5 * (lo + hi)))
            if lo == -10.0 or hi == 10.0:
                value = math.nan  # the break-away angle left the bracket (or no run completed)
            out.append(_row(e, "static friction mu_s", mu, value, "tan of the break-away angle; " + note, []))
        for mu in FRICTIONS:
            rows = results[jobs_k[(e, mu)].key]
            th = math.atan(mu) + math.radians(10.0)
            a = _observed(rows, "sliding_acceleration")
            value = math.tan(th) - a / (incline_threshold.G * math.cos(th))
            out.append(_row(e, "kinetic friction mu_k", mu, value,
                            "sliding acceleration 10 deg above the threshold; " + note, rows))
    return pd.DataFrame(out)


def _row(engine, parameter, asked, measured, how, rows) -> dict:
    why = _why_not(rows) if rows else ""
    return dict(engine=engine, parameter=parameter, asked=asked, measured=measured,
                difference=measured - asked, note=why or how)


def plot(eff: pd.DataFrame, path: Path) -> None:
    """Asked against measured restitution and friction, one line per engine."""
    plt = pyplot()
    params = list(dict.fromkeys(eff.parameter))
    fig, axes = plt.subplots(1, len(params), figsize=(4.2 * len(params), 3.8), squeeze=False, layout="constrained")
    for ax, param in zip(axes[0], params):
        part = eff[eff.parameter == param]
        lo, hi = float(part.asked.min()), float(part.asked.max())
        ax.plot([lo, hi], [lo, hi], color="black", lw=0.8, ls="--", label="asked = measured")
        for eng, grp in part.groupby("engine", sort=False):
            ax.plot(grp.asked, grp.measured, marker="o", label=eng)
        ax.set_xlabel(f"asked {param}")
        ax.set_ylabel("measured")
        ax.set_title(param)
    axes[0][0].legend(fontsize=7)
    save_figure(fig, path)


def read(out: Path) -> pd.DataFrame | None:
    """The rows `section` wrote into a result folder (effective_parameters.csv; None: none)."""
    path = Path(out) / "effective_parameters.csv"
    if not path.is_file():
        return None
    eff = pd.read_csv(path)
    return eff.assign(note=eff.note.fillna(""))


def section(eff: pd.DataFrame, out: Path) -> str:
    out = Path(out)
    write_atomic(out / "effective_parameters.csv", eff.to_csv(index=False))
    if eff.measured.notna().any():
        plot(eff[eff.measured.notna()], out / "plots" / "effective_parameters.png")
    wide = eff.pivot_table(index=["parameter", "asked"], columns="engine", values="measured", sort=False)
    wide = wide.reset_index()
    for col in wide.columns[2:]:
        wide[col] = wide[col].map(fmt)
    notes = eff[~eff.note.str.startswith(("rebound", "tan of", "sliding"))]
    lines = ["## Asked vs measured parameters", "",
             "What each engine actually produces when asked for a restitution or friction coefficient "
             "(`physval/readings/effective.py`; also in `effective_parameters.csv`). No tolerance: a mismatch is "
             "a finding about the engine's contact model.", "",
             "![asked vs measured](plots/effective_parameters.png)", "", md_table(wide), ""]
    if len(notes):
        lines += ["Not measured:", ""] + [f"- {r.engine} {r.parameter} {r.asked}: {r.note}" for r in notes.itertuples()]
        lines += [""]
    return "\n".join(lines)
