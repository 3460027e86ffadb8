"""Implementation parity: one engine and its port (MuJoCo C and MuJoCo Warp) run the same
scenes, and each check and each trajectory of the port is set against the original's.

Per check: the port's value minus the original's in units of the check's tolerance (in the
check's units: `tolerance`, or `tolerance * |expected|` for a relative one; the wider of the
two engines' rows, i.e. at the narrower float width, whose round-off share it includes, so a
float32 port's rounding counts as what the checks allow it), so 0.01 reads "the port moved
1 % of what the closed form allows", and whether the two got different verdicts. Per job: the step at which the two trajectories part
(physval.readings.divergence.parting), where some state first differs by more than PARTED
of the job's scale. divergence.PARTED (1e-9, what `physval compare` uses between two runs of
one double engine) would part a float32 port from its original in free flight by rounding
alone: at 16 float32 unit round-offs (9.5e-7) central_impact's dropped balls part 718 steps
into their fall, before any contact (measured). A thousandth of the scale
(1 mm on a scene of a metre, 4 mm/s on a metre's fall) is what a plot shows and float32
rounding of the battery's runs does not reach, so a pair that parts there behaves
differently, not merely rounds differently.

`checks` joins a run's rows of the two engines, `parting` their saved trajectories;
`families` sums both up per family; `write` writes parity.md, parity.csv (every check) and parting.csv (every
job).
"""
from __future__ import annotations

from pathlib import Path

import numpy as np
import pandas as pd

from physval.readings import divergence
from physval.reportkit import fmt, heading, md_table, write_atomic, write_csv

JUDGED = ("pass", "fail", "deviation")
SHOWN = 25  # rows of the largest-moves table (every check is in parity.csv)


PARTED = 1e-3  # of the job's scales (the module's docstring)


def _tolerance(df: pd.DataFrame) -> pd.Series:
    """Each check's tolerance in its own units (a relative one times |expected|)."""
    tol = pd.to_numeric(df.tolerance, errors="coerce")
    rel = df.tolerance_kind.eq("rel")
    return tol.where(~rel, tol * pd.to_numeric(df.expected, errors="coerce").abs())


def checks(rows: pd.DataFrame, a: str, b: str) -> pd.DataFrame:
    """One row per check run on both engines: both statuses and values, and the port's
    difference in the check's tolerance at the narrower float width (`difference`, NaN where
    either was not judged)."""
    keep = ["case", "variant", "metric", "status", "measured", "expected", "tolerance", "tolerance_kind", "reason"]
    left = rows[rows.engine == a][keep].assign(tol=lambda d: _tolerance(d))
    right = rows[rows.engine == b][keep].assign(tol=lambda d: _tolerance(d)).drop(columns=["expected",
                                                                                          "tolerance_kind"])
    df = left.merge(right, on=["case", "variant", "metric"], suffixes=("_a", "_b"))
    df["tol"] = np.fmax(df.tol_a, df.tol_b)  # at the narrower float width (NaN only where both are)
    df = df.rename(columns={"tolerance_a": "tolerance"}).drop(columns=["tol_a", "tol_b", "tolerance_b"])
    both = df.status_a.isin(JUDGED) & df.status_b.isin(JUDGED)
    diff = (pd.to_numeric(df.measured_b, errors="coerce") - pd.to_numeric(df.measured_a, errors="coerce")) / df.tol
    df["difference"] = diff.where(both & (df.tol > 0))
    # a scene only one engine can represent (a 3D variant against a 2D engine) is no verdict
    # of the other: counted apart, not as a verdict that differs
    one = df.status_a.eq("unsupported") ^ df.status_b.eq("unsupported")
    df["one_engine_only"] = one
    df["verdicts_differ"] = df.status_a.ne(df.status_b) & ~one
    return df.drop(columns="tol").reset_index(drop=True)


def parting(jobs: list[tuple[str, str, Path, Path]], threshold: float) -> pd.DataFrame:
    """(case, variant, trajectory of A, of B) -> where each pair parts (divergence.parting)."""
    out = []
    for case, variant, path_a, path_b in jobs:
        if path_a.is_file() and path_b.is_file():
            out.append({"case": case, "variant": variant, **divergence.parting(path_a, path_b, threshold)})
        else:
            out.append({"case": case, "variant": variant, "note": "no trajectory from both engines"})
    return pd.DataFrame(out, columns=["case", "variant", "job", "steps", "parted_step", "parted_time",
                                      "first_to_part", "body", "column", "largest", "note"])


