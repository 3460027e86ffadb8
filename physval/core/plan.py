"""Which jobs a run holds: each selected variant on each selected engine, less what an
engine's defaults leave out (families outside its default tags, runs it declares on demand
outside them).
"""
from __future__ import annotations

from cases import relations as invariances
from physval.core.jobs import Job
from physval.core.selection import select_variants


def plan(chosen: dict, engines: list[str], resolver, engines_named: bool, dt=None, iterations=None,
         on_demand: bool = False) -> tuple[list[Job], list[Job]]:
    """(jobs to run, jobs left out as on demand). An engine with `default_tags` runs only
    families with one of those tags (and, with `default_laws`, the variants whose compliant
    contact law it models), unless it was named; a job the adapter declares on demand runs only when asked,
    unless its family is one of the default ones (Adapter.deferred)."""
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
                if not engines_named and adapter.default_tags is not None and not (fam.tags & adapter.default_tags):
                    laws = scene.contact_laws
                    if not (adapter.default_laws and laws and laws <= adapter.capabilities.contact_laws):
                        continue
                if not on_demand and adapter.deferred(scene, fam.tags):
                    later.append(job)
                    continue
                jobs.append(job)
    return jobs, later


def relation_jobs(names: list[str], engines: list[str], resolver, engines_named: bool, chosen: dict | None = None,
                  dt=None, iterations=None) -> list[Job]:
    """Jobs of the invariance relations `names` (cases.relations): on every variant of
    `chosen` (family name -> variants) where given, else on each relation's default scenes
    (Relation.scenes: from each group, the first an engine can represent). A relation without
    meaning for a scene (a 2D scene turned about the vertical) is no job. The reference's
    slower formulations (Adapter.slow) run the battery only when named, as the other readings
    that repeat a scene; an engine that is not installed gets its rows saying so."""
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
            if adapter is not None and adapter.default_tags is not None and not engines_named:
                # as for the families (plan): an engine that names its default tags runs the
                # relations only on scenes of those families (none: on demand only)
                pool = {fam: vs for fam, vs in pool.items() if resolver.family(fam).tags & adapter.default_tags}
            jobs += [Job(fam, v, eng, dt, iterations, relation=relation.name)
                     for fam, variants in pool.items() for v in variants if relation.applies(scene_of(fam, v)) is None]
    return jobs
