"""`physval stress`: the robustness battery, stability maps and determinism.

- Battery: every `robustness_*` case family (cases/robustness.py says what they share)
  on every engine, through `physval.runner.run_jobs`, so statuses, known deviations and
  costs are exactly those of `physval run`; rows go to `stress_results.csv` (the columns of
  results.csv). Each family's small default grid also runs in `physval run`; `--long` adds
  its `FULL_GRID` (60 s rest, 20-box stacks and 210-box pyramids, the 216-ball pile, the
  20 s cradle), which only this command runs.
- Stability map: per engine, the tallest vertical stack (robustness_stacks' scene) that
  stands for 10 s, and how long the next height lasts, as the time step and the solver
  iterations vary (`Settings(dt, iterations)`, `physval.runner.simulate`). Heights are
  tried upwards and stop at the first that falls.
- Determinism: the same scene and settings run twice give the same final-state hash.

`add_parser(subparsers)` registers the `stress` command; `run(args)` runs it.
"""
from __future__ import annotations

import argparse
import dataclasses
import hashlib
import math
import re
import shlex
import sys
import time
from collections import Counter
from concurrent.futures import ProcessPoolExecutor
from fnmatch import fnmatchcase
from pathlib import Path

import numpy as np
import pandas as pd

from adapters import registry
from adapters.base import Settings, Unsupported
from cases import robustness_stacks
from cases.family import CaseFamily
from cases.observables import drift
from cases.registry import builtin_families
from cases.robustness import COLLAPSE_FRACTION, collapse_time

PREFIX = "robustness_"

# The map (--long): 60, 120 and 240 Hz; 5 to 50 iterations; stacks of 2 to 20.
MAP = {"heights": (2, 5, 10, 15, 20), "dts": (1 / 60, 1 / 120, 1 / 240), "iterations": (None, 5, 10, 20, 50)}
# Without --long: 60 Hz only, where stacks are hardest, up to 10 boxes. None: the
# adapter's stated default (e.g. PyBullet 50, DART 300 sweeps), what a user gets untouched.
QUICK_MAP = {"heights": (2, 5, 10), "dts": (1 / 60,), "iterations": (None, 5, 10, 20)}
MAP_DURATION = 10.0  # s: "stands" means stands this long
MAP_SETTLED = 1.0    # s: drift is measured from here on
# Variants run twice for the determinism check: many simultaneous contacts, and a landing
# on a tie of contact features.
DETERMINISM_VARIANTS = ("robustness_pile[2^2 balls,2D,T=0.6]", "robustness_degenerate[vertex-on,3D]",
                        "robustness_degenerate[edge-on,2D]")

EPILOG = """examples:
  physval stress                                    default grids, a 60 Hz stability map, determinism
  physval stress --long                             every robustness scene (minutes to hours) and the full map
  physval stress --engines mujoco,pybullet --cases 'robustness_stacks*'
  physval stress --cases 'robustness_pile[6^3*]' --long --out /tmp/pile
exit codes: 0 the battery completed (failing physics is a result); 2 bad input."""


# --- which families --------------------------------------------------------------------------

def robustness_families(long: bool = False) -> dict[str, CaseFamily]:
    """The robustness families; with `long`, each grid extended by its module's FULL_GRID."""
    out = {}
    for name, fam in builtin_families().items():
        if not name.startswith(PREFIX):
            continue
        full = getattr(sys.modules[fam.scene.__module__], "FULL_GRID", ()) if long else ()
        ids = {v.id for v in fam.variants}
        extra = tuple(p for p in full if fam.variant_id(p) not in ids)
        out[name] = dataclasses.replace(fam, grid=fam.grid + extra) if extra else fam
    return out


def select(families: dict[str, CaseFamily], specs: list[str]) -> tuple[dict[str, CaseFamily], list[str]]:
    """(families, test ids to keep) for specs 'FAMILY-GLOB' or 'FAMILY-GLOB[VARIANT-GLOB]'
    (as `physval run --cases`); raises ValueError for a spec that matches nothing."""
    if not specs:
        return families, []
    chosen, keep = {}, []
    for spec in specs:
        m = re.fullmatch(r"([^\[\]]+)(?:\[(.+)\])?", spec)
        hits = [(name, fam, v) for name, fam in families.items() if m and fnmatchcase(name, m[1])
                for v in fam.variants if fnmatchcase(v.id, m[2] or "*")]
        if not hits:
            raise ValueError(f"--cases {spec!r} matches no robustness scene (families: {', '.join(families)})")
        for name, fam, v in hits:
            chosen[name] = fam
            if v.test_id not in keep:
                keep.append(v.test_id)
    return chosen, keep


