"""Where two runs of the same job part: the trajectories `physval run --save-trajectories`
wrote in two runs (two engine releases, two settings), compared step by step.

For each job saved by both runs, the first step at which any dynamic body's state differs
by more than PARTED of that quantity's scale in the job (physval.core.parting, the measure
the invariance battery applies too: the scene's size, speed and rate of turning; a
quaternion's scale is 1). A job whose two trajectories are equal to the last bit never parts.
"""
from __future__ import annotations

import zipfile
from pathlib import Path

import numpy as np
import pandas as pd

from physval.core.parting import PARTED, apart as _apart, first_past
from physval.core.trajectories import load
from physval.report import fmt, md_table, pyplot, save_figure

SHOWN = 30   # rows of the table in the report (every job is in trajectories.csv)
DRAWN = 4    # jobs drawn side by side
UNREADABLE = "cannot be read"  # the note of a job whose saved file in A or B cannot be loaded


def parting(path_a: Path, path_b: Path, threshold: float = PARTED) -> dict:
    """How one job's two trajectories part: the first step and time past `threshold` (of the
    job's scales), the body and state component that parted first, the largest relative
    difference, and a note when they cannot be compared step by step (or a file cannot be
    read: damaged, or not a saved trajectory)."""
    try:
        ta, _ = load(path_a)
        tb, _ = load(path_b)
    except (OSError, EOFError, ValueError, KeyError, zipfile.BadZipFile) as exc:
        why = (str(exc).splitlines() or [""])[0][:200]
        return {"job": Path(path_a).stem, "note": f"{UNREADABLE}: {type(exc).__name__}: {why}"}
    out = {"job": Path(path_a).stem, "steps": min(len(ta.t), len(tb.t)) - 1, "parted_step": np.nan,
           "parted_time": np.nan, "first_to_part": "", "body": "", "column": -1, "largest": 0.0, "note": ""}
    if not np.isclose(ta.dt, tb.dt, rtol=1e-12, atol=0):
        return out | {"note": f"time steps differ ({ta.dt:g} s and {tb.dt:g} s): not compared step by step"}
    if len(ta.t) != len(tb.t):
        out["note"] = f"lengths differ ({len(ta.t)} and {len(tb.t)} samples): the common ones compared"
    if set(ta.states) != set(tb.states):
        out["note"] = (out["note"] + "; " if out["note"] else "") + "the runs hold different bodies"
    worst, per_body = _apart(ta, tb, out["steps"] + 1)
    out["largest"] = float(worst.max(initial=0.0))
    if where := first_past(worst, per_body, threshold):
        k = where["step"]
        out |= {"parted_step": k, "parted_time": float(ta.t[k]), "first_to_part": where["what"],
                "body": where["body"], "column": where["column"]}
    return out


def measure(dir_a: Path, dir_b: Path) -> pd.DataFrame:
    """One row per job saved by both runs (see `parting`), the jobs that part the most first;
    jobs saved by one run only are rows with a note."""
    a = {p.name: p for p in Path(dir_a).glob("*.npz")}
    b = {p.name: p for p in Path(dir_b).glob("*.npz")}
    rows = [parting(a[name], b[name]) for name in sorted(set(a) & set(b))]
    rows += [{"job": Path(name).stem, "note": f"saved in {'A' if name in a else 'B'} only"}
             for name in sorted(set(a) ^ set(b))]
    df = pd.DataFrame(rows, columns=["job", "steps", "parted_step", "parted_time", "first_to_part", "body", "column",
                                     "largest", "note"])
    return df.sort_values(["largest", "parted_step"], ascending=[False, True], na_position="last",
                          ignore_index=True)


def section(df: pd.DataFrame, figure: str | None) -> list[str]:
    """The report's section: how many jobs part, where the worst part, and the figure."""
    parted = df[df.parted_step.notna()]
    compared = df[df.steps.notna() & ~df.note.fillna("").str.startswith("time steps differ")]
    lines = ["## Trajectories", "",
             f"{len(compared)} jobs saved by both runs compared step by step: {len(parted)} part (some state "
             f"differs by more than {PARTED:g} of its scale), {len(compared) - len(parted)} do not "
             f"({int((compared.largest == 0).sum())} identical to the last bit). Scales are the job's: its size L "
             "(the largest distance of a body from the origin), its speed (the largest, at least sqrt(g L)) and "
             "rate of turning (the largest, at least speed / L); a quaternion's is 1. "
             f"{PARTED:g} lies seven orders above one double's rounding and below anything a plot can show.", ""]
    if figure:
        lines += [f"![the trajectories that part the most, side by side]({figure})", ""]
    if len(parted):
        shown = parted.head(SHOWN)
        lines += [md_table(pd.DataFrame({
            "job": shown.job, "parts at step": shown.parted_step.astype(int), "time s": shown.parted_time.map(fmt),
            "first to part": shown.first_to_part, "largest difference (of scale)": shown.largest.map(fmt),
            "note": shown.note.fillna("")})), ""]
        if len(parted) > SHOWN:
            lines += [f"... and {len(parted) - SHOWN} more in trajectories.csv.", ""]
    other = df[df.note.fillna("").ne("") & df.parted_step.isna()]
    if len(other):
        lines += [f"Not compared or one-sided: {len(other)} jobs (trajectories.csv says why).", ""]
    return lines


def plot(df: pd.DataFrame, dir_a: Path, dir_b: Path, path: Path, names: tuple[str, str]) -> bool:
    """The DRAWN jobs that part the most, one row each: left, the state component that parted
    first over time in A and B; right, how far apart the two runs are (relative to the
    state's scale, log) with PARTED and the step where they part. False if none parts."""
    worst = df[df.parted_step.notna()].head(DRAWN)
    if not len(worst):
        return False
    plt = pyplot()
    fig, axes = plt.subplots(len(worst), 2, figsize=(11, 2.6 * len(worst)), layout="constrained", squeeze=False)
    for (left, right), r in zip(axes, worst.itertuples()):
        ta, _ = load(Path(dir_a) / f"{r.job}.npz")
        tb, _ = load(Path(dir_b) / f"{r.job}.npz")
        body, col, n = r.body, int(r.column), int(r.steps) + 1
        left.plot(ta.t[:n], ta.states[body][:n, col], label=f"A ({Path(names[0]).name})", lw=1.6)
        left.plot(tb.t[:n], tb.states[body][:n, col], label=f"B ({Path(names[1]).name})", lw=1.0, ls="--")
        left.axvline(r.parted_time, color="k", ls=":", lw=0.8)
        left.set_title(f"{r.job}: {r.first_to_part}", fontsize=8)
        left.set_xlabel("t (s)", fontsize=8)
        left.legend(fontsize=7)
        gap = _apart(ta, tb, n)[0]
        right.semilogy(ta.t[:n], np.clip(gap, 1e-17, None), color="tab:red", lw=1)
        right.axhline(PARTED, color="k", ls="--", lw=0.8, label=f"parted: {PARTED:g} of the scale")
        right.axvline(r.parted_time, color="k", ls=":", lw=0.8)
        right.set_title(f"largest difference / scale (parts at step {int(r.parted_step)}, "
                        f"t = {r.parted_time:.4g} s)", fontsize=8)
        right.set_xlabel("t (s)", fontsize=8)
        right.legend(fontsize=7)
    save_figure(fig, path)
    return True
