"""The report kit every report is built from: atomic file writes, markdown tables and
number formatting, figures, the results frame, the summary matrix, the known-deviation,
failure and unsupported sections, and the environment table. A report is a list of
sections (markdown strings); each reading module (physval/readings/) writes its own
section with these pieces.

Every file is written to a temporary name beside its target and moved into place, so an
interrupt never leaves a half-written file (and no temporary file stays behind).
"""
from __future__ import annotations

import datetime as _dt
import math
import os
import platform
import sys
import tempfile
from collections import Counter
from pathlib import Path

import numpy as np
import pandas as pd

from physval.files import write_atomic  # noqa: F401 (part of the kit)

STATUS_MARK = {"pass": "pass", "fail": "FAIL", "deviation": "dev", "unsupported": "n/a",
               "unstable": "UNSTABLE", "error": "ERROR"}
STATUSES = tuple(STATUS_MARK)
NUMERIC = ("expected", "measured", "abs_error", "rel_error", "tolerance", "wall_s", "sim_s", "job_s", "dt")


# --- files --------------------------------------------------------------------------------

def write_csv(df: pd.DataFrame, path: Path, columns: list[str] | None = None) -> None:
    write_atomic(path, (df[columns] if columns else df).to_csv(index=False))


# --- text ---------------------------------------------------------------------------------

def heading(title: str, command: str = "", interrupted: str = "") -> list[str]:
    """A report's first lines: its title, the command that made it, and, for a run that
    was interrupted, a bold notice saying so (`interrupted` says what is missing)."""
    lines = [f"# {title}", ""]
    if command:
        lines += [f"Command: `{command}`", ""]
    if interrupted:
        lines += [f"**INCOMPLETE: {interrupted}** Run the same command again to finish it.", ""]
    return lines


def md_table(df: pd.DataFrame) -> str:
    return df.to_markdown(index=False) if len(df) else "_(none)_"


def fmt(x) -> str:
    if isinstance(x, (float, np.floating)):
        if math.isnan(x):
            return ""
        return f"{x:.4g}"
    return str(x)


def anchor(title: str) -> str:
    """The GitHub-style anchor of a markdown heading."""
    keep = "".join(ch for ch in title.lower() if ch.isalnum() or ch in " -_")
    return keep.strip().replace(" ", "-")


def contents(sections: list[str], level: int = 2) -> str:
    """A table of contents of the headings of `level` (and one below) in `sections`."""
    lines = ["## Contents", ""]
    for text in sections:
        for line in text.splitlines():
            hashes = len(line) - len(line.lstrip("#"))
            if line.startswith("#") and level <= hashes <= level + 1 and line[hashes:hashes + 1] == " ":
                title = line[hashes:].strip()
                lines.append(f"{'  ' * (hashes - level)}- [{title}](#{anchor(title)})")
    return "\n".join(lines) + "\n"


# --- figures ------------------------------------------------------------------------------

def pyplot():
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    return plt


MARKERS = ("o", "^", "v", "D", "P", "X", "*", "h")


def engine_styles(engines) -> dict[str, dict]:
    """A colour and a marker per engine for line plots: one colour per engine family (the
    name before its first '-': pybullet, pybullet-rigid, ...) and one marker per member,
    so a plot of 17 engines does not repeat tab10's ten colours."""
    colour, seen, out = {}, {}, {}
    for e in engines:
        family = e.split("-")[0]
        colour.setdefault(family, f"C{len(colour) % 10}")
        k = seen[family] = seen.get(family, -1) + 1
        out[e] = {"color": colour[family], "marker": MARKERS[k % len(MARKERS)]}
    return out


def save_figure(fig, path: Path) -> None:
    plt = pyplot()
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    fd, tmp = tempfile.mkstemp(dir=path.parent, prefix=f".{path.name}.", suffix=".png")
    os.close(fd)
    try:
        fig.savefig(tmp, dpi=110)
        os.chmod(tmp, 0o644)
        os.replace(tmp, path)
    except BaseException:
        if os.path.exists(tmp):
            os.unlink(tmp)
        raise
    finally:
        plt.close(fig)


# --- the results frame --------------------------------------------------------------------

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


def summary_matrix(df: pd.DataFrame, engines: list[str] | None = None) -> pd.DataFrame:
    """Family x engine: status counts and the worst error in tolerances."""
    engs = engines if engines is not None else list(dict.fromkeys(df.engine))
    out = []
    for fam in sorted(df.case.unique()):
        line = {"family": fam}
        part = df[df.case == fam]
        for eng in engs:
            sub = part[part.engine == eng]
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


def problems_section(df: pd.DataFrame, title: str = "Failures, blow-ups and errors") -> list[str]:
    bad = df[df.status.isin(["fail", "unstable", "error"])]
    lines = [f"## {title}", ""]
    if len(bad):
        lines += [md_table(pd.DataFrame({
            "status": bad.status, "engine": bad.engine, "check": bad.case + "[" + bad.variant + "]:" + bad.metric,
            "expected": bad.expected.map(fmt), "measured": bad.measured.map(fmt), "reason": bad.reason})), ""]
    else:
        lines += ["_(none)_", ""]
    return lines


def unsupported_section(df: pd.DataFrame) -> list[str]:
    uns = df[df.status == "unsupported"].drop_duplicates(["engine", "case", "reason"])
    return ["## Unsupported", "", md_table(uns[["engine", "case", "reason"]]), ""] if len(uns) else []


def environment(engine_versions: dict[str, str] | None = None) -> pd.DataFrame:
    env = {
        "date (UTC)": _dt.datetime.now(_dt.timezone.utc).strftime("%Y-%m-%d %H:%M"),
        "python": sys.version.split()[0],
        "numpy": np.__version__,
        "pandas": pd.__version__,
        "platform": platform.platform(),
        "machine": f"{platform.machine()}, {os.cpu_count()} cores",
    }
    for eng, ver in sorted((engine_versions or {}).items()):
        env[eng] = ver or "not run"
    return pd.DataFrame(list(env.items()), columns=["what", "value"])


def engine_versions(df: pd.DataFrame) -> dict[str, str]:
    return {e: v for e, v in df.groupby("engine")["engine_version"].first().items()}
