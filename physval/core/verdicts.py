"""Verdicts: how a measured value is judged against its closed form and the known
deviations, and the rows that carry the verdicts (the columns of results.csv).

Statuses:
- pass         within the check's tolerance;
- fail         outside it and not a recorded deviation (or a recorded one whose measured
               value left its band: the deviation changed);
- deviation    outside the tolerance, inside the band a known-deviation entry records
               for exactly this check (physval/core/deviations.py);
- unsupported  the engine cannot represent the scene (the reason says why);
- unstable     the engine's own state became NaN or infinite, or blew up;
- error        an exception: in the engine (a crash), or in the case's own code
               (an observer that raised or returned no finite number), named in the reason.
"""
from __future__ import annotations

import csv
import json
import math

from cases.family import Check
from physval.core import deviations
# the reasons that open a row whose known deviation moved: out of its band, or onto the
# closed form (both a fail); `physval run --fail-on changed,vanished` gates on them
from physval.core.deviations import CHANGED, VANISHED
from physval.core.tolerance import errors, tolerance_units, within

STATUSES = ("pass", "fail", "deviation", "unsupported", "unstable", "error")

COLUMNS = ["case", "variant", "params", "engine", "engine_version", "dt", "iterations", "effects",
           "effects_simulated", "metric", "unit", "expected", "measured", "abs_error", "rel_error",
           "tolerance", "tolerance_kind", "tolerance_reason", "measures", "status", "reason", "known_deviation",
           "band", "wall_s", "sim_s", "steps", "job_s", "compile_s", "first_in_worker", "knobs"]
# wall_s: stepping alone; job_s: the job's whole time in its worker (building the scene and the
# engine, stepping, recording, observing, judging): what the run's cost model reads; compile_s:
# of job_s, numba getting the reference's code ready (compiling it on a first run after an install
# or an edit of reference_impl); first_in_worker: 1 where the job was its engine's first in its
# worker, so that job_s holds the engine's start (imports, kernel compiles). The cost model leaves
# out the jobs of either kind (physval.readings.cost.priceable)


def judge(c: Check, value: float, engine: str, variant: str, entry: deviations.Deviation | None,
          bands_apply: bool = True) -> dict:
    """The verdict fields of one check measured at `value` (a finite number). `entry` is
    the first known-deviation entry whose pattern matches the check; `bands_apply` is
    False at settings other than those bands are recorded at (the family's dt, the
    adapter's default iterations)."""
    abs_err, rel_err = errors(c.expected, value)
    size = abs_err if c.kind == "abs" else rel_err
    band = entry.band(engine, variant, c.metric) if entry else None
    fields = dict(measured=value, abs_error=abs_err, rel_error=rel_err,
                  known_deviation=entry.cause if entry else "", band=band.describe() if band else "")
    outside = f"{c.kind} error {size:.3g} > tolerance {c.tolerance:.3g}"
    if within(c, abs_err, rel_err):
        if band is not None and bands_apply:  # the engine (or its mapping) changed: physval known ENGINE --write
            vanished = (f"{VANISHED}: {entry.pattern} ({entry.where}) records {band.describe()}, measured {value:.6g} "
                        f"{c.unit}, within the tolerance")
            if band.holds(value):
                return dict(fields, status="pass", reason=vanished)
            # out of its band onto the closed form: a change of the engine or of its mapping is a fail whichever
            # way the measurement moved (decision 8), or a fault that moves a known deviation onto the closed form
            # (a 2 mm contact offset on Drake's sinking stacks) would pass
            return dict(fields, status="fail", reason=f"{vanished} but outside the band: the engine or its mapping "
                                                      f"changed (`{entry.remeasure(engine)}`){_release_of(entry)}")
        return dict(fields, status="pass")
    if entry is None:
        return dict(fields, status="fail", reason=outside)
    where = f"known deviation {entry.pattern} ({entry.where})"
    if band is None:
        return dict(fields, status="fail", reason=(
            f"{outside}; matches {where} but no band is recorded for this check on {engine}: "
            f"`{entry.remeasure(engine)}` measures it"))
    if not bands_apply:
        return dict(fields, status="fail", reason=(
            f"{outside}; {where} is recorded at the family's dt and the adapter's default iterations only"))
    if band.holds(value):
        if (wide := entry.too_wide(band, tolerance_units(c.expected, c.tolerance, c.kind))) is not None:
            return dict(fields, status="fail", reason=f"{outside}; {wide}")
        return dict(fields, status="deviation", reason=(
            f"{entry.cause} [measured {value:.6g} {c.unit} in the recorded band {band.describe()}; "
            f"expected {c.expected:.6g}: {outside}]"))
    return dict(fields, status="fail", reason=(
        f"{CHANGED}: recorded {band.describe()}, measured {value:.6g} {c.unit} "
        f"({where}: {entry.cause}){_release_of(entry)}"))


