"""The execution core: a job (a case variant on an engine at given settings) is built,
stepped, recorded and judged by one function, `execute`; `run_jobs` runs a selection of
jobs on an executor (local worker processes or a Dask cluster), streaming finished jobs
to a row store. Every command and reading goes through it.

    context.py    what a process needs to turn names into families, adapters, deviations
    selection.py  the one grammar for --cases and --engines
    jobs.py       Job, Outcome, Probe, execute; Task, a job of a non-family kind
    record.py     stepping and recording a simulation (bulk state reads, blow-up checks)
    tolerance.py  a measurement's error and the tolerance that bounds it
    verdicts.py   statuses, judging a check against its closed form and bands
    executor.py   local worker processes (crash- and timeout-isolated) or Dask
    store.py      the streaming, resumable row store and the code fingerprint
    session.py    run_jobs: executor + store + progress + interrupts
    dry_run.py    user code (family files, --adapter files) tried in workers before use
"""
from physval.core.context import Context, Resolver
from physval.core.jobs import Job, Outcome, Probe, Task, execute, steps_of, time_step
from physval.core.record import Run, Unstable, simulate
from physval.core.session import Results, run_jobs
from physval.core.verdicts import COLUMNS, STATUSES

__all__ = ["Context", "Resolver", "Job", "Outcome", "Probe", "Task", "execute", "steps_of", "time_step", "Run",
           "Unstable", "simulate", "Results", "run_jobs", "COLUMNS", "STATUSES"]
