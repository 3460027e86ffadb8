"""The checks of a run as a frame, and the tables several readings draw from it: status
counts, the family x engine summary, known deviations, failures, unsupported runs, each
family's measured values and tolerance reasons. Every status is one of
physval.core.STATUSES; a report shows it by its mark (STATUS_MARK)."""
from __future__ import annotations

from collections import Counter

import numpy as np
import pandas as pd

from physval.core.verdicts import STATUSES
from physval.report import fmt, md_table

STATUS_MARK = dict(zip(STATUSES, ("pass", "FAIL", "dev", "n/a", "UNSTABLE", "ERROR")))
NUMERIC = ("expected", "measured", "abs_error", "rel_error", "tolerance", "wall_s", "sim_s", "job_s", "compile_s",
           "first_in_worker", "dt")
FORMULATION_PREFIX = "reference-"  # the reference's other formulations, summarised apart from the engines


def status_class(text) -> str:
    """The CSS class of a table cell that ends in a status mark ("3 pass 1 dev" -> s-dev)."""
    words = str(text).split()
    return f"s-{words[-1]}" if words and words[-1] in STATUS_MARK.values() else ""


def frame(rows: list[dict], columns: list[str]) -> pd.DataFrame:
    """Rows as a frame with numeric columns as numbers and `over_tol`: each judged check's
    error in units of its tolerance (1 = at the edge)."""
    df = pd.DataFrame(rows, columns=columns)
    for col in df.columns:
        if col in NUMERIC:
            df[col] = pd.to_numeric(df[col], errors="coerce")
        else:
            df[col] = df[col].astype(object).where(df[col].notna(), "")
    judged = df.status.isin(["pass", "fail", "deviation"])
    err = np.where(df.tolerance_kind == "rel", df.rel_error, df.abs_error).astype(float)
    tol = df.tolerance.to_numpy(dtype=float)
    with np.errstate(divide="ignore", invalid="ignore"):
        over = np.where(tol > 0, err / tol, np.where(err == 0, 0.0, np.inf))
    df["over_tol"] = np.where(judged & np.isfinite(err), over, np.where(judged, np.inf, np.nan))
    return df


def status_counts(df: pd.DataFrame) -> str:
    counts = Counter(df.status)
    return ", ".join(f"{counts[s]} {s}" for s in STATUSES if counts[s])


def engine_versions(df: pd.DataFrame) -> dict[str, str]:
    return {e: v for e, v in df.groupby("engine")["engine_version"].first().items()}


def engine_groups(df: pd.DataFrame) -> list[tuple[str, list[str]]]:
    """("Engines", the engines users run and the reference), then ("Reference
    formulations", the reference's other formulations): those that ran."""
    engines = list(dict.fromkeys(df.engine))
    plain = [e for e in engines if not e.startswith(FORMULATION_PREFIX)]
    forms = [e for e in engines if e.startswith(FORMULATION_PREFIX)]
    return [(t, g) for t, g in (("Engines", plain), ("Reference formulations", forms)) if g]


def summary_matrix(df: pd.DataFrame, engines: list[str] | None = None) -> pd.DataFrame:
    """Family x engine: status counts and the worst error in tolerances."""
    engs = engines if engines is not None else list(dict.fromkeys(df.engine))
    cells = dict(iter(df.groupby(["case", "engine"], sort=False)))  # one pass, not a scan of df per cell
    none = df.iloc[0:0]
    out = []
    for fam in sorted(df.case.unique()):
        line = {"family": fam}
        for eng in engs:
            sub = cells.get((fam, eng), none)
            counts = Counter(sub.status)
            cell = " ".join(f"{counts[s]} {STATUS_MARK[s]}" for s in STATUSES if counts[s])
            worst = sub.over_tol.dropna()
            if len(worst):
                cell += f"; worst {worst.max():.2g}x tol"
            line[eng] = cell
        out.append(line)
    return pd.DataFrame(out)


def deviation_table(df: pd.DataFrame) -> pd.DataFrame:
    """Every check that is a known deviation: the recorded band and the value measured now."""
    dev = df[df.status == "deviation"]
    return pd.DataFrame({"engine": dev.engine, "check": dev.case + "[" + dev.variant + "]:" + dev.metric,
                         "expected": dev.expected.map(fmt), "recorded band": dev.band,
                         "measured": dev.measured.map(fmt), "error/tol": dev.over_tol.map(fmt),
                         "cause": dev.known_deviation})


