"""A measurement's error and the tolerance that bounds it: the arithmetic the verdicts
(physval.core.verdicts) and the known-deviation bands (physval.core.deviations) share, kept
below both so that neither imports the other for it."""
from __future__ import annotations

import math

from cases.family import Check


def errors(expected: float, measured: float) -> tuple[float, float]:
    """(absolute, relative) error; relative is NaN when the expected value is 0."""
    if measured is None or not math.isfinite(measured):
        return math.nan, math.nan
    abs_err = abs(measured - expected)
    rel_err = abs_err / abs(expected) if expected != 0 else math.nan
    return abs_err, rel_err


def tolerance_units(expected: float, tolerance: float, kind: str) -> float:
    """A check's tolerance in the check's own units: `tolerance` for an absolute one,
    `tolerance * |expected|` for a relative one."""
    return tolerance if kind == "abs" else tolerance * abs(expected)


def within(check: Check, abs_err: float, rel_err: float) -> bool:
    """True when the error the check's tolerance bounds is within it."""
    err = abs_err if check.kind == "abs" else rel_err
    return math.isfinite(err) and err <= check.tolerance

