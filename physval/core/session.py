"""Running a selection of jobs: through an executor, streaming each finished job to a row
store, skipping jobs the store already holds, with progress, and stopping promptly on
Ctrl-C or SIGTERM with everything finished kept.
"""
from __future__ import annotations

import sys
import time
from dataclasses import dataclass, field

from physval.core.context import Context
from physval.core.executor import DEFAULT_JOB_TIMEOUT, make_executor
from physval.core.jobs import Call, CallResult, Job
from physval.core.store import RowStore, cache_keys
from physval.interrupts import Terminated, sigterm_as_ctrl_c


@dataclass
class Results:
    rows: dict[str, list[dict]] = field(default_factory=dict)  # job key -> rows (extra columns merged)
    ran: int = 0          # jobs run now
    reused: int = 0       # jobs taken from the store
    interrupted: str = ""  # "SIGINT" / "SIGTERM" when stopped early

    @property
    def complete(self) -> bool:
        return not self.interrupted

    def ordered(self, jobs: list[Job]) -> list[dict]:
        return [r for j in jobs for r in self.rows.get(j.key, [])]


class Progress:
    """A bar on a terminal; elsewhere a line every 10 % (or 60 s) with the time left."""

    def __init__(self, total: int, label: str, enabled: bool = True):
        self.total, self.label, self.done = total, label, 0
        self.start = self.last = time.monotonic()
        self.tty = enabled and sys.stderr.isatty()
        self.enabled = enabled and total > 0
        self.bar = None
        if self.tty and self.enabled:
            from tqdm import tqdm
            self.bar = tqdm(total=total, unit="job", desc=label, dynamic_ncols=True)

    def update(self, what: str = "") -> None:
        self.done += 1
        if not self.enabled:
            return
        if self.bar is not None:
            self.bar.set_postfix_str(what[:50], refresh=False)
            self.bar.update()
            return
        now = time.monotonic()
        step = max(1, self.total // 10)
        if self.done % step == 0 or now - self.last > 60 or self.done == self.total:
            self.last = now
            rate = (now - self.start) / self.done
            left = rate * (self.total - self.done)
            print(f"physval: {self.label}: {self.done}/{self.total} jobs, {now - self.start:.0f} s, "
                  f"about {left:.0f} s left", file=sys.stderr, flush=True)

    def close(self) -> None:
        if self.bar is not None:
            self.bar.close()


def run_jobs(jobs: list[Job], ctx: Context = Context(), workers: int = 1, scheduler: str | None = None,
             job_timeout: float | None = DEFAULT_JOB_TIMEOUT, start_method: str | None = None,
             store: RowStore | None = None, cache_key=None, progress: bool = True, label: str = "run",
             on_outcome=None) -> Results:
    """Run the jobs the store does not hold yet. `cache_key(job) -> str` stamps stored
    rows (required with a store). `on_outcome(outcome)` sees each job as it finishes.
    Never raises on an interrupt: Results.interrupted says it stopped early."""
    res = Results()
    todo = []
    for j in jobs:
        if store is not None and j.key in store.rows:
            res.rows[j.key] = store.rows[j.key]
            res.reused += 1
        else:
            todo.append(j)
    if not todo:
        return res
    bar = Progress(len(todo), label, progress)
    try:
        with sigterm_as_ctrl_c(), make_executor(ctx, workers, scheduler, job_timeout, start_method) as ex:
            for outcome in ex.run(todo):
                rows = [{**r, **outcome.extra} for r in outcome.rows]
                # in memory first: an interrupt during the disk write must not leave a row
                # on disk that the run does not count as finished (its finalize would drop it)
                res.rows[outcome.job.key] = rows
                res.ran += 1
                if store is not None:
                    store.append(outcome.job.key, rows, cache_key(outcome.job))
                if on_outcome is not None:
                    on_outcome(outcome)
                bar.update(outcome.job.test_id)
    except Terminated:
        res.interrupted = "SIGTERM"
    except KeyboardInterrupt:
        res.interrupted = "SIGINT"
    finally:
        bar.close()
    return res


@dataclass(frozen=True)
class Execution:
    """How to run jobs: the options every command shares (physval.commands.options.add_execution)."""
    workers: int = 1
    scheduler: str | None = None
    job_timeout: float | None = DEFAULT_JOB_TIMEOUT
    start_method: str | None = None
    progress: bool = True

    @classmethod
    def of(cls, args) -> "Execution":
        return cls(getattr(args, "workers", 1), getattr(args, "scheduler", None),
                   getattr(args, "job_timeout", DEFAULT_JOB_TIMEOUT), getattr(args, "start_method", None),
                   not getattr(args, "quiet", False))


def run_stored(jobs: list[Job], ctx: Context, path, columns: list[str], execution: Execution = Execution(),
               label: str = "run", on_outcome=None) -> tuple[Results, RowStore]:
    """run_jobs with a RowStore at `path`: finished jobs of an earlier run with the same
    code and engine versions are reused, new ones appended as they finish."""
    engines = list(dict.fromkeys(j.engine for j in jobs))
    keys = cache_keys(ctx, engines)
    store = RowStore(path, columns)
    store.load(keys.of_row)
    res = run_jobs(jobs, ctx, execution.workers, execution.scheduler, execution.job_timeout, execution.start_method,
                   store=store, cache_key=keys.of_job, progress=execution.progress, label=label,
                   on_outcome=on_outcome)
    return res, store


def map_calls(fn, args, ctx: Context = Context(), execution: Execution = Execution(),
              label: str = "calls") -> list[CallResult]:
    """fn(arg) for every arg, each a task of the executor (local workers, crash- and
    time-out-isolated, or Dask), in the order of `args`. A call that raised or whose worker
    died has no value and says why in `error`. Raises KeyboardInterrupt if interrupted."""
    calls = [Call(fn, a, i) for i, a in enumerate(args)]
    results: list[CallResult | None] = [None] * len(calls)
    bar = Progress(len(calls), label, execution.progress)
    try:
        with sigterm_as_ctrl_c(), make_executor(ctx, execution.workers, execution.scheduler,
                                                   execution.job_timeout, execution.start_method) as ex:
            for result in ex.run(calls):
                results[result.call.tag] = result
                bar.update()
    finally:
        bar.close()
    return results