# --- stability map ---------------------------------------------------------------------------

def stack_trial(engine: str, n: int, dt: float, iterations: int | None, duration: float = MAP_DURATION) -> dict:
    """One stack of n boxes on one engine (3D, or 2D for an engine that runs 2D scenes
    only): does it stand for `duration`? Never raises."""
    from physval.runner import Unstable, simulate
    row = {"engine": engine, "dim": "", "dt": dt, "hz": round(1 / dt), "iterations": iterations,
           "iterations_in_force": None, "n": n,
           "status": "", "standing_time": math.nan, "drift": math.nan, "us_per_step": math.nan, "reason": ""}
    try:
        adapter = registry.get(engine)
        dim = 3 if 3 in adapter.capabilities.dimensions else 2
        row["dim"] = dim
        scene = robustness_stacks.scene({"structure": "stack", "n": n, "dim": dim, "T": duration})
        names = [b.name for b in scene.dynamic_bodies]
        sim = adapter.build(scene, Settings(dt=dt, iterations=iterations))
        row["iterations_in_force"] = sim.iterations
    except (Unsupported, registry.EngineError) as exc:
        return {**row, "status": "unsupported", "reason": str(exc)}
    except Exception as exc:  # an engine crash is a result
        return {**row, "status": "error", "reason": f"{type(exc).__name__}: {exc}"}
    try:
        with sim:
            run = simulate(sim, scene, dt, duration)
    except Unstable as exc:
        return {**row, "status": "unstable", "reason": str(exc)}
    except Exception as exc:
        return {**row, "status": "error", "reason": f"{type(exc).__name__}: {exc}"}
    traj = run.trajectory
    standing = collapse_time(traj, names, robustness_stacks.SIZE)
    return {**row, "status": "stands" if standing >= traj.t[-1] else "collapsed", "standing_time": standing,
            "drift": drift(traj, names, MAP_SETTLED), "us_per_step": run.wall_s / run.steps * 1e6}


def _map_cell(cell: tuple) -> list[dict]:
    """Heights upwards on one (engine, dt, iterations) until one does not stand."""
    engine, dt, iterations, heights, duration = cell
    rows = []
    for n in heights:
        rows.append(stack_trial(engine, n, dt, iterations, duration))
        if rows[-1]["status"] != "stands":
            break
    return rows


def stability_map(engines: list[str], heights=MAP["heights"], dts=MAP["dts"], iterations=MAP["iterations"],
                  duration: float = MAP_DURATION, workers: int = 1) -> pd.DataFrame:
    """One row per (engine, dt, iterations, height) tried: status stands / collapsed /
    unstable / error / unsupported, standing time (the time to collapse), drift after
    MAP_SETTLED (m) and wall time per step."""
    cells = [(e, dt, it, tuple(sorted(heights)), duration) for e in engines for dt in dts for it in iterations]
    if workers > 1:
        with ProcessPoolExecutor(workers) as pool:
            parts = list(pool.map(_map_cell, cells))
    else:
        parts = [_map_cell(c) for c in cells]
    return pd.DataFrame([r for part in parts for r in part])


