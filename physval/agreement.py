"""Cross-engine agreement: on families flagged `cross_engine` (scenes without a full
closed form, whose checks are the well-posed quantities: rest face, total impulse, energy
dissipated, post-impact velocities), each quantity's value on every engine side by side,
its spread across engines and each engine's distance from the reference.

An engine agrees with the reference on a quantity when the two measured values differ by
no more than the check's own tolerance (absolute, or relative to the reference's value).
The verdicts of results.csv still judge each engine against the closed form; this table
answers the other question users ask: do the engines agree with each other?
"""
from __future__ import annotations

import math

import pandas as pd

from physval.metrics import errors

REFERENCE = "reference"


def distance(check_kind: str, measured: float, reference: float) -> float:
    """|measured - reference| in the check's own terms: absolute, or relative to the
    reference (NaN for a relative check when the reference reads 0)."""
    abs_err, rel_err = errors(reference, measured)
    return abs_err if check_kind == "abs" else rel_err


def table(df: pd.DataFrame, families: set[str]) -> pd.DataFrame:
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
