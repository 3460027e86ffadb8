"""`physval stress`: the robustness battery, stability maps and determinism.

- Battery: every family tagged `robustness` (the package cases/robustness says what they share)
  on every engine, as jobs of the core, so statuses, known deviations and costs are
  exactly those of `physval run`; rows go to `stress_results.csv` (the columns of
  results.csv). Each family's small default grid also runs in `physval run`; `--long`
  adds its full grid (60 s rest, 20-box stacks and 210-box pyramids, the 216-ball pile,
  the 20 s cradle), which only this command runs.
- Stability map: per engine, the tallest vertical stack (robustness_stacks' scene and
  observer) that stands for 10 s, and how long the next height lasts, as the time step
  and the solver iterations vary. Heights are tried upwards in waves of jobs (every cell
  at once) and a cell stops at the first height that falls.
- Determinism: the same scene and settings run twice give the same final-state hash.
"""
from __future__ import annotations

import hashlib
import math
from pathlib import Path

import numpy as np
import pandas as pd

from cases.robustness import stacks as robustness_stacks
from cases.family import Variant
from cases.robustness import COLLAPSE_FRACTION
from physval.core import COLUMNS, Job, Probe, simulate
from physval.core.session import Execution, run_stored
from physval.core.selection import select_variants
from physval.readings import scorecard
from physval.readings.checks import (deviation_summary, engine_versions, frame, problems_section, status_counts,
                                     summary_matrix, unsupported_section)
from physval.report import environment, fmt, heading, md_table, pyplot, save_figure, write_atomic

TAG = "robustness"
# The map (--long): 60, 120 and 240 Hz; 5 to 50 iterations; stacks of 2 to 20.
MAP = {"heights": (2, 5, 10, 15, 20), "dts": (1 / 60, 1 / 120, 1 / 240), "iterations": (None, 5, 10, 20, 50)}
# Without --long: 60 Hz only, where stacks are hardest, up to 10 boxes. None: the
# adapter's stated default (e.g. PyBullet 50, DART 300 sweeps), what a user gets untouched.
QUICK_MAP = {"heights": (2, 5, 10), "dts": (1 / 60,), "iterations": (None, 5, 10, 20)}
MAP_DURATION = 10.0  # s: "stands" means stands this long
# The determinism check's scenes: many simultaneous contacts, a landing on a tie of contact
# features, and a box sliding off the axes (DART's result depends on what
# its process ran before: 2.95e-9 or 3.42e-9 m off line, measured).
DETERMINISM_VARIANTS = ("robustness_pile[2^2 balls,2D,T=0.6]", "robustness_degenerate[vertex-on,3D]",
                        "robustness_degenerate[edge-on,2D]", "slide_to_stop[mu=0.5,v0=2,heading=22.5deg]")
STACK_COLUMNS = COLUMNS
HASH_COLUMNS = COLUMNS + ["state_hash"]


# --- stability map ---------------------------------------------------------------------------

def stack_job(engine: str, dim: int, n: int, dt: float, iterations: int | None, duration: float = MAP_DURATION) -> Job:
    fam = robustness_stacks.FAMILY
    params = {"structure": "stack", "n": n, "dim": dim, "T": duration}
    return Job(fam.name, Variant(fam.name, fam.variant_id(params), params), engine, dt, iterations)


def trial_row(job: Job, rows: list[dict]) -> dict:
    """One stack trial from its job's rows: stands / collapsed / unstable / error / unsupported."""
    p = job.variant.params
    row = {"engine": job.engine, "dim": p["dim"], "dt": job.dt, "hz": round(1 / job.dt),
           "iterations": job.iterations, "iterations_in_force": None, "n": p["n"], "status": "",
           "standing_time": math.nan, "drift": math.nan, "us_per_step": math.nan, "reason": ""}
    by = {r["metric"]: r for r in rows}
    first = rows[0] if rows else {}
    if first.get("status") in ("unsupported", "unstable", "error") or "standing_time" not in by:
        return {**row, "status": first.get("status", "error"), "reason": first.get("reason", "no rows")}
    standing = float(by["standing_time"]["measured"])
    it = first.get("iterations")
    steps = float(first["steps"]) if first.get("steps") not in ("", None) else math.nan
    return {**row, "iterations_in_force": int(float(it)) if it not in ("", None) else None,
            "status": "stands" if standing >= p["T"] - 1e-9 else "collapsed", "standing_time": standing,
            "drift": float(by["drift"]["measured"]) if "drift" in by else math.nan,
            "us_per_step": float(first["wall_s"]) / steps * 1e6 if steps else math.nan}


