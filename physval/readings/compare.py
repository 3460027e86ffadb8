"""Two runs side by side: which checks changed between result folder A and result folder B
(two engine releases, two physval versions, two settings).

A check is one row of results.csv, named by (case, variant, engine, metric). Between A and B
a check can
- change status (pass -> fail, unsupported -> pass, ...);
- move: its error (measured - expected) changed by more than `threshold` tolerances of the
  check (the tolerance A judged it with, in the check's units: `tolerance` for an absolute
  tolerance, `tolerance * |expected|` for a relative one). The error, not the measured value
  alone, so that a corrected closed form counts as a move too; with the same expected value
  both are the same;
- be in one run only.
Everything else is the same, to the last bit or by less than the threshold. A deterministic
engine at the same release and settings moves by exactly zero, so the default threshold
(THRESHOLD) does not hide noise: it hides changes too small to matter to any verdict.

`load` reads a results.csv (or a folder holding one), `compare` joins two, `write` writes
compare.md, compare.csv and compare.png. Trajectories saved by both runs are compared by
physval.readings.divergence.
"""
from __future__ import annotations

import io
from pathlib import Path

import numpy as np
import pandas as pd

from physval.report import fmt, heading, md_table, pyplot, save_figure, write_atomic, write_csv

KEY = ["case", "variant", "engine", "metric"]
REQUIRED = KEY + ["expected", "measured", "tolerance", "tolerance_kind", "status"]
OPTIONAL = ["engine_version", "dt", "iterations", "unit", "reason"]
NUMBERS = ("expected", "measured", "tolerance", "dt", "iterations")
# A move smaller than 1 % of a check's tolerance changes no verdict's margin by more than
# 1 % of the band the check allows: below what a reader of the report acts on. Deterministic
# engines move by exactly 0 between two runs of the same release; DART does not (its
# friction scenes moved by up to 3.5e-5 tolerances between two default runs, 12 of 11 557
# checks), and that stays below the threshold with a margin of 280.
THRESHOLD = 0.01
CHANGED = ("status", "moved", "only in A", "only in B")  # what makes `physval compare` exit 1
SHOWN = 40  # rows per detail table in compare.md (every row is in compare.csv)


class CompareError(ValueError):
    """A folder or file that is not a physval results table; one line naming it."""


def results_file(where) -> Path:
    """The results.csv of a result folder (or `where` itself, a CSV file)."""
    path = Path(where)
    if path.is_dir():
        path = path / "results.csv"
        if not path.is_file():
            raise CompareError(f"{where}: no results.csv in this folder (a `physval run --out` folder holds one)")
    elif not path.is_file():
        raise CompareError(f"{where}: no such folder or file")
    return path


def load(where) -> pd.DataFrame:
    """The checks of one run: KEY, the verdict's numbers and status (numbers as floats). A
    last row cut short (a run stopped in its write) is no check."""
    from physval.core.store import whole_rows
    try:
        path = results_file(where)
        text = whole_rows(path.read_text())
    except OSError as exc:
        raise CompareError(f"{where}: cannot be read ({exc.strerror or exc})") from None
    except UnicodeDecodeError as exc:
        raise CompareError(f"{where}: not a CSV table ({exc})") from None
    try:
        header = list(pd.read_csv(io.StringIO(text), nrows=0).columns)
        missing = [c for c in REQUIRED if c not in header]
        if missing:
            raise CompareError(f"{path}: no column {', '.join(missing)}: not a physval results.csv")
        df = pd.read_csv(io.StringIO(text), usecols=[c for c in REQUIRED + OPTIONAL if c in header], dtype=str,
                         keep_default_na=False)
    except CompareError:
        raise
    except (pd.errors.EmptyDataError, pd.errors.ParserError, UnicodeDecodeError, ValueError) as exc:
        raise CompareError(f"{path}: not a CSV table ({str(exc).splitlines()[0]})") from None
    for col in OPTIONAL:
        if col not in df:
            df[col] = ""
    for col in NUMBERS:
        df[col] = pd.to_numeric(df[col], errors="coerce")
    twice = df.duplicated(KEY, keep=False)
    if twice.any():
        first = df[twice].iloc[0]
        raise CompareError(f"{path}: {int(twice.sum())} rows repeat a check (e.g. {name_of(first)} on "
                           f"{first.engine}): not the results of one run")
    return df


