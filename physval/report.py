"""Writes a run's results: `results.csv`, `report.md` and `plots/*.png`.

Every file is written to a temporary name beside its target and moved into place, so an
interrupt never leaves a half-written file.
"""
from __future__ import annotations

import datetime as _dt
import json
import math
import os
import platform
import sys
import tempfile
from collections import Counter
from pathlib import Path

import numpy as np
import pandas as pd

from cases.family import Check
from physval import deviations
from physval.metrics import STATUSES, error_over_tolerance
from physval.runner import COLUMNS

STATUS_MARK = {"pass": "pass", "fail": "FAIL", "deviation": "dev", "unsupported": "n/a",
               "unstable": "UNSTABLE", "error": "ERROR"}


# --- atomic writes ------------------------------------------------------------------------

def write_atomic(path: Path, data: str | bytes) -> None:
    path.parent.mkdir(parents=True, exist_ok=True)
    fd, tmp = tempfile.mkstemp(dir=path.parent, prefix=f".{path.name}.", suffix=".tmp")
    try:
        with os.fdopen(fd, "wb") as fh:
            fh.write(data.encode() if isinstance(data, str) else data)
        os.chmod(tmp, 0o644)  # mkstemp makes it private; a report is for reading
        os.replace(tmp, path)
    except BaseException:
        if os.path.exists(tmp):
            os.unlink(tmp)
        raise


def frame(rows: list[dict]) -> pd.DataFrame:
    df = pd.DataFrame(rows, columns=COLUMNS)
    for col in ("expected", "measured", "abs_error", "rel_error", "tolerance", "wall_s", "sim_s"):
        df[col] = pd.to_numeric(df[col], errors="coerce")
    df["over_tol"] = [error_over_tolerance(Check(r.metric, r.unit, r.expected, r.tolerance, r.tolerance_kind or "abs", "-"),
                                           r.abs_error, r.rel_error) if r.status in ("pass", "fail", "deviation")
                      else math.nan for r in df.itertuples()]
    return df


def write_csv(df: pd.DataFrame, path: Path) -> None:
    write_atomic(path, df[COLUMNS].to_csv(index=False))


# --- environment --------------------------------------------------------------------------

def environment(df: pd.DataFrame) -> dict:
    env = {
        "date (UTC)": _dt.datetime.now(_dt.timezone.utc).strftime("%Y-%m-%d %H:%M"),
        "python": sys.version.split()[0],
        "numpy": np.__version__,
        "pandas": pd.__version__,
        "platform": platform.platform(),
        "machine": f"{platform.machine()}, {os.cpu_count()} cores",
    }
    for eng, ver in sorted(df.groupby("engine")["engine_version"].first().items()):
        env[eng] = ver or "not run"
    return env


# --- plots --------------------------------------------------------------------------------

def _plt():
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    return plt


def plot_summary(df: pd.DataFrame, path: Path) -> None:
    """Heat map of the worst error/tolerance per family and engine (log colour scale)."""
    plt = _plt()
    fams, engs = sorted(df.case.unique()), list(dict.fromkeys(df.engine))
    worst = np.full((len(fams), len(engs)), np.nan)
    for i, f in enumerate(fams):
        for j, e in enumerate(engs):
            vals = df[(df.case == f) & (df.engine == e)].over_tol.dropna()
            if len(vals):
                worst[i, j] = max(vals.max(), 1e-6)
    fig, ax = plt.subplots(figsize=(1.6 * len(engs) + 3, 0.6 * len(fams) + 1.8))
    shown = np.log10(np.clip(worst, 1e-3, 1e3))
    im = ax.imshow(shown, cmap="RdYlGn_r", vmin=-3, vmax=3, aspect="auto")
    ax.set_xticks(range(len(engs)), engs, rotation=30, ha="right")
    ax.set_yticks(range(len(fams)), fams)
    for i in range(len(fams)):
        for j in range(len(engs)):
            text = "n/a" if np.isnan(worst[i, j]) else f"{worst[i, j]:.2g}"
            ax.text(j, i, text, ha="center", va="center", fontsize=8)
    fig.colorbar(im, ax=ax, label="log10(worst error / tolerance)")
    ax.set_title("Worst error in tolerances (<1: within tolerance)")
    fig.tight_layout()
    _save(fig, path)