def families(table: pd.DataFrame, parts: pd.DataFrame) -> pd.DataFrame:
    """Per family: checks compared, those of scenes only one engine represents, verdicts that
    differ (both ran the scene), the median and largest |difference|
    in tolerances (and the check of the largest), jobs compared, how many part and the
    earliest and median parting time."""
    out = []
    for case in sorted(set(table.case) | set(parts.case)):
        t, p = table[table.case == case], parts[(parts.case == case) & parts.steps.notna()]
        d = t.difference.abs()
        worst = t.loc[d.idxmax()] if d.notna().any() else None
        parted = p[p.parted_step.notna()]
        out.append({"family": case, "checks": len(t), "judged on both": int(d.notna().sum()),
                    "one engine only": int(t.one_engine_only.sum()),
                    "verdicts differ": int(t.verdicts_differ.sum()),
                    "median |diff| (tol)": float(d.median()) if d.notna().any() else np.nan,
                    "largest |diff| (tol)": float(d.max()) if d.notna().any() else np.nan,
                    "largest at": f"[{worst.variant}]:{worst.metric}" if worst is not None else "",
                    "jobs": len(p), "part": len(parted),
                    "first parting s": float(parted.parted_time.min()) if len(parted) else np.nan,
                    "median parting s": float(parted.parted_time.median()) if len(parted) else np.nan})
    return pd.DataFrame(out)


def write(folder: Path, table: pd.DataFrame, parts: pd.DataFrame, a: str, b: str, threshold: float,
          command: str = "", versions: dict | None = None) -> list[Path]:
    """parity.md, parity.csv and parting.csv in `folder`."""
    fams = families(table, parts)
    d = table.difference.abs()
    judged = int(d.notna().sum())
    parted = parts[parts.parted_step.notna()]
    lines = heading(f"Implementation parity: {a} and {b}", command)
    if versions:
        lines += ["Releases: " + "; ".join(f"{e} {v}" for e, v in versions.items()), ""]
    lines += [
        f"The same scenes on both engines. Each check's difference is {b}'s value minus {a}'s in units of "
        f"the check's tolerance (the wider of the two engines', at the narrower float width); a trajectory pair parts at the first step where some state differs "
        f"by more than {threshold:.2g} of the job's scale (physval.readings.parity).", "",
        f"{len(table)} checks on both engines, {judged} judged on both: median |difference| "
        f"{fmt(float(d.median())) if judged else '-'} tolerances, {int((d > 1).sum())} differ by more than one "
        f"tolerance, {int(table.verdicts_differ.sum())} verdicts differ"
        + (f" ({int(table.one_engine_only.sum())} more checks are of scenes only one engine can represent)"
           if table.one_engine_only.any() else "") + ". "
        f"{int(parts.steps.notna().sum())} trajectory pairs: {len(parted)} part.", "",
        "## Per family", "", md_table(fams.map(fmt) if hasattr(fams, "map") else fams.applymap(fmt)), "",
        "## The largest differences", ""]
    top = table[d.notna()].assign(size=d).sort_values("size", ascending=False).head(SHOWN)
    lines += [md_table(pd.DataFrame({
        "check": top.case + "[" + top.variant + "]:" + top.metric, f"{a}": top.measured_a, f"{b}": top.measured_b,
        "expected": top.expected, "difference (tol)": top.difference.map(fmt),
        "verdicts": top.status_a + " / " + top.status_b})), ""]
    differ = table[table.verdicts_differ]
    lines += ["## Verdicts that differ", "", md_table(pd.DataFrame({
        "check": differ.case + "[" + differ.variant + "]:" + differ.metric, f"{a}": differ.status_a,
        f"{b}": differ.status_b, "difference (tol)": differ.difference.map(fmt),
        f"{b}'s reason": differ.reason_b.str.slice(0, 140)})), ""]
    lines += ["## Where the trajectories part", "", md_table(pd.DataFrame({
        "job": parted.case + "[" + parted.variant + "]", "step": parted.parted_step.astype(int),
        "time s": parted.parted_time.map(fmt), "first to part": parted.first_to_part,
        "largest difference (of scale)": parted.largest.map(fmt)}).sort_values("time s", key=lambda s: s.astype(float))
        if len(parted) else parted), ""]
    folder.mkdir(parents=True, exist_ok=True)
    write_atomic(folder / "parity.md", "\n".join(lines))
    write_csv(table, folder / "parity.csv")
    write_csv(parts, folder / "parting.csv")
    return [folder / "parity.md", folder / "parity.csv", folder / "parting.csv"]
