"""Which jobs a run holds: each selected variant on each selected engine, less what an
engine's defaults leave out (families outside its default tags, runs it declares on demand
outside them).
"""
from __future__ import annotations

from physval.core.jobs import Job


def plan(chosen: dict, engines: list[str], resolver, engines_named: bool, dt=None, iterations=None,
         on_demand: bool = False) -> tuple[list[Job], list[Job]]:
    """(jobs to run, jobs left out as on demand). An engine with `default_tags` runs only
    families with one of those tags (and the variants whose compliant contact law it
    models), unless it was named; a job the adapter declares on demand runs only when asked,
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
                    if not (laws and laws <= adapter.capabilities.contact_laws):
                        continue
                if not on_demand and adapter.deferred(scene, fam.tags):
                    later.append(job)
                    continue
                jobs.append(job)
    return jobs, later