def _release_of(entry: deviations.Deviation) -> str:
    """Where a recorded band judged a release it was not measured on, the note that says so
    ("; bands measured on drake 1.51.1, this run 1.60.0"): the fail may be the release's."""
    return f"; {entry.off_release}" if entry.off_release else ""


def blank_row(case: str, variant, engine: str, check: Check, **fields) -> dict:
    """A row of one check with every column present (empty where not known)."""
    row = {c: "" for c in COLUMNS}
    row.update(case=case, variant=variant.id, params=variant.params_json, engine=engine,
               metric=check.metric, unit=check.unit, expected=check.expected, tolerance=check.tolerance,
               tolerance_kind=check.kind, tolerance_reason=check.why, measures=check.measures, measured=math.nan,
               abs_error=math.nan, rel_error=math.nan)
    row.update(fields)
    return row


def contract_problems(path) -> list[str]:
    """What in a results.csv breaks the table contract, one line each (empty: it holds).
    Form, not physics: the columns of COLUMNS first, in that order; a known status; a reason on
    every row that is not a pass; params as a JSON object; numbers that parse; a pass
    whose error, of its check's own kind, lies within the tolerance; a deviation that
    names its entry and band."""
    found = []
    with open(path, newline="") as fh:
        reader = csv.DictReader(fh)
        if (reader.fieldnames or [])[:len(COLUMNS)] != COLUMNS:  # the row store's own columns may follow
            return [f"columns {reader.fieldnames} do not begin with {COLUMNS}"]
        for line, row in enumerate(reader, start=2):
            where = f"line {line} ({row['case']}[{row['variant']}] / {row['engine']} / {row['metric']})"
            status = row["status"]
            if status not in STATUSES:
                found.append(f"{where}: status {status!r} is not one of {', '.join(STATUSES)}")
            if status != "pass" and not row["reason"].strip():
                found.append(f"{where}: status {status} without a reason")
            try:
                params = json.loads(row["params"] or "{}")
                if not isinstance(params, dict):
                    raise ValueError
            except ValueError:
                found.append(f"{where}: params {row['params']!r} is not a JSON object")
            numbers = {}
            for col in ("dt", "expected", "measured", "abs_error", "rel_error", "tolerance", "wall_s", "sim_s", "job_s",
                        "compile_s", "first_in_worker"):
                try:
                    numbers[col] = float(row[col]) if row[col] != "" else math.nan
                except ValueError:
                    found.append(f"{where}: {col} {row[col]!r} is not a number")
            if status in ("pass", "fail", "deviation") and row["tolerance_kind"] not in ("abs", "rel"):
                found.append(f"{where}: tolerance_kind {row['tolerance_kind']!r} is not abs or rel")
            if status == "pass" and row["tolerance_kind"] in ("abs", "rel"):
                err = numbers.get(f"{row['tolerance_kind']}_error", math.nan)
                if not err <= numbers.get("tolerance", math.nan):
                    found.append(f"{where}: pass with {row['tolerance_kind']} error {err} > tolerance "
                                 f"{numbers.get('tolerance')}")
            if status == "deviation" and not (row["known_deviation"].strip() and row["band"].strip()):
                found.append(f"{where}: deviation without its entry and band")
    return found
