"""Errors and verdicts: how a measured value is judged against its closed form."""
from __future__ import annotations

import math

from cases.family import Check

STATUSES = ("pass", "fail", "deviation", "unsupported", "unstable", "error")


def errors(expected: float, measured: float) -> tuple[float, float]:
    """(absolute, relative) error; relative is NaN when the expected value is 0."""
    if measured is None or not math.isfinite(measured):
        return math.nan, math.nan
    abs_err = abs(measured - expected)
    rel_err = abs_err / abs(expected) if expected != 0 else math.nan
    return abs_err, rel_err


def within(check: Check, abs_err: float, rel_err: float) -> bool:
    """True when the error the check's tolerance bounds is within it."""
    err = abs_err if check.kind == "abs" else rel_err
    return math.isfinite(err) and err <= check.tolerance


def error_over_tolerance(check: Check, abs_err: float, rel_err: float) -> float:
    """How many tolerances away the measurement is (1 = at the edge); for ranking."""
    err = abs_err if check.kind == "abs" else rel_err
    if not math.isfinite(err):
        return math.inf
    return err / check.tolerance if check.tolerance > 0 else (0.0 if err == 0 else math.inf)