def plot_family(df: pd.DataFrame, family: str, path: Path) -> None:
    """Every check's error/tolerance, one column of points per engine."""
    plt = _plt()
    sub = df[(df.case == family) & df.over_tol.notna()]
    engs = list(dict.fromkeys(df.engine))
    fig, ax = plt.subplots(figsize=(1.3 * len(engs) + 3, 3.6))
    colours = {"pass": "tab:green", "fail": "tab:red", "deviation": "tab:orange"}
    rng = np.random.default_rng(0)
    for j, eng in enumerate(engs):
        part = sub[sub.engine == eng]
        y = np.clip(part.over_tol.to_numpy(dtype=float), 1e-6, 1e6)
        x = j + rng.uniform(-0.25, 0.25, size=len(y))
        ax.scatter(x, y, s=14, c=[colours.get(s, "grey") for s in part.status], alpha=0.8)
    ax.axhline(1.0, color="black", lw=0.8, ls="--")
    ax.set_yscale("log")
    ax.set_xticks(range(len(engs)), engs, rotation=30, ha="right")
    ax.set_ylabel("error / tolerance")
    ax.set_title(f"{family}: each check (green pass, orange known deviation, red fail)")
    fig.tight_layout()
    _save(fig, path)


def _save(fig, path: Path) -> None:
    plt = _plt()
    path.parent.mkdir(parents=True, exist_ok=True)
    fd, tmp = tempfile.mkstemp(dir=path.parent, prefix=f".{path.name}.", suffix=".png")
    os.close(fd)
    fig.savefig(tmp, dpi=110)
    plt.close(fig)
    os.chmod(tmp, 0o644)
    os.replace(tmp, path)


# --- markdown -----------------------------------------------------------------------------

def _md_table(df: pd.DataFrame) -> str:
    return df.to_markdown(index=False) if len(df) else "_(none)_"


def _fmt(x) -> str:
    if isinstance(x, (float, np.floating)):
        if math.isnan(x):
            return ""
        return f"{x:.4g}"
    return str(x)


def summary_matrix(df: pd.DataFrame) -> pd.DataFrame:
    engs = list(dict.fromkeys(df.engine))
    out = []
    for fam in sorted(df.case.unique()):
        line = {"family": fam}
        for eng in engs:
            sub = df[(df.case == fam) & (df.engine == eng)]
            counts = Counter(sub.status)
            cell = " ".join(f"{counts[s]} {STATUS_MARK[s]}" for s in STATUSES if counts[s])
            worst = sub.over_tol.dropna()
            if len(worst):
                cell += f"; worst {worst.max():.2g}x tol"
            line[eng] = cell
        out.append(line)
    return pd.DataFrame(out)


def family_table(df: pd.DataFrame, family: str) -> pd.DataFrame:
    sub = df[df.case == family]
    engs = list(dict.fromkeys(df.engine))
    out = []
    for (variant, metric), grp in sub.groupby(["variant", "metric"], sort=False):
        first = grp.iloc[0]
        line = {"variant": variant, "metric": f"{metric} [{first.unit}]", "expected": _fmt(first.expected),
                "tolerance": f"{_fmt(first.tolerance)} {first.tolerance_kind}"}
        for eng in engs:
            r = grp[grp.engine == eng]
            if not len(r):
                line[eng] = ""
                continue
            r = r.iloc[0]
            shown = _fmt(r.measured) if r.status in ("pass", "fail", "deviation") else ""
            line[eng] = f"{shown} {STATUS_MARK[r.status]}".strip()
        out.append(line)
    return pd.DataFrame(out)


def deviation_summary(dev: pd.DataFrame) -> pd.DataFrame:
    out = []
    for (eng, cause), grp in dev.groupby(["engine", "known_deviation"], sort=False):
        worst = grp.loc[grp.over_tol.idxmax()]
        out.append({"engine": eng, "cause": cause, "checks": len(grp),
                    "worst check": f"{worst.case}[{worst.variant}]:{worst.metric}",
                    "expected": _fmt(worst.expected), "measured": _fmt(worst.measured),
                    "error/tol": f"{worst.over_tol:.3g}"})
    return pd.DataFrame(out)


