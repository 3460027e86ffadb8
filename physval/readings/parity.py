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
`families` sums both up per family; `findings` says what the two readings show in words (the
verdicts that differ grouped by the cause recorded in the deviating engine's deviation file,
where the trajectories part first); `write` writes parity.md, parity.csv (every check, with
both engines' names and releases) and parting.csv (every job) into one folder a pair
(reports/parity/ENGINE-PORT). `beside` reads those folders back beside a run, and `section`
is the run report's "Implementation parity": each pair's findings, a table and a plot.
"""
from __future__ import annotations

import re
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import pandas as pd

from physval.readings import divergence
from physval.report import fmt, heading, md_table, pyplot, save_figure, write_atomic, write_csv

JUDGED = ("pass", "fail", "deviation")
SHOWN = 25  # rows of the largest-moves table (every check is in parity.csv)
CAUSE_CHARS = 150  # a recorded cause is quoted up to this many characters (its whole text is in parity.csv)


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
    keep = ["engine", "engine_version", "case", "variant", "metric", "status", "measured", "expected", "tolerance",
            "tolerance_kind", "reason"]
    left = rows[rows.engine == a][keep].assign(tol=lambda d: _tolerance(d))
    right = rows[rows.engine == b][keep].assign(tol=lambda d: _tolerance(d)).drop(columns=["expected",
                                                                                          "tolerance_kind"])
    df = left.merge(right, on=["case", "variant", "metric"], suffixes=("_a", "_b"))
    df = df[["engine_a", "engine_version_a", "engine_b", "engine_version_b"]
            + [c for c in df.columns if not c.startswith("engine")]]
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
    """(case, variant, trajectory of A, of B) -> where each pair parts (divergence.parting),
    with the threshold it parts at (`parted_at`, of the job's scale)."""
    out = []
    for case, variant, path_a, path_b in jobs:
        if path_a.is_file() and path_b.is_file():
            out.append({"case": case, "variant": variant, **divergence.parting(path_a, path_b, threshold)})
        else:
            out.append({"case": case, "variant": variant, "note": "no trajectory from both engines"})
    return pd.DataFrame(out, columns=["case", "variant", "job", "steps", "parted_step", "parted_time",
                                      "first_to_part", "body", "column", "largest", "note"]).assign(parted_at=threshold)


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


def _cause(reason) -> str:
    """A deviation file's recorded cause without the measured value the verdict appends,
    cut to CAUSE_CHARS at a word."""
    text = re.sub(r"\s*\[measured.*$", "", reason, flags=re.S).strip() if isinstance(reason, str) else ""
    if not text:
        return "no recorded cause"
    return text if len(text) <= CAUSE_CHARS else text[:CAUSE_CHARS].rsplit(" ", 1)[0] + " ..."


def differing(table: pd.DataFrame) -> pd.DataFrame:
    """The verdicts that differ, grouped: the engine that leaves `pass` (the port where both
    left it), its status, the other's status and the recorded cause; how many checks, in which
    families."""
    rows = []
    for r in table[table.verdicts_differ].itertuples():
        port_left = r.status_b != "pass"
        rows.append({"engine": r.engine_b if port_left else r.engine_a,
                     "status": r.status_b if port_left else r.status_a,
                     "other": r.engine_a if port_left else r.engine_b,
                     "other_status": r.status_a if port_left else r.status_b,
                     "cause": _cause(r.reason_b if port_left else r.reason_a), "family": r.case})
    keys = ["engine", "status", "other", "other_status", "cause"]
    if not rows:
        return pd.DataFrame(columns=keys + ["checks", "families"])
    return (pd.DataFrame(rows).groupby(keys, sort=False)
            .agg(checks=("family", "size"), families=("family", lambda f: ", ".join(sorted(set(f)))))
            .reset_index().sort_values("checks", ascending=False, kind="stable"))


def _verb(status: str, n: int) -> str:
    """What `n` checks of a status do, as a verb ("pass", "deviate (known)", "fail")."""
    one = n == 1
    return {"pass": "passes" if one else "pass", "deviation": "deviates (known)" if one else "deviate (known)",
            "fail": "fails" if one else "fail"}.get(status, f"{'is' if one else 'are'} {status}")


def counts(table: pd.DataFrame, parts: pd.DataFrame) -> dict:
    """A pair's parity in numbers: checks run on both and judged on both, the median
    |difference| in tolerances, checks beyond one tolerance, verdicts that differ, checks of
    scenes only one engine represents, trajectory pairs compared and those that part."""
    d, ran = table.difference.abs(), parts[parts.steps.notna()]
    return {"checks": len(table), "judged": int(d.notna().sum()), "median": float(d.median()),
            "beyond": int((d > 1).sum()), "differ": int(table.verdicts_differ.sum()),
            "one_only": int(table.one_engine_only.sum()), "jobs": len(ran),
            "parted": int(ran.parted_step.notna().sum())}


def findings(table: pd.DataFrame, parts: pd.DataFrame) -> tuple[str, list[str]]:
    """What a pair's parity shows, in words: one paragraph (how far the checks move, the
    largest move, where the trajectories part) and one sentence per cause of the verdicts
    that differ."""
    a, b = table.engine_a.iloc[0], table.engine_b.iloc[0]
    n = counts(table, parts)
    text = (f"Of {n['checks']} checks run on both, {n['judged']} were judged on both: the median difference is "
            f"{fmt(n['median']) if n['judged'] else '-'} tolerances, {n['beyond']} checks differ by more than one "
            f"tolerance and {n['differ']} verdicts differ")
    if n["one_only"]:
        text += f" ({n['one_only']} more checks are of scenes only one of the two can represent)"
    text += "."
    if n["judged"]:
        top = table.loc[table.difference.abs().idxmax()]
        text += (f" The largest difference is {top.case}[{top.variant}]:{top.metric}, {fmt(float(top.difference))} "
                 f"tolerances ({a} {fmt(float(top.measured_a))}, {b} {fmt(float(top.measured_b))}, expected "
                 f"{fmt(float(top.expected))}).")
    ran = parts[parts.steps.notna()]
    parted = ran[ran.parted_step.notna()].sort_values("parted_time", kind="stable")
    at = fmt(float(parts.parted_at.iloc[0])) if len(parts) else fmt(PARTED)
    if n["parted"]:
        first = parted.iloc[0]
        whole = sorted(c for c, g in ran.groupby("case") if g.parted_step.notna().all())
        text += (f" {n['parted']} of {n['jobs']} trajectory pairs part (a state differs by more than {at} of the "
                 f"job's scale); the first is {first.case}[{first.variant}], at step {int(first.parted_step)} "
                 f"({fmt(float(first.parted_time))} s, {first.first_to_part} first)"
                 + (f"; every pair of {', '.join(whole)} parts" if whole else "") + ".")
    elif n["jobs"]:
        text += f" None of the {n['jobs']} trajectory pairs part (by more than {at} of the job's scale)."
    causes = [f"{g.families}: {g.checks} check{'' if g.checks == 1 else 's'} {_verb(g.other_status, g.checks)} on "
              f"{g.other} and {_verb(g.status, g.checks)} on {g.engine}; recorded cause: {g.cause}"
              for g in differing(table).itertuples()]
    return text, causes


def write(folder: Path, table: pd.DataFrame, parts: pd.DataFrame, a: str, b: str, threshold: float,
          command: str = "", versions: dict | None = None) -> list[Path]:
    """parity.md, parity.csv and parting.csv in `folder`."""
    fams = families(table, parts)
    d = table.difference.abs()
    parted = parts[parts.parted_step.notna()]
    lines = heading(f"Implementation parity: {a} and {b}", command)
    if versions:
        lines += ["Releases: " + "; ".join(f"{e} {v}" for e, v in versions.items()), ""]
    text, causes = findings(table, parts) if len(table) else ("No check ran on both engines.", [])
    lines += [
        f"The same scenes on both engines. Each check's difference is {b}'s value minus {a}'s in units of "
        f"the check's tolerance (the wider of the two engines', at the narrower float width); a trajectory pair parts at the first step where some state differs "
        f"by more than {threshold:.2g} of the job's scale (physval.readings.parity).", "", text, ""]
    if causes:
        lines += ["The verdicts that differ, by the cause recorded in the deviating engine's deviation file:", ""]
        lines += [f"- {c}" for c in causes] + [""]
    lines += [
        "## Per family", "", md_table(fams.map(fmt) if hasattr(fams, "map") else fams.applymap(fmt)), "",
        "## The largest differences", ""]
    top = table.assign(size=d)[d.notna()].sort_values("size", ascending=False).head(SHOWN)  # none: no row
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


PARITY_DIR = "parity"  # beside a run's report: one folder a pair, the parity command's default
LEGEND = ("An engine and its port on the same scenes (`physval parity ENGINE PORT`, read from "
          f"{PARITY_DIR}/ beside this run): each check's difference, the port's value minus the original's, in "
          "units of the check's tolerance; the verdicts that differ, with the cause recorded in the deviating "
          "engine's deviation file; and where the two trajectories of a job part. Each pair's page has every family.")


@dataclass
class Pair:
    """One pair's parity reading found beside a run: its folder (relative to the run's), both
    engines' names and releases, every check (`checks`) and every trajectory pair (`parting`)."""
    folder: Path
    a: str
    b: str
    versions: dict[str, str]
    table: pd.DataFrame
    parts: pd.DataFrame


# the columns of parity.csv and parting.csv that a run's report reads
TABLE_COLUMNS = ("case", "engine_a", "engine_b", "engine_version_a", "engine_version_b", "difference",
                 "verdicts_differ", "one_engine_only")
PARTS_COLUMNS = ("case", "steps", "parted_step")


def beside(out: Path, left_out: list[str] | None = None) -> list[Pair]:
    """The parity readings in parity/*/ under a run's folder. One whose parity.csv or
    parting.csv cannot be read as `physval parity` writes them (empty, damaged, written
    before the engines' names were kept) is passed over, and named in `left_out`."""
    from physval.report import companion_table
    left_out = [] if left_out is None else left_out
    pairs = []
    for file in sorted((Path(out) / PARITY_DIR).glob("*/parity.csv")):
        table = companion_table(file, "parity", TABLE_COLUMNS)
        if isinstance(table, str):
            left_out.append(f"{file}: {table}")
            continue
        if not len(table):
            continue
        parts_file = file.with_name("parting.csv")
        parts = companion_table(parts_file, "parity", PARTS_COLUMNS) if parts_file.is_file() else parting([], PARTED)
        if isinstance(parts, str):
            left_out.append(f"{parts_file}: {parts}")
            continue
        a, b = table.engine_a.iloc[0], table.engine_b.iloc[0]
        pairs.append(Pair(file.parent.relative_to(out), a, b, {a: str(table.engine_version_a.iloc[0]),
                                                                b: str(table.engine_version_b.iloc[0])}, table, parts))
    return pairs


def overview(pairs: list[Pair]) -> pd.DataFrame:
    """One row a pair: its checks and trajectories in numbers."""
    rows = []
    for p in pairs:
        n = counts(p.table, p.parts)
        rows.append({"port": p.b, "original": p.a, "releases": f"{p.versions[p.b]}; {p.versions[p.a]}",
                     "judged on both": n["judged"], "median |diff| (tol)": fmt(n["median"]),
                     "beyond 1 tol": n["beyond"], "verdicts differ": n["differ"], "one engine only": n["one_only"],
                     "trajectories part": f"{n['parted']} of {n['jobs']}",
                     "details": (p.folder / "parity.md").as_posix()})
    return pd.DataFrame(rows)


def plot(pairs: list[Pair], path: Path) -> None:
    """Each pair's share of checks whose difference is within x tolerances (log x)."""
    plt = pyplot()
    fig, ax = plt.subplots(figsize=(7.5, 4.2), layout="constrained")
    for p in pairs:
        d = np.sort(p.table.difference.abs().dropna().to_numpy())
        if len(d):
            ax.step(np.clip(d, 1e-8, None), np.arange(1, len(d) + 1) / len(d), where="post",
                    label=f"{p.b} against {p.a} ({len(d)} checks)")
    ax.axvline(1.0, color="grey", ls="--", lw=1)
    ax.set_xscale("log")
    ax.set_xlabel("|port's value - original's| in the check's tolerances (1e-8 and below drawn at 1e-8)")
    ax.set_ylabel("share of checks judged on both")
    ax.set_title("Implementation parity: how far the port moves each check", fontsize=10)
    ax.legend(fontsize=8, loc="lower right")
    save_figure(fig, path)


def section(pairs: list[Pair], out: Path) -> str:
    """The run report's "Implementation parity": the pairs' numbers, a plot and each pair's
    findings in words."""
    plot(pairs, Path(out) / "plots" / "parity.png")
    table = overview(pairs)
    table["details"] = [f"[{d}]({d})" for d in table.details]
    lines = ["## Implementation parity", "", LEGEND, "", md_table(table), "", "![parity](plots/parity.png)", ""]
    for p in pairs:
        text, causes = findings(p.table, p.parts)
        lines += [f"**{p.b} against {p.a}.** {text}", ""]
        if causes:
            lines += ["Where the verdicts differ:", ""] + [f"- {c}" for c in causes] + [""]
    return "\n".join(lines)
