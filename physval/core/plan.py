"""Which jobs a run holds: each selected variant on each selected engine, less what the one
rule of this module (`leaves_out`) leaves out: families outside an engine's default tags,
runs the engine declares on demand outside them, and runs whose measured cost passes the
per-job limit (with hysteresis: `over_the_limit`), unless the run's store holds them finished:
a finished job costs nothing (`finished`: a measurement's load or an engine's import that put a
job over the limit in one run would otherwise drop its rows from the next, and its report).
"""
from __future__ import annotations

import math
from typing import Callable

from cases import relations as invariances
from physval.core.jobs import Job
from physval.core.selection import select_variants

# A default run's budget is 3 minutes on 2 cores, 360 worker-seconds (decision 10). A job
# measured to cost more than 15 s (about 4 % of that budget) waits for --on-demand: one such
# job would take a visible share of the run on its own. In the quiet default runs of the
# shipped table the costliest jobs took 10.9 and 9.3 s (reference-newton-coulomb's
# resting_blocks n=5 and n=4) and 7.1 s (DART's 10-box stack), all under the limit; over it
# only reference-lemke's 3D pinch grasps at 2 mu F / m g = 0.98 and 1.25 (125 and 119 s, its
# pivoting on a degenerate LCP), priced apart in the table (its per-variant rows).
# The limit has hysteresis (`over_the_limit`): a job measured near it (the grasp at 1.02,
# 7.6 s a job in a quiet run and 17.1 s in a loaded one) would otherwise leave the default
# run and come back from one regeneration of the table to the next, and the committed
# reports and the next default run would disagree on whether it runs.
PER_JOB_LIMIT_S = 15.0

# a job's measured cost in worker-seconds (NaN: not measured), and whether the cost table
# prices it apart (a row of its own variant: physval.readings.cost.pricer)
Price = Callable[[Job], tuple[float, bool]]


def over_the_limit(cost: float, apart: bool) -> bool:
    """Whether a job measured at `cost` seconds waits for --on-demand, the per-job limit L
    (PER_JOB_LIMIT_S) with hysteresis: a job the cost table does not price apart (`apart`
    False: priced by its family, or new) waits only above L; one it prices apart (a row of
    its own, written when the job was measured over L) keeps waiting while its cost is above
    L/2 and comes back only below L/2. The table keeps a job apart by the same rule
    (physval.readings.cost.per_family), so one measurement between L/2 and L, quiet or
    loaded, moves no job in or out of the run."""
    return cost > (PER_JOB_LIMIT_S / 2 if apart else PER_JOB_LIMIT_S)


def leaves_out(adapter, tags: frozenset[str], scene, *, named: bool = False, on_demand: bool = False,
               cost: float = math.nan, apart: bool = False) -> str | None:
    """Why a run leaves out the run of `scene` (of a family tagged `tags`) on `adapter`, or
    None: it takes it. The one rule of what a run takes, which `plan`, `relation_jobs` and
    the tests that follow a default run apply.
    - An engine with `default_tags`, not named (`named`: --engines names engines), runs only
      the families with one of those tags, and (with `default_laws`) the variants whose
      compliant contact law it models; the rest not even with --on-demand.
    - Without `on_demand`, a run the adapter declares on demand (Adapter.deferred), or one
      whose measured `cost` (seconds a job) is over the per-job limit, waits for --on-demand:
      over PER_JOB_LIMIT_S, or over half of it where the cost table prices the job apart
      (`apart`; the hysteresis of `over_the_limit`)."""
    if not named and adapter.default_tags is not None and not (tags & adapter.default_tags):
        laws = scene.contact_laws
        if not (adapter.default_laws and laws and laws <= adapter.capabilities.contact_laws):
            return (f"{adapter.name} runs the families tagged {', '.join(sorted(adapter.default_tags)) or 'none'} "
                    "unless named (--engines)")
    if on_demand:
        return None
    why = adapter.deferred(scene, tags)
    if why:
        return f"waits for --on-demand: {why}"
    if over_the_limit(cost, apart):
        limit = f"the per-job limit {PER_JOB_LIMIT_S:.0f} s"
        back = f"it runs again when measured under half of it, {PER_JOB_LIMIT_S / 2:g} s"
        if cost > PER_JOB_LIMIT_S:
            return f"waits for --on-demand: measured {cost:.3g} s a job, over {limit}" + (
                f" (priced apart: {back})" if apart else "")
        return (f"waits for --on-demand: measured {cost:.3g} s a job, under {limit} but priced apart (once over "
                f"it): {back}")
    return None