def stale_deviations(df: pd.DataFrame) -> list[str]:
    """Entries of adapters/xfails that matched no check, or whose checks all passed."""
    notes = []
    for eng in df.engine.unique():
        for d in deviations.load(eng):
            hit = df[(df.engine == eng) & (df.case == d.family)]
            hit = hit[[d.matches(r.case, r.variant, r.metric) for r in hit.itertuples()]]
            if hit.empty:
                if d.family in set(df.case):
                    notes.append(f"{eng}: `{d.pattern}` (line {d.line}) matched no check in this run")
            elif (hit.status == "pass").all():
                notes.append(f"{eng}: `{d.pattern}` (line {d.line}) passed everywhere: the deviation is gone, remove the entry")
    return notes


def plot_effective(eff: pd.DataFrame, path: Path) -> None:
    """Asked against measured restitution and friction, one line per engine."""
    plt = _plt()
    params = list(dict.fromkeys(eff.parameter))
    fig, axes = plt.subplots(1, len(params), figsize=(4.2 * len(params), 3.8), squeeze=False)
    for ax, param in zip(axes[0], params):
        part = eff[eff.parameter == param]
        lo, hi = float(part.asked.min()), float(part.asked.max())
        ax.plot([lo, hi], [lo, hi], color="black", lw=0.8, ls="--", label="asked = measured")
        for eng, grp in part.groupby("engine", sort=False):
            ax.plot(grp.asked, grp.measured, marker="o", label=eng)
        ax.set_xlabel(f"asked {param}")
        ax.set_ylabel("measured")
        ax.set_title(param)
    axes[0][0].legend(fontsize=8)
    fig.tight_layout()
    _save(fig, path)


def effective_section(eff: pd.DataFrame) -> list[str]:
    lines = ["## Asked vs measured parameters", "",
             "What each engine actually produces when asked for a restitution or friction coefficient "
             "(`physval/effective.py`; also in `effective_parameters.csv`). No tolerance: a mismatch is "
             "a finding about the engine's contact model.", "",
             "![asked vs measured](plots/effective_parameters.png)", ""]
    for eng, grp in eff.groupby("engine", sort=False):
        shown = grp[["parameter", "asked", "measured", "difference", "note"]].copy()
        for col in ("asked", "measured", "difference"):
            shown[col] = shown[col].map(_fmt)
        lines += [f"**{eng}**", "", _md_table(shown), ""]
    return lines


def plot_laws(summary: pd.DataFrame, path: Path) -> None:
    """Each engine's worst physics-law residual over the battery, one panel per law."""
    from physval.laws import RESIDUALS
    plt = _plt()
    fig, axes = plt.subplots(1, len(RESIDUALS), figsize=(3.4 * len(RESIDUALS), 3.6), squeeze=False)
    floor = 1e-16  # an exact zero is drawn at the floor of the log axis
    for ax, key in zip(axes[0], RESIDUALS):
        values = pd.to_numeric(summary[key], errors="coerce")
        shown = values.where(values > floor, floor).fillna(floor)
        ax.bar(summary.engine, shown, color=["tab:gray" if math.isnan(v) else "tab:blue" for v in values])
        ax.set_yscale("log")
        ax.set_title(key, fontsize=9)
        ax.tick_params(axis="x", labelrotation=45, labelsize=8)
    fig.tight_layout()
    _save(fig, path)


def laws_section(laws: pd.DataFrame, plot: Path) -> list[str]:
    """The report's section on physics-law residuals (rows of physval.laws.measure); draws `plot`."""
    from physval.laws import ACTIVE, MAX_SECONDS, SLIDING, summary
    measured = laws[laws.point_steps.notna()] if "point_steps" in laws else laws.iloc[0:0]
    worst = pd.DataFrame(summary(measured.to_dict("records")))
    lines = ["## Physics-law residuals", "",
             "Each engine's own contact forces (`Simulation.contact_points`) against the laws of rigid contact, "
             "point by point and step by step over a battery of library scenes (`physval/laws.py`, each scene "
             f"at its family's time step for at most {MAX_SECONDS:g} s): penetration; complementarity, the power "
             "f_n max(v_n + e min(v_n-, 0), 0) of a normal force on a contact separating faster than restitution "
             "asks; friction-cone excess |f_t| / (mu_s f_n) - 1; maximal-dissipation gap "
             f"1 + f_t . v_t / (mu_k f_n |v_t|) on sliding points (|v_t| > {SLIDING:g} m/s; 0 is full Coulomb "
             f"friction against the slip, 1 none). Points with f_n below {ACTIVE:g} of the scene's weight are "
             "left out of cone and dissipation. An engine that reports one resultant per touching pair "
             "(Pymunk) is read at the pair's mean point, so a pair that rocks or turns on two points reads as one "
             "point's slip. No tolerance: these are readings, all in `laws.csv`.", ""]
    if len(worst):
        plot_laws(worst, plot)
        from physval.laws import RESIDUALS
        shown = pd.DataFrame({"engine": worst.engine, "scenes": worst.scenes})
        for key in RESIDUALS:
            shown[key] = [f"{_fmt(v)} ({where})" if where else "-"
                          for v, where in zip(worst[key], worst[f"{key} worst in"])]
        lines += ["Worst over the battery per engine (in brackets: the scene it occurs in):", "",
                  _md_table(shown), "", "![physics-law residuals](plots/laws.png)", ""]
    notes = laws[laws.note.fillna("") != ""]
    if len(notes):
        lines += ["Not measured:", ""] + [f"- {r.engine}{' ' + r.case if r.case else ''}: {r.note}"
                                          for r in notes.itertuples()] + [""]
    return lines


