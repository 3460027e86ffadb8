"""The invariance battery's section of the report: each engine against each relation of
cases.relations (a scene run as given and transformed, compared through the transformation:
physval.core.invariance), and every broken invariance with the step at which the two runs
part, what parted first and the largest difference.

A cell reads: `=` the two runs identical to the last bit; `ok` within the engine's promise
(round-off at its float width), with the largest difference (of the quantity's scale in the
job); a number (in bold where it fails, plain where it is a recorded known deviation) the
largest difference and `@k` the step the runs part at; `-` unsupported (the reason is on the
Unsupported page). Where a relation ran on two scenes (rotate_vertical: a slide and a box
stack), the worse of the two is shown.
"""
from __future__ import annotations

import pandas as pd

from cases.relations import METRIC_PREFIX as PREFIX
from physval.core.invariance import parted_at
from physval.report import fmt, md_table

RANK = {"fail": 0, "unstable": 1, "error": 2, "deviation": 3, "pass": 4, "unsupported": 5}
SHOWN = 40  # findings listed in the report (every one is in results.csv)


def measure(df: pd.DataFrame) -> pd.DataFrame:
    """The battery's rows: engine, relation, scene, status, largest difference, tolerance,
    the step the runs part at (-1: they do not), the reason."""
    mine = df[df.metric.astype(str).str.startswith(PREFIX)]
    if not len(mine):
        return pd.DataFrame()
    return pd.DataFrame({
        "engine": mine.engine, "relation": mine.metric.str[len(PREFIX):],
        "scene": mine.case + "[" + mine.variant.astype(str) + "]", "status": mine.status,
        "largest": pd.to_numeric(mine.measured, errors="coerce"),
        "tolerance": pd.to_numeric(mine.tolerance, errors="coerce"),
        "parts_at": [parted_at(r) for r in mine.reason.fillna("")], "reason": mine.reason.fillna(""),
        "known_deviation": mine.known_deviation.fillna("")}).reset_index(drop=True)


def cell(r) -> str:
    if r.status == "unsupported":
        return "-"
    if r.status in ("unstable", "error"):
        return r.status
    if r.status == "pass":
        return "=" if r.largest == 0 else f"ok {fmt(r.largest)}"
    text = f"{fmt(r.largest)} @{r.parts_at}" if r.parts_at >= 0 else fmt(r.largest)
    return f"**{text}**" if r.status == "fail" else text


def grid(rows: pd.DataFrame) -> pd.DataFrame:
    """Engines as rows, relations as columns, each cell its worst scene's (`cell`)."""
    worst = rows.assign(rank=rows.status.map(RANK).fillna(9)).sort_values(["rank", "largest"], ascending=[True, False])
    worst = worst.drop_duplicates(["engine", "relation"])
    table = worst.assign(cell=[cell(r) for r in worst.itertuples()]).pivot(index="engine", columns="relation",
                                                                           values="cell")
    relations = list(dict.fromkeys(rows.relation))
    engines = list(dict.fromkeys(rows.engine))
    return table.loc[engines, relations].fillna("").reset_index()


LEGEND = ("Each relation runs a scene twice, as given and transformed (turned, moved, mirrored, scaled, built in "
          "another order, given as a hull or a mesh, on 4 threads, as world 3 of a batch of 4, saved and restored "
          "midway), and compares the second run, mapped back through the transformation, with the first, state by "
          "state, relative to each quantity's scale in the scene. Each is judged against what the engine promises: "
          "bit-identical, or round-off at its declared float width and the coordinates' size. A cell: `=` identical "
          "to the last bit; `ok d` within the promise, largest difference d; `d @k` a broken invariance (bold: "
          "failing; plain: a recorded known deviation) with its largest difference d and the step k at which the two "
          "runs part; `-` unsupported (a shape, a mode the engine lacks). Where a relation ran on two scenes the "
          "worse is shown. [The invariance battery's page in the docs] explains each relation and its promise.")


def section(rows: pd.DataFrame) -> str:
    if rows is None or not len(rows):
        return ""
    broken = rows[rows.status.isin(["fail", "deviation", "unstable", "error"])].sort_values(
        ["engine", "relation"], kind="stable")
    lines = ["## Invariance", "", LEGEND.replace("[The invariance battery's page in the docs]",
                                                 "The invariance battery's page in the docs"), "",
             md_table(grid(rows)), ""]
    if len(broken):
        shown = broken.head(SHOWN)
        lines += ["### Broken invariances", "",
                  f"{len(broken)} relation runs part by more than the engine promises; where the run parts first and "
                  "in what (the reason), and the recorded cause of a known deviation:", "",
                  md_table(pd.DataFrame({
                      "engine": shown.engine, "relation": shown.relation, "scene": shown.scene,
                      "largest (of scale)": shown.largest.map(fmt), "parts at step": [
                          str(k) if k >= 0 else "" for k in shown.parts_at],
                      "status": shown.status, "cause": shown.known_deviation.str.slice(0, 160)})), ""]
        if len(broken) > SHOWN:
            lines += [f"... and {len(broken) - SHOWN} more in results.csv (metric `{PREFIX}*`).", ""]
    return "\n".join(lines)