def map_summary(df: pd.DataFrame) -> pd.DataFrame:
    """Per (engine, dt, iterations): the tallest stack that stood, the next height tried
    and how long it lasted (its time to collapse), the tallest's drift and step cost."""
    out = []
    for (eng, dt, it), grp in df.groupby(["engine", "dt", "iterations"], sort=False, dropna=False):
        stood = grp[grp.status == "stands"]
        fell = grp[grp.status != "stands"]
        best = stood.iloc[-1] if len(stood) else None
        nxt = fell.iloc[0] if len(fell) else None
        in_force = grp.iloc[0].get("iterations_in_force")
        label = int(it) if it is not None and not (isinstance(it, float) and math.isnan(it)) else (
            f"default ({int(in_force)})" if in_force is not None and not pd.isna(in_force) else "default")
        out.append({"engine": eng, "dim": f"{grp.iloc[0].dim}D" if grp.iloc[0].dim != "" else "", "hz": round(1 / dt),
                    "iterations": label,
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
    from physval.report import _plt, _save
    plt = _plt()
    summary = map_summary(df)
    engines = list(dict.fromkeys(summary.engine))
    top = max(int(df.n.max()), 1)
    fig, axes = plt.subplots(1, len(engines), figsize=(2.6 * len(engines) + 1.6, 3.2), squeeze=False,
                             layout="constrained")
    for ax, eng in zip(axes[0], engines):
        part = summary[summary.engine == eng]
        hz = sorted(part.hz.unique())
        cols = list(dict.fromkeys(str(it) for it in part.iterations))  # "default (N)" first, then counts
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
    _save(fig, path)


def stability_section(df: pd.DataFrame, plot: str = "plots/stability_map.png") -> str:
    """The "Stability" markdown section (with the plot at `plot`, relative to the report)."""
    from physval.report import _fmt, _md_table
    if df.empty:
        return "## Stability\n\n_(no stability map in this run)_\n"
    summary = map_summary(df)
    shown = summary.copy()
    for col in ("its drift (m)", "next: time to collapse (s)", "us/step (tallest)"):
        shown[col] = shown[col].map(_fmt)
    dur = MAP_DURATION
    lines = ["## Stability", "",
             f"Per engine, the tallest vertical stack of 0.2 m, 1 kg boxes (mu = 0.5, e = 0; 3D, or 2D for a 2D "
             f"engine) that stands for "
             f"{dur:g} s (no box moves more than {COLLAPSE_FRACTION:.0%} of its size sideways or a whole size "
             "down), as the step rate and the "
             "solver iterations vary; heights are tried upwards and stop at the first that falls, whose time to "
             f"collapse is shown. Drift: the tallest standing stack's largest displacement after {MAP_SETTLED:g} s "
             "(1 % of the box is 2 mm). Cost: wall time per step of the tallest standing stack (noisy machine). "
             "Iterations are each engine's own solver count (DART: sweeps of the Coulomb-cone NSGS solver the "
             "adapter selects; PyBullet: the multibody solver, which has no warm starting, for a scene with "
             "friction); `default (N)` is the adapter's stated default, what a user gets untouched.", "",
             f"![stability map]({plot})", "", _md_table(shown), ""]
    bad = df[df.status.isin(["unstable", "error", "unsupported"])].drop_duplicates(["engine", "status", "reason"])
    if len(bad):
        lines += ["Runs that did not finish:", "", _md_table(bad[["engine", "hz", "iterations", "n", "status", "reason"]]), ""]
    return "\n".join(lines)


# --- determinism -----------------------------------------------------------------------------

def state_hash(states: dict[str, np.ndarray]) -> str:
    """SHA-256 of every body's state row (float64 bytes), bodies in name order."""
    h = hashlib.sha256()
    for name in sorted(states):
        h.update(name.encode())
        h.update(np.ascontiguousarray(states[name], dtype=np.float64).tobytes())
    return h.hexdigest()


def final_state_hash(engine: str, family: CaseFamily, params: dict) -> str:
    """Build, run for the family's duration at its dt, hash the final states."""
    from physval.runner import simulate
    scene = family.scene(params)
    with registry.get(engine).build(scene, Settings(dt=family.dt_for(params))) as sim:
        run = simulate(sim, scene, family.dt_for(params), family.duration(params))
    return state_hash({name: states[-1] for name, states in run.trajectory.states.items()})


def determinism(engines: list[str], variants=DETERMINISM_VARIANTS, repeats: int = 2) -> pd.DataFrame:
    """Each variant run `repeats` times per engine: deterministic when every final-state
    hash is the same. Status: deterministic / differs / unsupported / error."""
    from physval.runner import families as all_families
    fams = all_families()
    out = []
    for test_id in variants:
        fam_name, vid = test_id.split("[", 1)
        fam = fams[fam_name]
        variant = next(v for v in fam.variants if v.id == vid[:-1])
        for eng in engines:
            row = {"engine": eng, "scene": test_id, "runs": repeats, "status": "", "hash": "", "reason": ""}
            try:
                adapter = registry.get(eng)
                why = adapter.capabilities.cannot_run(fam.scene(variant.params))
                if why:
                    raise Unsupported(why)
                hashes = [final_state_hash(eng, fam, variant.params) for _ in range(repeats)]
            except (Unsupported, registry.EngineError) as exc:
                out.append({**row, "status": "unsupported", "reason": str(exc)})
                continue
            except Exception as exc:
                out.append({**row, "status": "error", "reason": f"{type(exc).__name__}: {exc}"})
                continue
            same = len(set(hashes)) == 1
            out.append({**row, "status": "deterministic" if same else "differs", "hash": hashes[0][:16]})
    return pd.DataFrame(out)


def deterministic_engines(df: pd.DataFrame) -> list[str]:
    """Engines whose every run in `df` (from `determinism`) repeated exactly."""
    ran = df[df.status.isin(["deterministic", "differs"])]
    return [e for e, grp in ran.groupby("engine", sort=False) if (grp.status == "deterministic").all()]


def determinism_section(df: pd.DataFrame) -> str:
    from physval.report import _md_table
    lines = ["## Determinism", "",
             "Each scene built and run twice in one process with the same settings; deterministic when the "
             "SHA-256 of every body's final state (float64 bytes) is identical.", "",
             f"Deterministic engines: {', '.join(deterministic_engines(df)) or 'none'}.", "",
             _md_table(df), ""]
    return "\n".join(lines)


# --- report ----------------------------------------------------------------------------------

def cost_table(df: pd.DataFrame) -> pd.DataFrame:
    """Wall time per step (us) of each scene per engine, stepping only."""
    runs = df.drop_duplicates(["case", "variant", "engine"])
    runs = runs[pd.to_numeric(runs.steps, errors="coerce") > 0]
    if runs.empty:
        return pd.DataFrame()
    runs = runs.assign(scene=runs.case + "[" + runs.variant + "]",
                       us=runs.wall_s / pd.to_numeric(runs.steps) * 1e6)
    table = runs.pivot(index="scene", columns="engine", values="us").reset_index()
    return table[["scene"] + [e for e in dict.fromkeys(df.engine) if e in table.columns]]


def write_stress_report(rows: list[dict], smap: pd.DataFrame, det: pd.DataFrame, out: Path, command: str = "") -> pd.DataFrame:
    from physval.report import (_fmt, _md_table, deviation_summary, environment, frame, stale_deviations,
                                summary_matrix, write_atomic, write_csv)
    out = Path(out)
    df = frame(rows)
    write_csv(df, out / "stress_results.csv")
    if not smap.empty:
        write_atomic(out / "stability_map.csv", smap.to_csv(index=False))
        plot_stability_map(smap, out / "plots" / "stability_map.png")
    if not det.empty:
        write_atomic(out / "determinism.csv", det.to_csv(index=False))
    counts = Counter(df.status)
    lines = ["# physval stress report", ""]
    if command:
        lines += [f"Command: `{command}`", ""]
    lines += [f"{len(df)} checks from {df.groupby(['case', 'variant', 'engine']).ngroups} runs: "
              + ", ".join(f"{n} {s}" for s, n in counts.most_common()) + ".", "",
              "Robustness scenes are judged by invariants (cases/robustness.py): no NaN or blow-up (status "
              "`unstable`), energy never rises, bounded overlap and drift, momentum kept where no external "
              "force acts, and the time a structure stands (its time to collapse). Each family's docstring says "
              "why its scenes are hard; every tolerance's reason is in `stress_results.csv`.", "",
              "## Summary", "", _md_table(summary_matrix(df)), ""]
    dev = df[df.status == "deviation"]
    lines += ["## Known deviations", "", _md_table(deviation_summary(dev)) if len(dev) else "_(none in this run)_", ""]
    stale = stale_deviations(df)
    if stale:
        lines += ["Stale entries in the deviation files:", ""] + [f"- {s}" for s in stale] + [""]
    bad = df[df.status.isin(["fail", "unstable", "error"])]
    lines += ["## Failures, blow-ups and errors", ""]
    lines += [_md_table(pd.DataFrame({
        "status": bad.status, "engine": bad.engine, "check": bad.case + "[" + bad.variant + "]:" + bad.metric,
        "expected": bad.expected.map(_fmt), "measured": bad.measured.map(_fmt), "reason": bad.reason})) if len(bad)
        else "_(none)_", ""]
    uns = df[df.status == "unsupported"].drop_duplicates(["engine", "case", "reason"])
    if len(uns):
        lines += ["## Unsupported", "", _md_table(uns[["engine", "case", "reason"]]), ""]
    cost = cost_table(df)
    if len(cost):
        shown = cost.copy()
        for col in shown.columns[1:]:
            shown[col] = shown[col].map(_fmt)
        lines += ["## Cost per scene", "", "Wall time per step in microseconds (stepping only, scene construction "
                  "excluded; one run each on a noisy machine).", "", _md_table(shown), ""]
    lines += [stability_section(smap), determinism_section(det) if not det.empty else "",
              "## Environment", "", _md_table(pd.DataFrame(list(environment(df).items()), columns=["what", "value"])), ""]
    write_atomic(out / "stress_report.md", "\n".join(lines))
    return df


# --- command line ----------------------------------------------------------------------------

def add_parser(subparsers) -> argparse.ArgumentParser:
    """Register the `stress` subcommand on an argparse subparsers object."""
    p = subparsers.add_parser(
        "stress", help="robustness battery, stability maps and determinism; writes stress_results.csv and stress_report.md",
        formatter_class=argparse.RawDescriptionHelpFormatter, epilog=EPILOG,
        description="Run the robustness scenes (tall stacks, pyramids, mass ratios, warm starting, overlap "
                    "recovery, tunnelling, piles, Newton's cradle, tiny and far bodies, degenerate landings) on "
                    "engines, judged by invariants; map the tallest stack each engine keeps standing as the step "
                    "rate and solver iterations vary; check that each engine repeats a run exactly. Writes "
                    "stress_results.csv (the columns of results.csv), stress_report.md (with a Stability "
                    "section), stability_map.csv, determinism.csv and plots/ into --out.")
    p.add_argument("--engines", nargs="+", metavar="NAME",
                   help="engines (default: every engine but the reference's other formulations, reference-*, "
                        "which run when named; comma-separated lists work too; see 'physval list --engines')")
    p.add_argument("--cases", nargs="+", metavar="GLOB",
                   help="robustness scenes: globs on the family or on 'family[variant]', e.g. 'robustness_stacks' "
                        "or 'robustness_pile[6^3*]' (default: every robustness family)")
    p.add_argument("--out", default="reports/stress", metavar="DIR", help="output folder (default: reports/stress)")
    p.add_argument("--long", action="store_true",
                   help="also run the long variants (FULL_GRID: 60 s rest, 20-box stacks, 210-box pyramids, the "
                        "216-ball pile, 20 s cradle) and the full stability map (60-240 Hz, 5-50 iterations, "
                        "stacks up to 20); minutes to hours")
    p.add_argument("--workers", type=int, default=1, metavar="N",
                   help="parallel processes (default 1: keeps the step timings undisturbed)")
    p.add_argument("--no-map", action="store_true", help="skip the stability map")
    p.add_argument("--quiet", action="store_true", help="no progress bar or progress lines")
    return p


def _names(values) -> list[str]:
    """Items of space- or comma-separated lists; commas inside [...] belong to a variant glob."""
    return [x.strip() for v in values or [] for x in re.split(r",(?![^\[]*\])", v) if x.strip()]


def run(args) -> int:
    """Run the battery, the stability map and the determinism check; write the report.
    Returns 0 when completed (failing physics is a result), 2 on bad input."""
    from physval.runner import plan, run_jobs

    def say(text: str) -> None:
        if not args.quiet:
            print(f"physval stress: {text}", file=sys.stderr)

    named = _names(args.engines)
    # as `physval run`: the reference's other formulations run only when named
    engines = named or [e for e in registry.engine_names() if not e.startswith("reference-")]
    unknown = [e for e in engines if e not in registry.ENGINES]
    if unknown:
        print(f"physval stress: error: unknown engine {unknown[0]!r}: choose from {', '.join(registry.ENGINES)}",
              file=sys.stderr)
        return 2
    if args.workers < 1:
        print(f"physval stress: error: --workers {args.workers}: must be >= 1", file=sys.stderr)
        return 2
    try:
        families, keep = select(robustness_families(args.long), _names(args.cases))
    except ValueError as exc:
        print(f"physval stress: error: {exc}", file=sys.stderr)
        return 2
    jobs = [j for j in plan(families, engines) if not keep or j.variant.test_id in keep]
    out = Path(args.out)
    say(f"{len(jobs)} runs ({len(families)} families x {len(engines)} engines) -> {out}/")
    t0 = time.perf_counter()
    rows = run_jobs(jobs, families, workers=args.workers, progress=not args.quiet and sys.stderr.isatty())
    say(f"battery done in {time.perf_counter() - t0:.0f} s")
    smap = pd.DataFrame()
    if not args.no_map:
        grid = MAP if args.long else QUICK_MAP
        say(f"stability map: stacks of {grid['heights']} at {[round(1 / d) for d in grid['dts']]} Hz, "
            f"iterations {grid['iterations']}")
        smap = stability_map(engines, **grid, workers=args.workers)
    say("determinism")
    det = determinism(engines)
    command = "physval " + " ".join(shlex.quote(a) for a in sys.argv[1:])
    df = write_stress_report(rows, smap, det, out, command=command)
    counts = Counter(df.status)
    print(f"{len(df)} checks: " + ", ".join(f"{n} {s}" for s, n in counts.most_common()))
    print(f"wrote {out / 'stress_results.csv'}, {out / 'stress_report.md'}")
    return 0


def main(argv: list[str] | None = None) -> int:
    """`python -m physval.stress ...` until the stress command is wired into physval's CLI."""
    parser = argparse.ArgumentParser(prog="physval")
    sub = parser.add_subparsers(dest="command", required=True)
    add_parser(sub)
    return run(parser.parse_args(argv))


if __name__ == "__main__":
    sys.exit(main())
