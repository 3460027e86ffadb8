"""Which engine is closest to physics on each effect, and at what cost: each effect's
ranking of the engines by the scorecard's grade (physval.readings.scorecard: the grade, then
the larger share within tolerance, the smaller typical miss, the more checks judged), and
one line per effect naming the first of it, the reference implementation and its
formulations aside (they are built from the lecture notes the closed forms come from), with
its wall time per simulated second in the run: the median over the effect's runs of
`wall_s / sim_s` of results.csv.
"""
from __future__ import annotations

import math

import pandas as pd

from physval.readings.scorecard import EFFECTS, ORDER
from physval.report import Section, fmt, md_table

SHOWN = 3  # engines named after the closest, per effect
ASIDE = "reference"  # the reference implementation (and reference-*, its formulations)


def ranking(card: pd.DataFrame) -> pd.DataFrame:
    """Per effect, the engines from the closest to physics (rank 1) to the farthest, those
    with a grade only: effect, rank, engine, grade, within, judged, miss, ms_per_s."""
    graded = card[card.effect.isin(EFFECTS) & card.grade.isin(ORDER)]
    return graded.sort_values(["effect", "rank"], key=lambda c: c.map(list(EFFECTS).index) if c.name == "effect"
                              else c)[["effect", "rank", "engine", "grade", "within", "judged", "miss", "ms_per_s"]]


def _named(r) -> str:
    cost = f"; {fmt(r.ms_per_s)} ms per simulated second" if math.isfinite(r.ms_per_s) else ""
    miss = f", typical miss {fmt(r.miss)} tol" if r.grade != "A" and math.isfinite(r.miss) else ""
    return f"{r.engine} (**{r.grade}**, {r.within}/{r.judged} within{miss}{cost})"


def _standing(r) -> tuple:
    """What ties two engines: the same grade, counts and typical miss (none: A)."""
    return r.grade, r.within, r.judged, "" if math.isnan(r.miss) else r.miss


def answers(card: pd.DataFrame, aside: str = ASIDE) -> list[str]:
    """One line per effect: the engine closest to physics on it and its cost (engines tied
    with it at the same grade and counts, up to SHOWN, the cheapest first), then the next
    SHOWN of the ranking; engines named `aside` or `aside-*` left out (the reference
    implementation and its formulations)."""
    ranked = ranking(card)
    ranked = ranked[(ranked.engine != aside) & ~ranked.engine.str.startswith(aside + "-")]
    lines = []
    for effect, grp in ranked.groupby("effect", sort=False):
        rows = list(grp.itertuples())
        best = rows[0]
        tied = [r for r in rows if _standing(r) == _standing(best)]
        text = f"- **{effect}**: " + ", ".join(_named(r) for r in tied[:SHOWN])
        if len(tied) > 1:
            text += f" (tied{f', and {len(tied) - SHOWN} more' if len(tied) > SHOWN else ''})"
        rest = rows[len(tied):len(tied) + SHOWN]
        if rest:
            text += "; then " + ", ".join(f"{r.engine} **{r.grade}**" for r in rest)
        lines.append(text)
    return lines


INTRO = ("Which engine is closest to physics on each effect, and at what cost: the first of each effect's ranking "
         "(the scorecard's grade, then the share within tolerance, the typical miss, the checks judged, the cost), "
         "the reference implementation and its formulations aside, with its wall time per simulated second in this "
         "run (the median over the effect's runs of `wall_s / sim_s`; wall time, so a loaded machine inflates it: "
         "compare engines within one run). An engine is judged on the checks it can represent: a 2D engine on the "
         "2D variants.")


def section(card: pd.DataFrame) -> str:
    """"Closest to physics": one line per effect, and the full ranking of every effect."""
    lines = answers(card)
    if not lines:
        return ""
    ranked = ranking(card)
    order = pd.DataFrame([{"effect": effect, "engines, closest first": ", ".join(
        f"{r.engine} {r.grade}" for r in grp.itertuples())} for effect, grp in ranked.groupby("effect", sort=False)])
    return "\n".join(["## Closest to physics", "", INTRO, ""] + lines + [
        "", "<details><summary>Every engine, ranked per effect</summary>", "", md_table(order), "", "</details>", ""])


class Closest(Section):
    """Per effect, the engine closest to physics and its cost, and the whole ranking; its
    source names the run's grades (`card`: physval.readings.scorecard.measure)."""

    def measure(self, run) -> pd.DataFrame:
        return run.card

    def markdown(self, card: pd.DataFrame) -> str:
        return section(card)