def plot_agreement(agree: pd.DataFrame, engines: list[str], path: Path) -> None:
    """Each engine's distance from the reference, in tolerances, per quantity."""
    from physval.agreement import REFERENCE, distance
    plt = _plt()
    agree = agree[agree[REFERENCE].notna()] if REFERENCE in agree else agree.iloc[0:0]
    if not len(agree):
        return
    fig, ax = plt.subplots(figsize=(max(6.0, 0.32 * len(agree)), 4.2))
    x = np.arange(len(agree))
    for i, eng in enumerate(e for e in engines if e != REFERENCE and e in agree):
        signed = [(1 if v >= r else -1) * distance(k, v, r) / t if t > 0 else math.nan
                  for v, r, t, k in zip(agree[eng], agree[REFERENCE], agree.tolerance, agree.kind)]
        ax.scatter(x + 0.08 * (i - 1.5), signed, s=14, label=eng)
    ax.axhspan(-1, 1, color="tab:green", alpha=0.12, label="within the check's tolerance")
    ax.set_yscale("symlog", linthresh=1)
    ax.set_xticks(x, [f"{c}[{v}]:{m}" for c, v, m in zip(agree.case, agree.variant, agree.metric)],
                  rotation=90, fontsize=6)
    ax.set_ylabel("(engine - reference) / tolerance")
    ax.legend(fontsize=7, ncol=2)
    fig.tight_layout()
    _save(fig, path)


def agreement_section(agree: pd.DataFrame, engines: list[str], plot: Path) -> list[str]:
    plot_agreement(agree, engines, plot)
    shown = agree.drop(columns=["kind"]).copy()
    for col in shown.columns:
        if shown[col].dtype.kind == "f":
            shown[col] = shown[col].map(_fmt)
    return ["## Cross-engine agreement", "",
            "Families without a full closed form, checked on their well-posed quantities (`cross_engine` "
            "families; `physval/agreement.py`, also in `agreement.csv`): every engine's value side by side, "
            "the spread across engines, and the engine farthest from the reference in units of the check's "
            "tolerance (<= 1: it agrees with the reference).", "",
            "![engines against the reference](plots/agreement.png)", "", _md_table(shown), ""]


