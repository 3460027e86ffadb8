"""Running a selection of jobs: through an executor, streaming each finished job to a row
store, skipping jobs the store already holds, with progress, and stopping promptly on
Ctrl-C or SIGTERM with everything finished kept.
"""
from __future__ import annotations

import collections
import contextlib
import sys
import time
from dataclasses import dataclass, field
from typing import Callable

from physval.core.ahead import Ahead
from physval.core.context import Context
from physval.core.executor import DEFAULT_JOB_TIMEOUT, make_executor
from physval.core.jobs import Call, CallResult, Job, rejudge
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
    """A bar on a terminal; elsewhere a line every 10 % (or 60 s) with the time left. The
    total may grow as jobs are planned (a reading's next wave)."""

    def __init__(self, total: int, label: str, enabled: bool = True):
        self.total, self.label, self.done = 0, label, 0
        self.done_before = 0  # done before the pace's clock started (restart)
        self.start = self.last = time.monotonic()
        self.tty = enabled and sys.stderr.isatty()
        self.enabled = enabled
        self.bar = None
        self.grow(total)

    def grow(self, n: int) -> None:
        """n more jobs to run."""
        self.total += n
        if not (self.tty and self.enabled and self.total):
            return
        if self.bar is None:
            from tqdm import tqdm
            self.bar = tqdm(total=self.total, unit="job", desc=self.label, dynamic_ncols=True)
        elif n:
            self.bar.total = self.total
            self.bar.refresh()

    def restart(self) -> None:
        """Its pace from now: the time before went mostly to something else (compiling)."""
        self.start = self.last = time.monotonic()
        self.done_before = self.done
        if self.bar is not None:
            self.bar.reset(total=self.total)
            self.bar.update(self.done)

    def update(self, what: str = "") -> None:
        self.done += 1
        if not self.enabled or not self.total:
            return
        if self.bar is not None:
            self.bar.set_postfix_str(what[:50], refresh=False)
            self.bar.update()
            return
        now = time.monotonic()
        step = max(1, self.total // 10)
        if self.done % step == 0 or now - self.last > 60 or self.done == self.total:
            self.last = now
            rate = (now - self.start) / max(1, self.done - self.done_before)
            left = rate * (self.total - self.done)
            print(f"physval: {self.label}: {self.done}/{self.total} jobs, {now - self.start:.0f} s, "
                  f"about {left:.0f} s left", file=sys.stderr, flush=True)

    def close(self) -> None:
        if self.bar is not None:
            self.bar.close()


@dataclass
class Stream:
    """The jobs of a command or of a reading, with the store their rows go to. `plan`: a
    list of jobs, or a generator that yields waves of jobs (lists), is sent the rows of
    each wave ({job key: rows}, the store's own rows for jobs it held) and returns the
    reading's value (a bisection: each wave's jobs depend on the last wave's rows).
    `first`: its jobs go ahead of the others' (a chain of waves whose latency would
    otherwise decide when the command ends). After `run_streams`: `results`, `value`,
    `spent`."""
    plan: object
    store: RowStore | None = None
    cache_key: Callable[[Job], str] | None = None  # job -> the key its stored rows are stamped with
    label: str = "run"
    first: bool = False
    on_outcome: Callable | None = None
    results: Results = field(default_factory=Results)
    value: object = None
    spent: "Spent" = field(default_factory=lambda: Spent())


@dataclass
class Spent:
    """Where the worker time of a stream's jobs went: `job_s` the jobs' whole time in their
    workers (building, stepping, recording, observing, judging), `run_s` of it their runs
    (stepping and recording each step), `stepping_s` of that the engines' steps alone
    (rows' wall_s), `compile_s` of the jobs' time numba's getting the reference's code ready
    (rows' compile_s), `cpu_s` the workers' CPU in them, `waited_s` their workers' idle time
    before each began."""
    jobs: int = 0
    job_s: float = 0.0
    compile_s: float = 0.0
    run_s: float = 0.0
    stepping_s: float = 0.0
    cpu_s: float = 0.0
    waited_s: float = 0.0

    def add(self, outcome) -> None:
        self.jobs += 1
        t = getattr(outcome, "timing", None)
        if t is not None:
            self.job_s += t.wall_s
            self.cpu_s += t.cpu_s
            self.waited_s += t.waited_s
        self.run_s += getattr(outcome, "run_s", 0.0)
        first = (getattr(outcome, "rows", None) or [{}])[0]
        self.stepping_s += _seconds(first.get("wall_s"))
        self.compile_s += _seconds(first.get("compile_s"))


def _seconds(value) -> float:
    """A row's time field as a number (0 where it holds none)."""
    try:
        return float(value or 0.0)
    except (TypeError, ValueError):
        return 0.0


@dataclass
class PoolUse:
    """The executor's whole run: `wall_s` from its start to its last result, on `workers`
    workers (`started`: worker processes started, replacements included; `worker_cpu_s`:
    their CPU, user + system, as they reported it; local workers only), of which what they
    compiled ahead of the jobs beside them (physval.core.ahead): `ahead_s` of worker time,
    `ahead_cpu_s` of CPU."""
    wall_s: float = 0.0
    workers: int = 0
    started: int = 0
    worker_cpu_s: float = 0.0
    ahead_s: float = 0.0
    ahead_cpu_s: float = 0.0


def _waves(plan):
    if isinstance(plan, (list, tuple)):
        yield list(plan)
        return None
    return (yield from plan)


def run_streams(streams: list[Stream], ctx: Context = Context(), execution: "Execution" = None,
                executor=None) -> PoolUse:
    """Run every stream's jobs that its store does not hold yet on one executor (one set
    of workers, kept busy by all of them: a reading's waves run beside the jobs of the
    command, not after them), streaming each job's rows to its stream's store. A job two
    streams want runs once, whether the second asks before it ends or after. `executor`:
    an open one (make_executor) to run on and leave open, for a caller whose next jobs
    depend on these (a fit's next generation); else one made for this call. Never raises
    on an interrupt: each stream's Results.interrupted says it stopped early (and its value
    stays None)."""
    execution = execution or Execution()
    queue: collections.deque = collections.deque()
    waiting: dict[str, list[Stream]] = {}   # job key -> the streams that wait for its rows
    state: dict[int, dict] = {}             # id(stream) -> its generator, wave rows, pending keys
    finished: dict[str, tuple] = {}         # job key -> (outcome, rows) of a job run in this call
    bar = Progress(0, streams[0].label if streams else "run", execution.progress)
    use = PoolUse(workers=execution.workers)
    ahead: Ahead | None = None

    def advance(s: Stream, rows: dict | None) -> None:
        """Send `s` its finished wave and queue its next (waves its store holds whole are
        answered at once)."""
        st = state[id(s)]
        while True:
            try:
                wave = next(st["gen"]) if rows is None else st["gen"].send(rows)
            except StopIteration as stop:
                s.value, st["pending"] = stop.value, None
                return
            st["rows"], todo, seen = {}, [], set()
            for j in wave:
                if j.key in seen:
                    continue
                seen.add(j.key)
                if s.store is not None and j.key in s.store.verdicts_stale:  # a known deviation edited since
                    s.store.rejudge([j], judge_again(ctx), s.cache_key)
                if s.store is not None and j.key in s.store.rows:  # finished by an earlier run
                    st["rows"][j.key] = s.results.rows[j.key] = s.store.rows[j.key]
                    s.results.reused += 1
                elif j.key in s.results.rows:  # run for an earlier wave
                    st["rows"][j.key] = s.results.rows[j.key]
                elif j.key in finished:  # run for another stream before this one asked
                    deliver(s, *finished[j.key])
                else:
                    todo.append(j)
            st["pending"] = {j.key for j in todo}
            if not todo:
                rows = st["rows"]
                continue
            fresh = [j for j in todo if j.key not in waiting]  # (the others: queued for another stream)
            for j in todo:
                waiting.setdefault(j.key, []).append(s)
            bar.grow(len(fresh))
            if ahead is not None:  # an engine still compiling: its jobs wait for its parts
                fresh = ahead.hold(fresh)
            if s.first:
                queue.extendleft(reversed(fresh))
            else:
                queue.extend(fresh)
            return

    def deliver(s: Stream, outcome, rows: list) -> None:
        """A job's rows to stream `s`: in memory first (an interrupt during the disk write
        must not leave a row on disk that the run does not count as finished: its finalize
        would drop it), then its store and its on_outcome."""
        key = outcome.job.key
        state[id(s)]["rows"][key] = s.results.rows[key] = rows
        s.results.ran += 1
        s.spent.add(outcome)
        if s.store is not None:
            s.store.append(key, rows, s.cache_key(outcome.job))
        if s.on_outcome is not None:
            s.on_outcome(outcome)

    t0 = time.monotonic()
    try:
        for s in streams:
            state[id(s)] = {"gen": _waves(s.plan), "pending": set(), "rows": {}}
            advance(s, None)
        if queue:
            with sigterm_as_ctrl_c(), (contextlib.nullcontext(executor) if executor is not None else make_executor(
                    ctx, execution.workers, execution.scheduler, execution.job_timeout, execution.start_method)) as ex:
                ahead = Ahead.start(queue, ctx, beside=execution.workers > 1 or bool(execution.scheduler))
                for outcome in ex.run(queue):
                    if ahead is not None and ahead.owns(outcome):
                        ahead.arrived(outcome, queue)
                        if not ahead.compiling:
                            bar.restart()  # its time left from the jobs' pace, not the compiling's
                        continue
                    key = outcome.job.key
                    rows = [{**r, **outcome.extra} for r in outcome.rows]
                    finished[key] = (outcome, rows)
                    for s in waiting.pop(key, []):
                        st = state[id(s)]
                        deliver(s, outcome, rows)
                        st["pending"].discard(key)
                        if not st["pending"]:
                            advance(s, st["rows"])
                    bar.update(outcome.job.test_id)
                use.started = getattr(ex, "started", 0)
                # (what they compiled ahead is not the jobs' overhead: Cost has it on its own line)
                use.worker_cpu_s = getattr(ex, "worker_cpu_s", 0.0) - (ahead.cpu_s if ahead is not None else 0.0)
    except KeyboardInterrupt as exc:
        why = "SIGTERM" if isinstance(exc, Terminated) else "SIGINT"
        for s in streams:
            st = state.get(id(s))
            if st is None or st["pending"] is not None:  # not finished
                s.results.interrupted, s.value = why, None
                if st is not None:
                    st["gen"].close()
    finally:
        use.wall_s = time.monotonic() - t0
        if ahead is not None:
            use.ahead_s, use.ahead_cpu_s = ahead.worker_s, ahead.cpu_s
        bar.close()
    return use


def judge_again(ctx: Context):
    """(job, stored rows) -> the rows judged against the known deviations of now, or None
    (RowStore.rejudge's judge_again)."""
    resolver = ctx.resolver()
    return lambda job, rows: rejudge(job, rows, resolver)


def run_jobs(jobs: list[Job], ctx: Context = Context(), workers: int = 1, scheduler: str | None = None,
             job_timeout: float | None = DEFAULT_JOB_TIMEOUT, start_method: str | None = None,
             store: RowStore | None = None, cache_key=None, progress: bool = True, label: str = "run",
             on_outcome=None) -> Results:
    """Run the jobs the store does not hold yet. `cache_key(job) -> str` stamps stored
    rows (required with a store). `on_outcome(outcome)` sees each job as it finishes.
    Never raises on an interrupt: Results.interrupted says it stopped early."""
    stream = Stream(jobs, store, cache_key, label, on_outcome=on_outcome)
    run_streams([stream], ctx, Execution(workers, scheduler, job_timeout, start_method, progress))
    return stream.results


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
    stream = stored(jobs, ctx, path, columns, label, on_outcome=on_outcome)
    run_streams([stream], ctx, execution)
    return stream.results, stream.store


def stored(plan, ctx: Context, path, columns: list[str], label: str = "run", first: bool = False,
           on_outcome=None) -> Stream:
    """A Stream into a RowStore at `path` (loaded: finished jobs of an earlier run with the
    same code and engine versions are reused, new ones appended as they finish)."""
    engines = list(dict.fromkeys(j.engine for j in plan)) if isinstance(plan, (list, tuple)) else None
    keys = cache_keys(ctx, engines)  # (a plan in waves: each engine's key found as its first job comes)
    store = RowStore(path, columns)
    store.load(keys.of_row)
    return Stream(plan, store, keys.of_job, label, first, on_outcome)


def run_plan(plan, ctx: Context, path, columns: list[str], execution: Execution = Execution(), label: str = "run"):
    """The value a reading's plan (a generator of waves, see Stream) returns, its jobs run
    through a RowStore at `path` on one executor; None if interrupted."""
    stream = stored(plan, ctx, path, columns, label)
    run_streams([stream], ctx, execution)
    return stream.value


def executor_of(ctx: Context, execution: Execution):
    """The executor `execution` asks for (a context manager that stops its workers at its
    end), for several map_calls in a row on the same workers (executor=)."""
    return make_executor(ctx, execution.workers, execution.scheduler, execution.job_timeout, execution.start_method)


def map_calls(fn, args, ctx: Context = Context(), execution: Execution = Execution(),
              label: str = "calls", executor=None) -> list[CallResult]:
    """fn(arg) for every arg, each a task of the executor (local workers, crash- and
    time-out-isolated, or Dask), in the order of `args`. A call that raised or whose worker
    died has no value and says why in `error`. Raises KeyboardInterrupt if interrupted.
    `executor`: one of executor_of whose workers (and what they loaded) serve these calls,
    instead of workers started for them and stopped after."""
    calls = [Call(fn, a, i) for i, a in enumerate(args)]
    results: list[CallResult | None] = [None] * len(calls)
    bar = Progress(len(calls), label, execution.progress)
    try:
        with sigterm_as_ctrl_c(), (contextlib.nullcontext(executor) if executor is not None
                                   else executor_of(ctx, execution)) as ex:
            for result in ex.run(calls):
                results[result.call.tag] = result
                bar.update()
    finally:
        bar.close()
    return results
