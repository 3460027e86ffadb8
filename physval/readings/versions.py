"""The report of `physval versions` (versions.md): each release's environment and run, and
what changed between each pair of releases compared (physval.readings.compare)."""
from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import pandas as pd

from physval.readings import compare
from physval.readings.divergence import PARTED
from physval.readings.checks import status_counts
from physval.report import fmt, heading, md_table, write_atomic


@dataclass(frozen=True)
class Release:
    release: str
    env: object            # physval.core.envs.Env
    run_s: float           # wall time of the release's `physval run` (resumed: only what was left)
    folder: Path


def _environment(env) -> str:
    made = f"made now in {env.seconds:.0f} s" if env.created else f"from the cache (made in {env.seconds:.0f} s)"
    own = ", ".join(f"{n} {v}" for n, v in env.installed.items()) or "nothing: the machine's own release"
    return f"{made}; its own packages: {own}"


def _parting(parts: pd.DataFrame | None) -> str:
    """'11 of 75 jobs, first at 0.003 s': how many trajectories part, and the earliest."""
    if parts is None:
        return "not saved"
    both = parts[parts.steps.notna()]
    parted = both[both.parted_step.notna()]
    return f"{len(parted)} of {len(both)} jobs" + (f", first at {parted.parted_time.min():.4g} s" if len(parted) else "")


def _pair_row(a: str, b: str, table: pd.DataFrame, parts: pd.DataFrame | None) -> dict:
    n = compare.counts(table)
    moved = table[table.change.isin(["status", "moved"])]
    return {"A": a, "B": b, "status changed": n["status"], "moved": n["moved"], "only in A": n["only in A"],
            "only in B": n["only in B"], "identical": n["same"],
            "largest move (tol)": fmt(table.move.max()) if table.move.notna().any() else "",
            "towards closed form": int((moved.direction == "towards").sum()),
            "away": int((moved.direction == "away").sum()), "trajectories part": _parting(parts),
            "report": f"[compare.md](compare/{a}-vs-{b}/compare.md)"}


def write(out: Path, package: str, engines: list[str], releases: list[Release], compared: list, threshold: float,
          command: str) -> None:
    """versions.md in `out`: the pairs compared, then each release's environment and run."""
    runs = []
    for r in releases:
        df = compare.load(r.folder)
        runs.append({"release": r.release, "Python": r.env.python.version.split()[0],
                     "environment": _environment(r.env), "run s": f"{r.run_s:.0f}",
                     "checks": len(df), "statuses": status_counts(df)})
    lines = heading(f"{package} across releases", command) + [
        f"Engines: {', '.join(engines)}. Each release ran in a virtual environment of its own holding that release "
        "(cached under physval's cache folder, envs/), with this physval's code; a check moved when its error "
        f"moved by more than {threshold:g} of its tolerance; trajectories part where a state differs by more than "
        f"{PARTED:g} of its scale (compare.md says how).", "",
        "## What changed", "",
        md_table(pd.DataFrame([_pair_row(*pair) for pair in compared])), "",
        "## The releases", "",
        md_table(pd.DataFrame(runs)), "",
        "Each release's run is in its folder (RELEASE/: results.csv, report.md). `run s` is the wall time of its "
        "`physval run`; run again, the command reuses each environment and every finished job.", ""]
    write_atomic(out / "versions.md", "\n".join(lines))

