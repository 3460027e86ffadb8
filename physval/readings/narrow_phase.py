"""The narrow-phase reading: each engine's contact normal, depth and points for the
catalogue of convex pairs at known poses (cases/narrow_phase.py) against exact geometry.

The measurements are the family's checks, run as any family's jobs through the core (one
step at rest, gravity off, the points read from Simulation.contact_points); this reading
takes their rows from a run and shows them side by side: a table, engines as rows and
pairs as columns, each cell naming the metrics that miss their tolerance with the error
(`ok`: every check of the pair within it; `dev`: a recorded known deviation; `-`: the
engine does not run the pair, e.g. it reports no contact points), and a plot of every
error against its tolerance, one panel per metric. `measure` gives one row per engine,
pair and metric; `section` writes them as narrow_phase.csv beside the report.
"""
from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pandas as pd

from physval.report import engine_styles, fmt, md_table, pyplot, save_figure, write_atomic

FAMILY = "narrow_phase"
METRICS = ("normal_error", "depth", "point_offset", "uncovered")
SHORT = {"normal_error": "normal", "depth": "depth", "point_offset": "point", "uncovered": "uncovered"}
UNITS = {"normal_error": "rad", "depth": "m", "point_offset": "m", "uncovered": "m"}
MARK = {"fail": "FAIL", "deviation": "dev"}
FLOOR = 1e-12  # an exact zero, or a miss of no size, is drawn at this floor of the log axis
CEILING = 1.0  # an infinite error (no point reported) is drawn here


def measure(df: pd.DataFrame) -> pd.DataFrame | None:
    """One row per engine, pair and metric of the narrow_phase family in a run's rows
    (physval.readings.checks.frame): status, measured, expected, |error|, tolerance and the
    reason; None if the run has none."""
    mine = df[df.case == FAMILY]
    if not len(mine):
        return None
    return pd.DataFrame({
        "engine": mine.engine, "pair": mine.variant.astype(str), "metric": mine.metric, "status": mine.status,
        "measured": pd.to_numeric(mine.measured, errors="coerce"),
        "expected": pd.to_numeric(mine.expected, errors="coerce"),
        "error": pd.to_numeric(mine.abs_error, errors="coerce"),
        "tolerance": pd.to_numeric(mine.tolerance, errors="coerce"),
        "reason": mine.reason.fillna("")}).reset_index(drop=True)


def cell(rows: pd.DataFrame) -> str:
    """One engine's pair: `-` not run, `ok` all within tolerance, else each miss with its error."""
    judged = rows[rows.status.isin(["pass", "fail", "deviation"])]
    if not len(judged):
        return "-" if rows.status.eq("unsupported").all() else "/".join(sorted(set(rows.status)))
    misses = judged[judged.status != "pass"]
    if not len(misses):
        return "ok"
    text = ", ".join(f"{SHORT.get(r.metric, r.metric)} {fmt(r.error) if math.isfinite(r.error) else 'none'} "
                     f"{MARK[r.status]}" for r in misses.itertuples())
    return f"**{text}**" if misses.status.eq("fail").any() else text


def grid(rows: pd.DataFrame) -> pd.DataFrame:
    """Engines as rows, pairs as columns (`cell`)."""
    engines, pairs = list(dict.fromkeys(rows.engine)), list(dict.fromkeys(rows.pair))
    out = [{"engine": e, **{p: cell(rows[(rows.engine == e) & (rows.pair == p)]) for p in pairs}} for e in engines]
    return pd.DataFrame(out, columns=["engine", *pairs])


def plot(rows: pd.DataFrame, path: Path) -> None:
    """Every engine's error per pair against the tolerance (dashed), one panel per metric;
    a pair the engine reports no point for is drawn at the top."""
    plt = pyplot()
    judged = rows[rows.status.isin(["pass", "fail", "deviation"])]
    pairs = list(dict.fromkeys(rows.pair))
    metrics = [m for m in METRICS if m in set(judged.metric)]
    if not metrics:
        return
    styles = engine_styles(list(dict.fromkeys(judged.engine)))
    fig, axes = plt.subplots(1, len(metrics), figsize=(4.2 * len(metrics), 4.4), squeeze=False, layout="constrained")
    for ax, metric in zip(axes[0], metrics):
        these = judged[judged.metric == metric]
        for k, (engine, style) in enumerate(styles.items()):
            mine = these[these.engine == engine]
            if not len(mine):
                continue
            x = np.array([pairs.index(p) for p in mine.pair]) + (k - len(styles) / 2) * 0.6 / len(styles)
            y = np.where(np.isfinite(mine.error), np.clip(mine.error, FLOOR, CEILING), CEILING)
            ax.scatter(x, y, s=22, label=engine, **style)
        for tol in these.tolerance.dropna().unique():
            ax.axhline(tol, color="k", linestyle="--", linewidth=0.8)
        ax.set_yscale("log")
        ax.set_ylim(FLOOR / 3, CEILING * 3)
        ax.set_xticks(range(len(pairs)), pairs, rotation=40, ha="right", fontsize=8)
        ax.set_title(f"{metric} error ({UNITS[metric]}); dashed: tolerance", fontsize=9)
        ax.set_ylabel(f"|error| (0 drawn at {FLOOR:g}, no point at {CEILING:g})", fontsize=8)
    axes[0][-1].legend(fontsize=7, loc="center left", bbox_to_anchor=(1.0, 0.5))
    save_figure(fig, path)


def section(rows: pd.DataFrame, out: Path) -> str:
    out = Path(out)
    write_atomic(out / "narrow_phase.csv", rows.to_csv(index=False))
    lines = ["## Narrow phase against exact geometry", "",
             "Each engine's contact normal, depth and points for a catalogue of convex pairs at known poses "
             "(`cases/narrow_phase.py`: one step at rest, gravity off, frictionless; the points as the engine's "
             "`contact_points` read-out gives them), against the exact normal, the overlap the pose sets, the "
             "region the two bodies share (a point, segment, rectangle or disc on the base's surface, as thick as the "
             "overlap) and, for a line or face contact, whether the points span it. A cell lists the metrics "
             "that miss with their error (rad for the normal, m otherwise; `none`: no point reported); `ok`: "
             "all within tolerance; `dev`: a recorded known deviation, **bold**: a failure; `-`: not run on "
             "the engine (it reports no contact points, or lacks a shape). Every value is in `narrow_phase.csv`.", ""]
    lines += [md_table(grid(rows)), ""]
    if rows.status.isin(["pass", "fail", "deviation"]).any():
        plot(rows, out / "plots" / "narrow_phase.png")
        lines += ["![narrow-phase errors against their tolerances](plots/narrow_phase.png)", ""]
    return "\n".join(lines)