def name_of(row) -> str:
    return f"{row.case}[{row.variant}]:{row.metric}"


def _scale(df: pd.DataFrame, side: str) -> np.ndarray:
    """A check's tolerance in its own units (the absolute size of one tolerance)."""
    tol = df[f"tolerance_{side}"].to_numpy(float)
    rel = (df[f"tolerance_kind_{side}"] == "rel").to_numpy()
    return np.where(rel, tol * np.abs(df[f"expected_{side}"].to_numpy(float)), tol)


def compare(a: pd.DataFrame, b: pd.DataFrame, threshold: float = THRESHOLD) -> pd.DataFrame:
    """One row per check of either run: both sides' fields (suffixes _a, _b) and
    - move: |error_b - error_a| in tolerances (0 when neither has a number, inf when one has);
    - err_a, err_b: each side's |error| in that same tolerance (for towards/away);
    - direction: "towards" the closed form (|error| smaller in B), "away", or "";
    - change: status, moved, below threshold, same, only in A, only in B.
    Sorted: changed checks first, the largest move first."""
    m = a.merge(b, on=KEY, how="outer", suffixes=("_a", "_b"), indicator=True, sort=False)
    scale = _scale(m, "a")
    scale = np.where(np.isfinite(scale) & (scale > 0), scale, _scale(m, "b"))
    e_a = (m.measured_a - m.expected_a).to_numpy(float)
    e_b = (m.measured_b - m.expected_b).to_numpy(float)
    d = np.abs(e_b - e_a)
    has_a, has_b = np.isfinite(e_a), np.isfinite(e_b)
    with np.errstate(divide="ignore", invalid="ignore"):
        ok = np.isfinite(scale) & (scale > 0)
        move = np.where(ok, d / scale, np.where(d == 0, 0.0, np.inf))
        m["err_a"] = np.where(ok, np.abs(e_a) / scale, np.nan)
        m["err_b"] = np.where(ok, np.abs(e_b) / scale, np.nan)
    move = np.where(has_a & has_b, move, np.where(has_a | has_b, np.inf, 0.0))
    both = (m["_merge"] == "both").to_numpy()
    m["move"] = np.where(both, move, np.nan)
    m["direction"] = np.select([both & has_a & has_b & (np.abs(e_b) < np.abs(e_a)),
                                both & has_a & has_b & (np.abs(e_b) > np.abs(e_a))], ["towards", "away"], "")
    m["change"] = np.select(
        [m["_merge"] == "left_only", m["_merge"] == "right_only", m.status_a != m.status_b,
         m.move > threshold, m.move > 0],
        ["only in A", "only in B", "status", "moved", "below threshold"], "same")
    m = m.drop(columns="_merge")
    rank = np.where(m.change.isin(CHANGED), 0, 1)
    order = np.lexsort((-m.move.fillna(-1).to_numpy(), rank))
    return m.iloc[order].reset_index(drop=True)


def changed(table: pd.DataFrame) -> bool:
    return bool(table.change.isin(CHANGED).any())


def counts(table: pd.DataFrame) -> dict[str, int]:
    got = table.change.value_counts()
    return {c: int(got.get(c, 0)) for c in ("status", "moved", "below threshold", "same", "only in A", "only in B")}


def summary_line(table: pd.DataFrame, threshold: float) -> str:
    n = counts(table)
    return (f"{n['status']} checks changed status, {n['moved']} moved by more than {threshold:g} tolerances, "
            f"{n['only in A']} in A only, {n['only in B']} in B only; {n['below threshold']} moved less, "
            f"{n['same']} identical")


def per_family(table: pd.DataFrame) -> pd.DataFrame:
    """Family x engine, the groups where anything differs, the largest move first."""
    rows = []
    for (fam, eng), g in table.groupby(["case", "engine"], sort=False):
        n = g.change.value_counts()
        if not (n.get("status", 0) or n.get("moved", 0) or n.get("below threshold", 0)
                or n.get("only in A", 0) or n.get("only in B", 0)):
            continue
        moved = g[g.change.isin(["status", "moved"])]
        rows.append({"family": fam, "engine": eng, "checks in both": int(g.move.notna().sum()),
                     "status changed": int(n.get("status", 0)), "moved": int(n.get("moved", 0)),
                     "below threshold": int(n.get("below threshold", 0)), "only in A": int(n.get("only in A", 0)),
                     "only in B": int(n.get("only in B", 0)), "largest move (tol)": g.move.max(),
                     "towards": int((moved.direction == "towards").sum()),
                     "away": int((moved.direction == "away").sum())})
    out = pd.DataFrame(rows)
    if len(out):
        out = out.sort_values(["largest move (tol)", "status changed"], ascending=False, na_position="last")
    return out


