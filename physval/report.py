"""The report of `physval run`: report.md and plots/, built from sections (physval.readings).
results.csv is the row store itself (physval.core.store), finalised in job order."""
from __future__ import annotations

from pathlib import Path

from physval.core import COLUMNS
from physval.readings import verdicts
from physval.reportkit import (contents, heading, engine_versions, environment, frame, md_table, problems_section, status_counts,
                               summary_matrix, unsupported_section, write_atomic)

INTRO = ("physval runs analytic cases (closed-form answers with tolerances, each with its reason) on physics "
         "engines and judges every check. Read the summary first; each family's section says what it checks "
         "and why its tolerances have their size.")


def write_run_report(rows: list[dict], out: Path, families: dict, command: str = "", complete: bool = True,
                     planned: int | None = None, engine_wide: dict | None = None, stale: list[str] = ()) -> None:
    """report.md and plots/ for the rows of a run; `complete` False: an interrupted run's
    report (marked so, without plots). `stale`: notes on known-deviation entries."""
    out = Path(out)
    df = frame(rows, COLUMNS)
    runs = df.groupby(["case", "variant", "engine"]).ngroups if len(df) else 0
    head = heading("physval report", command,
                   "" if complete else f"the run was interrupted after {runs} of {planned} runs. Finished runs are "
                                        "kept and not recomputed; plots are drawn when it completes.")
    head += [INTRO, "", f"{len(df)} checks from {runs} runs: {status_counts(df)}.", ""]
    if not complete:
        body = [md_table(summary_matrix(df)), ""] if len(df) else []
        body += problems_section(df)
        write_atomic(out / "report.md", "\n".join(head + body))
        return
    plots = out / "plots"
    sections = ["\n".join(verdicts.summary_sections(df, plots)),
                "\n".join(verdicts.deviation_sections(df, list(stale))),
                "\n".join(problems_section(df)),
                "\n".join(unsupported_section(df))]
    from physval.readings import agreement, effective, laws
    engine_wide = engine_wide or {}
    if "effective" in engine_wide:
        sections.append(effective.section(engine_wide["effective"], out))
    agree = agreement.measure(df, {n for n, f in families.items() if f.cross_engine})
    if len(agree):
        sections.append(agreement.section(agree, out))
    if "laws" in engine_wide:
        sections.append(laws.section(engine_wide["laws"], out))
    sections += ["\n".join(verdicts.family_sections(df, families, plots)),
                 "\n".join(verdicts.settings_section(df)), "\n".join(verdicts.cost_section(df)),
                 "\n".join(["## Environment", "", md_table(environment(engine_versions(df))), ""])]
    sections = [s for s in sections if s.strip()]
    write_atomic(out / "report.md", "\n".join(head + [contents(sections)] + sections))