def deviation_summary(df: pd.DataFrame) -> pd.DataFrame:
    """One row per engine and cause: how many checks, and the worst of them."""
    dev = df[df.status == "deviation"]
    out = []
    for (eng, cause), grp in dev.groupby(["engine", "known_deviation"], sort=False):
        worst = grp.loc[grp.over_tol.fillna(-1).idxmax()]
        out.append({"engine": eng, "cause": cause, "checks": len(grp),
                    "worst check": f"{worst.case}[{worst.variant}]:{worst.metric}",
                    "expected": fmt(worst.expected), "recorded band": worst.band, "measured": fmt(worst.measured),
                    "error/tol": fmt(worst.over_tol)})
    return pd.DataFrame(out)


def per_engine_counts(df: pd.DataFrame, status: str) -> pd.DataFrame:
    """One row per engine: how many of its checks have `status`, over how many families and
    causes (reasons), and the worst of them in tolerances: a listing's one-screen summary."""
    part = df[df.status == status]
    out = []
    for eng, grp in part.groupby("engine", sort=False):
        row = {"engine": eng, "checks": len(grp), "families": grp.case.nunique(),
               "causes": grp["known_deviation" if status == "deviation" else "reason"].nunique()}
        if status == "deviation":
            worst = grp.loc[grp.over_tol.fillna(-1).idxmax()]
            row |= {"worst check": f"{worst.case}[{worst.variant}]:{worst.metric}", "error/tol": fmt(worst.over_tol)}
        out.append(row)
    return pd.DataFrame(out)


def problems(df: pd.DataFrame) -> pd.DataFrame:
    """The checks that failed, blew up or raised, one row each."""
    bad = df[df.status.isin(["fail", "unstable", "error"])]
    return pd.DataFrame({"status": bad.status, "engine": bad.engine, "check": bad.case + "[" + bad.variant + "]:" +
                         bad.metric, "expected": bad.expected.map(fmt), "measured": bad.measured.map(fmt),
                         "reason": bad.reason})


def problems_section(df: pd.DataFrame, title: str = "Failures, blow-ups and errors") -> list[str]:
    bad = problems(df)
    return [f"## {title}", "", md_table(bad) if len(bad) else "_(none)_", ""]


def unsupported_section(df: pd.DataFrame) -> list[str]:
    uns = df[df.status == "unsupported"].drop_duplicates(["engine", "case", "reason"])
    return ["## Unsupported", "", md_table(uns[["engine", "case", "reason"]]), ""] if len(uns) else []


def family_table(df: pd.DataFrame, family: str) -> pd.DataFrame:
    """A family's measured values: one row per check, one column per engine."""
    sub = df[df.case == family]
    engines = list(dict.fromkeys(df.engine))
    lines: dict[tuple, dict] = {}
    for r in sub.itertuples():
        line = lines.get((r.variant, r.metric))
        if line is None:
            line = lines[(r.variant, r.metric)] = {
                "variant": r.variant, "metric": f"{r.metric} [{r.unit}]", "expected": fmt(r.expected),
                "tolerance": f"{fmt(r.tolerance)} {r.tolerance_kind}"}
        if r.engine not in line:
            shown = fmt(r.measured) if r.status in ("pass", "fail", "deviation") else ""
            line[r.engine] = f"{shown} {STATUS_MARK[r.status]}".strip()
    out = pd.DataFrame(list(lines.values()))
    return out[["variant", "metric", "expected", "tolerance"] + [e for e in engines if e in out.columns]] \
        if len(out) else out


def tolerance_reasons(df: pd.DataFrame, family: str) -> pd.DataFrame:
    """Each check's tolerance reason once (the size varies by variant, the reason is the same)."""
    sub = df[df.case == family].drop_duplicates(["metric", "tolerance_reason"])
    return pd.DataFrame({"metric": sub.metric, "tolerance": sub.tolerance_kind, "why this size": sub.tolerance_reason})