def _status_flows(table: pd.DataFrame) -> str:
    flows = table[table.change == "status"].groupby(["status_a", "status_b"]).size().sort_values(ascending=False)
    return "; ".join(f"{a} -> {b}: {n}" for (a, b), n in flows.items()) or "none"


def _engines(df: pd.DataFrame) -> str:
    n = df.engine.nunique()
    return f"{n} engine" + ("s" if n != 1 else "")


def _versions(df: pd.DataFrame) -> str:
    return ", ".join(f"{e} {v}" for e, v in df.groupby("engine", sort=False).engine_version.first().items()) or "none"


def _changed_versions(table: pd.DataFrame) -> str:
    both = table[table.move.notna()]
    pairs = both.groupby(["engine", "engine_version_a", "engine_version_b"], sort=False).size()
    return ", ".join(f"{e} {va} -> {vb}" for (e, va, vb), _ in pairs.items() if va != vb) or "the same"


def _differs(table: pd.DataFrame, col: str) -> int:
    a, b = table[f"{col}_a"], table[f"{col}_b"]
    return int((table.move.notna() & (a != b) & ~(a.isna() & b.isna())).sum())


def _checks(rows: pd.DataFrame) -> pd.DataFrame:
    """A detail table of checks: both sides' status, measured value and error in tolerances."""
    return pd.DataFrame({
        "engine": rows.engine, "check": rows.case + "[" + rows.variant + "]:" + rows.metric,
        "status A": rows.status_a.fillna(""), "status B": rows.status_b.fillna(""),
        "expected": rows.expected_b.fillna(rows.expected_a).map(fmt),
        "measured A": rows.measured_a.map(fmt), "measured B": rows.measured_b.map(fmt),
        "error/tol A": rows.err_a.map(fmt), "error/tol B": rows.err_b.map(fmt),
        "move (tol)": rows.move.map(fmt), "direction": rows.direction})


def _limited(rows: pd.DataFrame, what: str) -> list[str]:
    lines = [md_table(_checks(rows.head(SHOWN))), ""]
    if len(rows) > SHOWN:
        lines += [f"... and {len(rows) - SHOWN} more {what} in compare.csv.", ""]
    return lines


def report(table: pd.DataFrame, a: pd.DataFrame, b: pd.DataFrame, names: tuple[str, str], threshold: float,
           command: str = "", extra: list[str] | None = None) -> str:
    """compare.md: a one-screen summary, then the family x engine table and the details."""
    n = counts(table)
    verdict = ("**Something changed** (exit code 1)" if changed(table) else "**Nothing changed** (exit code 0)")
    moves = table[table.change.isin(["status", "moved"]) & np.isfinite(table.move.fillna(np.inf))]
    top = moves.head(1)  # the table is sorted: the largest first
    lines = heading("Comparison of two runs", command) + [
        f"- A: `{names[0]}`: {len(a)} checks on {_engines(a)}",
        f"- B: `{names[1]}`: {len(b)} checks on {_engines(b)}",
        "",
        f"{verdict}: {summary_line(table, threshold)}.",
        "",
        f"- status changes: {_status_flows(table)}",
        f"- of the status changes and moves, {(moves.direction == 'towards').sum()} brought the measured value "
        f"nearer the closed form, {(moves.direction == 'away').sum()} further from it",
        f"- engine releases: {_changed_versions(table)}; dt differs on {_differs(table, 'dt')} checks, "
        f"iterations on {_differs(table, 'iterations')}, the expected value on {_differs(table, 'expected')}",
    ]
    if len(top):
        r = top.iloc[0]
        lines.append(f"- largest move: {name_of(r)} on {r.engine}, {r.move:.3g} tolerances "
                     f"(error {fmt(r.err_a)} -> {fmt(r.err_b)} tolerances: {r.direction or 'as far'} "
                     f"{'the closed form' if r.direction else 'from the closed form'})")
    lines += [
        f"- threshold: a check moved when its error moved by more than {threshold:g} of its tolerance "
        "(`--threshold`); a deterministic engine at the same release and settings moves by exactly 0",
        "", "![each check's error in tolerances, A against B](compare.png)", "",
        "## Per family and engine", "",
        "Groups where anything differs, the largest move first (moves in tolerances; towards/away: the status "
        "changes and moves that brought the measured value nearer to, or further from, the closed form).", "",
        md_table(per_family(table).assign(**{"largest move (tol)": lambda d: d["largest move (tol)"].map(fmt)}))
        if n["status"] + n["moved"] + n["below threshold"] + n["only in A"] + n["only in B"] else "_(none)_", "",
        "## Status changes", ""]
    lines += _limited(table[table.change == "status"], "status changes")
    lines += ["## Largest moves", ""] + _limited(table[table.change == "moved"], "moves")
    one_sided = table[table.change.isin(["only in A", "only in B"])]
    lines += ["## In one run only", ""] + _limited(one_sided, "one-sided checks")
    lines += ["## The runs' engines", "", f"- A: {_versions(a)}", f"- B: {_versions(b)}", ""]
    return "\n".join(lines + (extra or [])) + "\n"