def write_report(rows: list[dict], out: Path, title: str = "physval report", command: str = "",
                 effective: list[dict] | None = None, laws: list[dict] | None = None,
                 cross_engine: set[str] = frozenset()) -> pd.DataFrame:
    """Write results.csv, report.md and plots into `out` (and effective_parameters.csv,
    laws.csv, agreement.csv when asked-vs-measured rows, physics-law rows or `cross_engine`
    families are given); return the results frame."""
    out = Path(out)
    df = frame(rows)
    write_csv(df, out / "results.csv")
    eff = pd.DataFrame(effective or [], columns=["engine", "parameter", "asked", "measured", "difference", "note"])
    if len(eff):
        write_atomic(out / "effective_parameters.csv", eff.to_csv(index=False))
        if eff.measured.notna().any():
            plot_effective(eff[eff.measured.notna()], out / "plots" / "effective_parameters.png")
    law = pd.DataFrame(laws or [])
    if len(law):
        write_atomic(out / "laws.csv", law.to_csv(index=False))
    plots = out / "plots"
    plot_summary(df, plots / "summary.png")
    for fam in sorted(df.case.unique()):
        plot_family(df, fam, plots / f"{fam}.png")

    counts = Counter(df.status)
    lines = [f"# {title}", ""]
    if command:
        lines += [f"Command: `{command}`", ""]
    lines += [f"{len(df)} checks from {df.groupby(['case', 'variant', 'engine']).ngroups} runs: "
              + ", ".join(f"{counts[s]} {s}" for s in STATUSES if counts[s]) + ".", "",
              "Statuses: **pass** within the tolerance; **fail** outside it; **deviation** a known engine "
              "shortfall (listed in `adapters/xfails/<engine>.txt`, shown below with its measured size); "
              "**unsupported** the engine cannot represent the scene; **unstable** NaN or blow-up; "
              "**error** an exception. Each tolerance's reason is in `results.csv` (`tolerance_reason`).", "",
              "## Summary", "", _md_table(summary_matrix(df)), "",
              "![worst error per family and engine](plots/summary.png)", ""]

    lines += ["## Known deviations", "",
              "One row per engine and cause (`adapters/xfails/<engine>.txt`), with the checks it covers and "
              "the worst of them; every check is in the family tables below and in `results.csv`.", ""]
    dev = df[df.status == "deviation"]
    if len(dev):
        lines += [_md_table(deviation_summary(dev)), ""]
    else:
        lines += ["_(none in this run)_", ""]
    stale = stale_deviations(df)
    if stale:
        lines += ["Stale entries in the deviation files:", ""] + [f"- {s}" for s in stale] + [""]

    bad = df[df.status.isin(["fail", "unstable", "error"])]
    lines += ["## Failures, blow-ups and errors", ""]
    if len(bad):
        lines += [_md_table(pd.DataFrame({
            "status": bad.status, "engine": bad.engine, "check": bad.case + "[" + bad.variant + "]:" + bad.metric,
            "expected": bad.expected.map(_fmt), "measured": bad.measured.map(_fmt), "reason": bad.reason})), ""]
    else:
        lines += ["_(none)_", ""]

    uns = df[df.status == "unsupported"].drop_duplicates(["engine", "case", "reason"])
    if len(uns):
        lines += ["## Unsupported", "", _md_table(uns[["engine", "case", "reason"]]), ""]

    if len(eff):
        lines += effective_section(eff)
    from physval.agreement import table as agreement_table
    agree = agreement_table(df, set(cross_engine))
    if len(agree):
        write_atomic(out / "agreement.csv", agree.to_csv(index=False))
        lines += agreement_section(agree, list(dict.fromkeys(df.engine)), plots / "agreement.png")
    if len(law):
        lines += laws_section(law, plots / "laws.png")

    lines += ["## Families", ""]
    for fam in sorted(df.case.unique()):
        first = df[df.case == fam].iloc[0]
        lines += [f"### {fam}", "", f"Effects simulated: {first.effects}.", "",
                  f"![{fam}](plots/{fam}.png)", "", _md_table(family_table(df, fam)), ""]

    lines += ["## Engine settings", "",
              "The knobs each adapter set (engine's own names), from one run per engine; every run's "
              "record is in the `knobs` column of `results.csv`.", ""]
    for eng, grp in df[df.knobs != ""].groupby("engine", sort=False):
        lines += [f"**{eng}** (effects simulated in that run: {grp.iloc[0].effects_simulated})", "", "```",
                  json.dumps(json.loads(grp.iloc[0].knobs), indent=1, sort_keys=True), "```", ""]

    timing = df.drop_duplicates(["case", "variant", "engine"])
    timing = timing[timing.steps.astype(str) != ""]
    if len(timing):
        t = timing.groupby("engine").apply(
            lambda g: pd.Series({"runs": len(g), "steps": int(pd.to_numeric(g.steps).sum()),
                                 "us per step (median over runs)": float(np.median(g.wall_s / pd.to_numeric(g.steps)) * 1e6)}),
            include_groups=False).reset_index()
        lines += ["## Cost", "", "Wall time of stepping only (scene construction excluded), all families "
                  "together; see `physval sweep` for error against cost.", "", _md_table(t), ""]

    lines += ["## Environment", "", _md_table(pd.DataFrame(list(environment(df).items()), columns=["what", "value"])), ""]
    write_atomic(out / "report.md", "\n".join(lines))
    return df