def stability_map(engines: list[str], ctx, out: Path, heights=MAP["heights"], dts=MAP["dts"],
                  iterations=MAP["iterations"], duration: float = MAP_DURATION,
                  execution: Execution = Execution()) -> pd.DataFrame | None:
    """One row per (engine, dt, iterations, height) tried (None if interrupted)."""
    resolver = ctx.resolver()
    cells = []
    for e in engines:
        try:
            dim = 3 if 3 in resolver.adapter(e).capabilities.dimensions else 2
        except Exception:
            dim = 3
        cells += [(e, dim, dt, it) for dt in dts for it in iterations]
    heights = sorted(heights)
    rows, alive = [], list(cells)
    for n in heights:
        if not alive:
            break
        jobs = {c: stack_job(c[0], c[1], n, c[2], c[3], duration) for c in alive}
        res, _ = run_stored(list(jobs.values()), ctx, out / "stability_runs.csv", STACK_COLUMNS, execution,
                            label=f"stability map, {n} boxes")
        if not res.complete:
            return None
        still = []
        for c, job in jobs.items():
            rows.append(trial_row(job, res.rows[job.key]))
            if rows[-1]["status"] == "stands":
                still.append(c)
        alive = still
    return pd.DataFrame(rows)


def map_summary(df: pd.DataFrame) -> pd.DataFrame:
    """Per (engine, dt, iterations): the tallest stack that stood, the next height tried
    and how long it lasted (its time to collapse), the tallest's drift and step cost."""
    out = []
    for (eng, dt, it), grp in df.groupby(["engine", "dt", "iterations"], sort=False, dropna=False):
        grp = grp.sort_values("n")
        stood = grp[grp.status == "stands"]
        fell = grp[grp.status != "stands"]
        best = stood.iloc[-1] if len(stood) else None
        nxt = fell.iloc[0] if len(fell) else None
        in_force = grp.iloc[0].get("iterations_in_force")
        label = int(it) if it is not None and not (isinstance(it, float) and math.isnan(it)) else (
            f"default ({int(in_force)})" if in_force is not None and not pd.isna(in_force) else "default")
        out.append({"engine": eng, "dim": f"{grp.iloc[0].dim}D", "hz": round(1 / dt), "iterations": label,
                    "tallest standing": int(best.n) if best is not None else 0,
                    "its drift (m)": best.drift if best is not None else math.nan,
                    "next height": int(nxt.n) if nxt is not None else "",
                    "next: status": nxt.status if nxt is not None else "",
                    "next: time to collapse (s)": nxt.standing_time if nxt is not None else math.nan,
                    "us/step (tallest)": best.us_per_step if best is not None else math.nan})
    return pd.DataFrame(out)


def plot_stability_map(df: pd.DataFrame, path: Path) -> None:
    """One panel per engine: iterations across, step rate down, the tallest standing stack
    in each cell (and the next height's time to collapse)."""
    plt = pyplot()
    summary = map_summary(df)
    engines = list(dict.fromkeys(summary.engine))
    top = max(int(df.n.max()), 1)
    fig, axes = plt.subplots(1, len(engines), figsize=(2.6 * len(engines) + 1.6, 3.2), squeeze=False,
                             layout="constrained")
    im = None
    for ax, eng in zip(axes[0], engines):
        part = summary[summary.engine == eng]
        hz = sorted(part.hz.unique())
        cols = list(dict.fromkeys(str(it) for it in part.iterations))
        grid = np.full((len(hz), len(cols)), np.nan)
        for _, r in part.iterrows():
            i, j = hz.index(r["hz"]), cols.index(str(r["iterations"]))
            grid[i, j] = r["tallest standing"]
            collapse = r["next: time to collapse (s)"]
            text = str(r["tallest standing"]) + (f"\n{collapse:.1f}s" if math.isfinite(collapse) else "")
            ax.text(j, i, text, ha="center", va="center", fontsize=7,
                    color="black" if r["tallest standing"] > 0.6 * top else "white")
        im = ax.imshow(grid, cmap="viridis", vmin=0, vmax=top, aspect="auto")
        ax.set_xticks(range(len(cols)), [c.replace(" (", "\n(") for c in cols], fontsize=7)
        ax.set_yticks(range(len(hz)), [f"{h} Hz" for h in hz] if ax is axes[0][0] else [])
        ax.set_xlabel("iterations")
        ax.set_title(eng, fontsize=10)
    fig.colorbar(im, ax=axes[0].tolist(), label="tallest stack standing the whole run")
    fig.suptitle("Tallest stack standing (below it: the next height's time to collapse)", fontsize=10)
    save_figure(fig, path)