def priced(price: Price | None, job: Job, finished: frozenset = frozenset()) -> dict:
    """leaves_out's `cost` and `apart` of `job` by `price` (none: not measured, or `finished`
    holds its key: its rows are in the run's store, and taking it costs nothing)."""
    if price is None or job.key in finished:
        return {}
    cost, apart = price(job)
    return {"cost": cost, "apart": apart}


def plan(chosen: dict, engines: list[str], resolver, engines_named: bool, dt=None, iterations=None,
         on_demand: bool = False, price: Price | None = None,
         finished: frozenset = frozenset()) -> tuple[list[Job], list[tuple[Job, str]]]:
    """(jobs to run, (job, why) of those left out until --on-demand), by `leaves_out`;
    `price`: a job's measured cost and whether it is priced apart
    (physval.readings.cost.pricer), for the per-job limit, which spares the jobs whose keys
    `finished` holds (the run's store has their rows)."""
    jobs, later = [], []
    for name, variants in chosen.items():
        fam = resolver.family(name)
        for v in variants:
            scene = None
            for eng in engines:
                job = Job(name, v, eng, dt, iterations)
                try:
                    adapter = resolver.adapter(eng)
                except Exception:
                    jobs.append(job)  # not installed: its rows say so
                    continue
                if scene is None:
                    scene = fam.scene(v.params)
                if leaves_out(adapter, fam.tags, scene, named=engines_named, on_demand=True):
                    continue  # not in this run, even on demand
                why = None if on_demand else leaves_out(adapter, fam.tags, scene, named=engines_named,
                                                        **priced(price, job, finished))
                if why:
                    later.append((job, why))
                    continue
                jobs.append(job)
    return jobs, later


def relation_jobs(names: list[str], engines: list[str], resolver, engines_named: bool, chosen: dict | None = None,
                  dt=None, iterations=None, on_demand: bool = False, price: Price | None = None,
                  finished: frozenset = frozenset()) -> list[Job]:
    """Jobs of the invariance relations `names` (cases.relations): on every variant of
    `chosen` (family name -> variants) where given, else on each relation's default scenes
    (Relation.scenes: from each group, the first an engine can represent). A relation without
    meaning for a scene (a 2D scene turned about the vertical) is no job. The reference's
    slower formulations (Adapter.slow) run the battery only when named, as the other readings
    that repeat a scene; what a run leaves out of an engine's families (`leaves_out`) it
    leaves out of its relations (a battery has no later: what waits for --on-demand is
    no job); an engine that is not installed gets its rows saying so."""
    jobs, scenes = [], {}

    def scene_of(fam: str, v):
        if (fam, v.id) not in scenes:
            scenes[fam, v.id] = resolver.family(fam).scene(v.params)
        return scenes[fam, v.id]

    defaults = {spec: next(iter(select_variants(resolver.families, [spec]).items()))
                for r in map(invariances.by_name, names) for group in r.scenes for spec in group} \
        if chosen is None else {}
    for relation in map(invariances.by_name, names):
        for eng in engines:
            try:
                adapter = resolver.adapter(eng)
            except Exception:
                adapter = None
            if adapter is not None and adapter.slow and not engines_named:
                continue
            pool = chosen or {}
            if chosen is None:
                pool = {}
                for group in relation.scenes:
                    for spec in group:
                        fam, (v, *_) = defaults[spec]
                        if relation.applies(scene_of(fam, v)) is None and (
                                adapter is None or adapter.capabilities.cannot_run(scene_of(fam, v)) is None):
                            pool.setdefault(fam, []).append(v)
                            break
            for fam, variants in pool.items():
                for v in variants:
                    job = Job(fam, v, eng, dt, iterations, relation=relation.name)
                    if relation.applies(scene_of(fam, v)) is None and (adapter is None or not leaves_out(
                            adapter, resolver.family(fam).tags, scene_of(fam, v), named=engines_named,
                            on_demand=on_demand, **priced(price, job, finished))):
                        jobs.append(job)
    return jobs
