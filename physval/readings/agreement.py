"""Cross-engine agreement: on families tagged `cross_engine` (scenes without a full closed
form, whose checks are the well-posed quantities: rest face, total impulse, energy
dissipated, post-impact velocities), each quantity's value on every engine side by side,
its spread across engines and each engine's distance from the reference.

An engine agrees with the reference on a quantity when the two measured values differ by
no more than the check's own tolerance (absolute, or relative to the reference's value).
The verdicts judge each engine against the closed form; this reading answers the other
question users ask: do the engines agree with each other?
"""
from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pandas as pd

from physval.core.tolerance import errors
from physval.report import fmt, md_table, pyplot, save_figure, write_atomic

REFERENCE = "reference"


def distance(check_kind: str, measured: float, reference: float) -> float:
    """|measured - reference| in the check's own terms: absolute, or relative to the
    reference (NaN for a relative check when the reference reads 0)."""
    abs_err, rel_err = errors(reference, measured)
    return abs_err if check_kind == "abs" else rel_err


def measure(df: pd.DataFrame, families: set[str]) -> pd.DataFrame:
    """One row per (case, variant, metric) of the flagged families: each engine's value,
    the spread (max - min over engines), and the worst engine's distance from the
    reference in units of the tolerance (<= 1: agrees)."""
    part = df[df.case.isin(families) & df.measured.notna() & ~df.status.isin(["unsupported", "error", "unstable"])]
    part = part[~part.engine.str.startswith(REFERENCE + "-")]  # the reference at its default formulation
    out = []
    for (case, variant, metric), grp in part.groupby(["case", "variant", "metric"], sort=False):
        first = grp.iloc[0]
        values = dict(zip(grp.engine, grp.measured.astype(float)))
        row = {"case": case, "variant": variant, "metric": metric, "unit": first.unit,
               "expected": float(first.expected), "tolerance": float(first.tolerance),
               "kind": first.tolerance_kind, **values,
               "spread": max(values.values()) - min(values.values()) if len(values) > 1 else math.nan}
        ref = values.get(REFERENCE)
        others = {e: v for e, v in values.items() if e != REFERENCE}
        if ref is not None and others:
            worst = max(others, key=lambda e: distance(first.tolerance_kind, others[e], ref))
            row["worst engine"] = worst
            row["worst / tolerance"] = distance(first.tolerance_kind, others[worst], ref) / float(first.tolerance)
        out.append(row)
    engines = list(dict.fromkeys(part.engine))
    head = ["case", "variant", "metric", "unit", "expected", "tolerance", "kind"]
    tail = ["spread", "worst engine", "worst / tolerance"]
    return pd.DataFrame(out, columns=head + engines + tail) if out else pd.DataFrame()


def plot(agree: pd.DataFrame, path: Path) -> None:
    """Each engine's distance from the reference, in tolerances, per quantity."""
    engines = [c for c in agree.columns[7:-3] if c != REFERENCE]
    agree = agree[agree[REFERENCE].notna()] if REFERENCE in agree else agree.iloc[0:0]
    if not len(agree):
        return
    plt = pyplot()
    fig, ax = plt.subplots(figsize=(max(6.0, 0.32 * len(agree)), 4.6), layout="constrained")
    x = np.arange(len(agree))
    for i, eng in enumerate(engines):
        signed = [(1 if v >= r else -1) * distance(k, v, r) / t if t > 0 else math.nan
                  for v, r, t, k in zip(agree[eng], agree[REFERENCE], agree.tolerance, agree.kind)]
        ax.scatter(x + 0.08 * (i - len(engines) / 2), signed, s=14, label=eng)
    ax.axhspan(-1, 1, color="tab:green", alpha=0.12, label="within the check's tolerance")
    ax.set_yscale("symlog", linthresh=1)
    ax.set_xticks(x, [f"{c}[{v}]:{m}" for c, v, m in zip(agree.case, agree.variant, agree.metric)],
                  rotation=90, fontsize=6)
    ax.set_ylabel("(engine - reference) / tolerance")
    ax.legend(fontsize=7, ncol=2)
    save_figure(fig, path)


def family_summary(agree: pd.DataFrame) -> pd.DataFrame:
    """Per family: quantities compared, how many every engine agrees on, the worst engine."""
    out = []
    for case, grp in agree.groupby("case", sort=False):
        worst = grp["worst / tolerance"].astype(float)
        i = worst.idxmax() if worst.notna().any() else None
        out.append({"family": case, "quantities": len(grp), "all engines agree": int((worst <= 1).sum()),
                    "worst": f"{grp.loc[i, 'worst engine']} on {grp.loc[i, 'variant']}:{grp.loc[i, 'metric']} "
                             f"({worst[i]:.3g} tol)" if i is not None else "-"})
    return pd.DataFrame(out)


def section(agree: pd.DataFrame, out: Path) -> str:
    write_atomic(Path(out) / "agreement.csv", agree.to_csv(index=False))
    plot(agree, Path(out) / "plots" / "agreement.png")
    shown = agree.drop(columns=["kind"]).copy()
    for col in shown.columns:
        if shown[col].dtype.kind == "f":
            shown[col] = shown[col].map(fmt)
    return "\n".join(["## Cross-engine agreement", "",
                      "Families without a full closed form, checked on their well-posed quantities (tag "
                      "`cross_engine`; also in `agreement.csv`): every engine's value side by side, the spread "
                      "across engines, and the engine farthest from the reference in units of the check's "
                      "tolerance (<= 1: it agrees with the reference).", "",
                      md_table(family_summary(agree)), "",
                      "![engines against the reference](plots/agreement.png)", "",
                      "<details><summary>Every quantity</summary>", "", md_table(shown), "", "</details>", ""])