def stability_section(df: pd.DataFrame, plot: str = "plots/stability_map.png") -> str:
    """The "Stability" markdown section (with the plot at `plot`, relative to the report)."""
    if df is None or df.empty:
        return "## Stability\n\n_(no stability map in this run)_\n"
    shown = map_summary(df)
    for col in ("its drift (m)", "next: time to collapse (s)", "us/step (tallest)"):
        shown[col] = shown[col].map(fmt)
    lines = ["## Stability", "",
             f"Per engine, the tallest vertical stack of 0.2 m, 1 kg boxes (mu = 0.5, e = 0; 3D, or 2D for a 2D "
             f"engine) that stands for {MAP_DURATION:g} s (no box moves more than {COLLAPSE_FRACTION:.0%} of its size "
             "sideways or a whole size down), as the step rate and the solver iterations vary; heights are tried "
             "upwards and stop at the first that falls, whose time to collapse is shown. Drift: the tallest "
             f"standing stack's largest displacement after {robustness_stacks.SETTLED:g} s (1 % of the box is 2 mm). "
             "Cost: wall time per step of the tallest standing stack (noisy machine). Iterations are each engine's "
             "own solver count (DART: sweeps of the Coulomb-cone NSGS solver the adapter selects; PyBullet: the "
             "multibody solver, which has no warm starting, for a scene with friction); `default (N)` is the "
             "adapter's stated default, what a user gets untouched.", "",
             f"![stability map]({plot})", "", md_table(shown), ""]
    bad = df[df.status.isin(["unstable", "error", "unsupported"])].drop_duplicates(["engine", "status", "reason"])
    if len(bad):
        lines += ["Runs that did not finish:", "", md_table(bad[["engine", "hz", "iterations", "n", "status", "reason"]]), ""]
    return "\n".join(lines)


# --- determinism -----------------------------------------------------------------------------

def state_hash(states: dict[str, np.ndarray]) -> str:
    """SHA-256 of every body's state row (float64 bytes), bodies in name order."""
    h = hashlib.sha256()
    for name in sorted(states):
        h.update(name.encode())
        h.update(np.ascontiguousarray(states[name], dtype=np.float64).tobytes())
    return h.hexdigest()


class FinalHash(Probe):
    """The final state's hash of the job's run, then of the same scene built and run twice
    more in the same process, one after the other ("HASH HASH HASH"): a result that depends
    on the process's history (heap addresses reused from the last world, global state)
    differs within one job, whichever worker runs it. (Measured: DART's results alternate
    between two when each world is built after the last one was closed, and a world built
    while another is still open gives the first one's; ordering by heap address would
    explain it.)"""

    def __init__(self, job: Job):
        from physval.core.context import Context
        self.scene = Context().resolver().family(job.family).scene(job.variant.params)

    def after(self, run, sim, rebuild) -> dict:
        traj, runs = run.trajectory, [run]
        for _ in range(2):
            with rebuild() as again:
                runs.append(simulate(again, self.scene, traj.dt, len(traj.t) - 1, forces=traj.forces is not None))
        return {"state_hash": " ".join(state_hash({n: s[-1] for n, s in r.trajectory.states.items()})
                                       for r in runs)}


def determinism(engines: list[str], ctx, out: Path, variants=DETERMINISM_VARIANTS, repeats: int = 2,
                execution: Execution = Execution()) -> pd.DataFrame | None:
    """Each variant run `repeats` times per engine (each run its own job, in any worker, and
    each job runs its scene three times, FinalHash): deterministic when every final-state
    hash is the same."""
    fams = ctx.resolver().families
    chosen = select_variants(fams, list(variants))
    jobs = {(v.test_id, e, k): Job(f, v, e, probe=f"{__name__}:FinalHash", probe_args=(("run", k),))
            for f, vs in chosen.items() for v in vs for e in engines for k in range(repeats)}
    res, _ = run_stored(list(jobs.values()), ctx, out / "determinism_runs.csv", HASH_COLUMNS, execution,
                        label="determinism")
    if not res.complete:
        return None
    out_rows = []
    for test_id in dict.fromkeys(t for t, _, _ in jobs):
        for e in engines:
            got = [res.rows[jobs[(test_id, e, k)].key] for k in range(repeats)]
            firsts = [g[0] if g else {} for g in got]
            row = {"engine": e, "scene": test_id, "runs": 3 * repeats, "status": "", "hash": "", "reason": ""}
            hashes = [f.get("state_hash", "") for f in firsts]
            if all(hashes):
                same = len({h for job_runs in hashes for h in job_runs.split()}) == 1
                within = any(len(set(job_runs.split())) > 1 for job_runs in hashes)
                why = "" if same else ("the scene run again in the same process ends elsewhere" if within
                                       else "jobs in different processes end in different states")
                out_rows.append({**row, "status": "deterministic" if same else "differs", "hash": hashes[0][:16],
                                 "reason": why})
            else:
                bad = next(f for f, h in zip(firsts, hashes) if not h)
                status = "unsupported" if bad.get("status") == "unsupported" else "error"
                out_rows.append({**row, "status": status, "reason": bad.get("reason", "")})
    return pd.DataFrame(out_rows)


