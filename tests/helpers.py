"""Running jobs in the test process (no worker), with stand-in adapters and known deviations;
and a built-in variant's scene at its family's dt, for the tests that build an engine directly."""
from __future__ import annotations

from physval.core import Context, Job, execute
from physval.core.context import Resolver


def run_job(job: Job, family=None, adapter=None, known=None) -> list[dict]:
    """The verdict rows of one job, run here: `family`, `adapter`, `known` (a list of
    deviations for the job's engine) replace what the names would resolve to."""
    resolver = Resolver(Context())
    resolver.provide(job.engine, adapter, known, family)
    return execute(job, resolver).rows


def variant_scene(family: str, variant: str):
    """(scene, settings) of built-in `family`'s variant `variant`, at the family's dt for it."""
    from adapters.base import Settings
    from cases.registry import builtin_families
    fam = builtin_families()[family]
    v = next(v for v in fam.variants if v.id == variant)
    return fam.scene(v.params), Settings(dt=fam.dt_for(v.params))
