"""Running jobs in the test process (no worker), with stand-in adapters and known deviations."""
from __future__ import annotations

from physval.core import Context, Job, execute
from physval.core.context import Resolver


def run_job(job: Job, family=None, adapter=None, known=None) -> list[dict]:
    """The verdict rows of one job, run here: `family`, `adapter`, `known` (a list of
    deviations for the job's engine) replace what the names would resolve to."""
    resolver = Resolver(Context())
    resolver.provide(job.engine, adapter, known, family)
    return execute(job, resolver).rows