def deterministic_engines(df: pd.DataFrame) -> list[str]:
    """Engines whose every run in `df` (from `determinism`) repeated exactly."""
    ran = df[df.status.isin(["deterministic", "differs"])]
    return [e for e, grp in ran.groupby("engine", sort=False) if (grp.status == "deterministic").all()]


def determinism_section(df: pd.DataFrame) -> str:
    return "\n".join(["## Determinism", "",
                      "Each scene run six times with the same settings: in two jobs (possibly in different worker "
                      "processes), each building and running it three times in its process; deterministic when the "
                      "SHA-256 of every body's final state (float64 bytes) is identical in all six.", "",
                      f"Deterministic engines: {', '.join(deterministic_engines(df)) or 'none'}.",
                      "", md_table(df), ""])


# --- report ----------------------------------------------------------------------------------

def cost_table(df: pd.DataFrame) -> pd.DataFrame:
    """Wall time per step (us) of each scene per engine, stepping only."""
    runs = df.drop_duplicates(["case", "variant", "engine"])
    steps = pd.to_numeric(runs.steps, errors="coerce")
    runs = runs[steps > 0].assign(steps=steps[steps > 0])
    if runs.empty:
        return pd.DataFrame()
    runs = runs.assign(scene=runs.case + "[" + runs.variant + "]", us=runs.wall_s / runs.steps * 1e6)
    table = runs.pivot(index="scene", columns="engine", values="us").reset_index()
    return table[["scene"] + [e for e in dict.fromkeys(df.engine) if e in table.columns]]


def write_stress_report(rows: list[dict], smap, det, out: Path, command: str = "", complete: bool = True) -> pd.DataFrame:
    out = Path(out)
    df = frame(rows, COLUMNS)
    write_atomic(out / "stress_results.csv", df[COLUMNS].to_csv(index=False))
    lines = heading("physval stress report", command, "" if complete else "interrupted.")
    lines += [f"{len(df)} checks from {df.groupby(['case', 'variant', 'engine']).ngroups if len(df) else 0} runs: "
              f"{status_counts(df)}.", "",
              "Robustness scenes are judged by invariants (the package cases/robustness): no NaN or blow-up (status "
              "`unstable`), energy never rises, bounded overlap and drift, momentum kept where no external "
              "force acts, and the time a structure stands (its time to collapse). Each family's docstring says "
              "why its scenes are hard; every tolerance's reason is in `stress_results.csv`.", "",
              scorecard.by_family(df), "## Summary", "", md_table(summary_matrix(df)), ""]
    lines += ["## Known deviations", "",
              md_table(deviation_summary(df)) if (df.status == "deviation").any() else "_(none in this run)_", ""]
    lines += problems_section(df) + unsupported_section(df)
    cost = cost_table(df)
    if len(cost):
        shown = cost.copy()
        for col in shown.columns[1:]:
            shown[col] = shown[col].map(fmt)
        lines += ["## Cost per scene", "", "Wall time per step in microseconds (stepping only, scene construction "
                  "excluded; one run each on a noisy machine).", "", md_table(shown), ""]
    if smap is not None and not smap.empty:
        write_atomic(out / "stability_map.csv", smap.to_csv(index=False))
        plot_stability_map(smap, out / "plots" / "stability_map.png")
    lines += [stability_section(smap)]
    if det is not None and not det.empty:
        write_atomic(out / "determinism.csv", det.to_csv(index=False))
        lines += [determinism_section(det)]
    lines += ["## Environment", "", md_table(environment(engine_versions(df) if len(df) else {})), ""]
    write_atomic(out / "stress_report.md", "\n".join(lines))
    return df