def plot(table: pd.DataFrame, path: Path, names: tuple[str, str]) -> None:
    """Each check in both runs: its error in tolerances in A (x) against B (y). On the
    diagonal: unchanged; below it: nearer the closed form in B. Errors are drawn from 1e-6
    tolerances up (an exact value would have no place on a log scale)."""
    plt = pyplot()
    both = table[table.move.notna()]
    fig, ax = plt.subplots(figsize=(6.4, 6.0), layout="constrained")
    styles = (("same", "0.75", 6, "same"), ("below threshold", "tab:olive", 8, "moved below the threshold"),
              ("moved", "tab:blue", 12, "moved"), ("status", "tab:red", 18, "status changed"))
    both = both[both.err_a.notna() | both.err_b.notna()]  # neither has a number: nothing to draw
    for change, colour, size, label in styles:
        part = both[both.change == change]
        if len(part):
            x, y = np.clip(part.err_a.to_numpy(float), 1e-6, 1e6), np.clip(part.err_b.to_numpy(float), 1e-6, 1e6)
            ax.scatter(np.nan_to_num(x, nan=1e6), np.nan_to_num(y, nan=1e6), s=size, c=colour,
                       label=f"{label} ({len(part)})", alpha=0.8, linewidths=0)
    ax.plot([1e-6, 1e6], [1e-6, 1e6], color="k", lw=0.6)
    ax.axvline(1, color="k", ls=":", lw=0.6)
    ax.axhline(1, color="k", ls=":", lw=0.6)
    ax.set(xscale="log", yscale="log", xlim=(5e-7, 2e6), ylim=(5e-7, 2e6),
           xlabel=f"|error| / tolerance in A ({Path(names[0]).name or names[0]})",
           ylabel=f"|error| / tolerance in B ({Path(names[1]).name or names[1]})",
           title="Each check with a number in either run (dotted: the tolerance; no number in one run: "
                 "drawn at 1e6)")
    ax.title.set_fontsize(9)
    if ax.get_legend_handles_labels()[0]:  # no check with a number in both runs: nothing to name
        ax.legend(fontsize=8, loc="upper left")
    save_figure(fig, path)


CSV_COLUMNS = KEY + ["change", "move", "direction", "status_a", "status_b", "expected_a", "expected_b",
                     "measured_a", "measured_b", "err_a", "err_b", "tolerance_a", "tolerance_kind_a",
                     "engine_version_a", "engine_version_b", "dt_a", "dt_b", "reason_a", "reason_b"]


def write(table: pd.DataFrame, a: pd.DataFrame, b: pd.DataFrame, out: Path, names: tuple[str, str],
          threshold: float, command: str = "", extra: list[str] | None = None) -> None:
    """compare.md, compare.csv (every check of either run: `change` says what it did;
    err_a/err_b: |error| in tolerances) and compare.png into `out`."""
    out = Path(out)
    write_csv(table, out / "compare.csv", CSV_COLUMNS)
    plot(table, out / "compare.png", names)
    write_atomic(out / "compare.md", report(table, a, b, names, threshold, command, extra))
