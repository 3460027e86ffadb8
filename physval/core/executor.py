"""Where jobs run: worker processes on this machine (the default), or an existing Dask
distributed cluster (`--scheduler ADDRESS`). Both yield each job's Outcome as it finishes.

Local workers isolate crashes: every job runs in a worker process, with one worker as with
many. A job whose worker dies (a segfault, an abort) or that exceeds the per-job time
limit becomes `error` rows naming the signal or the limit; the worker is replaced and
every other job runs (a worker answers its jobs in order, so the job it dies in is the
first unanswered one; the jobs sent to it ahead had not begun and go back to the queue).
Workers ignore Ctrl-C (the main process stops them at once and keeps what finished) and
exit on their own when the main process dies. Workers live as long as their executor:
one executor runs every job of a command, its readings' included.

On Dask, jobs travel in batches of at least about 100 ms of stepping. A batch whose
worker dies is split and its jobs resubmitted one by one, so a crashing job costs only
its own rows. The per-job time limit is not enforced on a cluster: a job that hangs holds
its Dask worker (recycle workers with `dask worker --lifetime`).
"""
from __future__ import annotations

import collections
import contextlib
import multiprocessing as mp
import multiprocessing.connection
from multiprocessing.reduction import ForkingPickler
import os
import signal
import sys
import threading
import time

from physval.core.context import Context
from physval.core.jobs import Job, lost, perform, steps_of

DEFAULT_JOB_TIMEOUT = 900.0  # s: the longest default job takes about a minute; on-demand ones minutes
MIN_BATCH_STEPS = 20_000     # Dask: ~100 ms of stepping at >= 5 us a step, so scheduling stays small
START_METHODS = ("fork", "spawn", "forkserver")


class ExecutorError(RuntimeError):
    """The executor cannot start (e.g. an unreachable Dask scheduler): bad input."""


def default_start_method() -> str:
    """Linux: forkserver (Python's default from 3.14; workers start from a clean process);
    elsewhere the platform's default (spawn)."""
    return "forkserver" if sys.platform.startswith("linux") else mp.get_start_method()


# set for the fork server when it is to load the reference's compiled step (physval.core.preload)
PRELOAD_REFERENCE = "PHYSVAL_PRELOAD_REFERENCE"


def start_fork_server(start_method: str | None = None, reference: bool = False) -> None:
    """Under forkserver, start the fork server now: it loads the harness and the families
    (physval.core.preload) while the caller goes on, and every worker forks from it ready;
    with `reference` (a run that steps the reference, or tries a user's code on it), the
    reference's compiled step too, where it is compiled already (1.4 CPU-s a worker
    otherwise). It imports from this process's path (fork_server_env), not from the folder
    physval was started in. A server already running stays as it started."""
    if (start_method or default_start_method()) == "forkserver":
        from multiprocessing import forkserver
        mp.get_context("forkserver").set_forkserver_preload(["physval.core.preload"])
        saved = dict(os.environ)
        os.environ.update(fork_server_env())
        if reference:
            os.environ[PRELOAD_REFERENCE] = "1"
        try:
            forkserver.ensure_running()  # spawns the server with os.environ as it is now
        finally:
            os.environ.clear()
            os.environ.update(saved)


def fork_server_env() -> dict[str, str]:
    """The fork server is a `python -c` process, whose path begins with the current
    directory (Python 3.11 does not hand it the caller's path, 3.12 only after the
    preload's imports): a user's `cases/` (or `physval/`) folder there would be imported
    instead of physval's, and every worker forked from it would fail. So it starts without
    the current directory (PYTHONSAFEPATH) and with this process's path, as the workers
    themselves get it (an entry '' stands for the current directory: left out)."""
    path = [os.path.abspath(p) for p in sys.path if p]
    return {"PYTHONSAFEPATH": "1", "PYTHONPATH": os.pathsep.join(dict.fromkeys(path))}


# --- the worker process --------------------------------------------------------------------

def _die_with_parent(lifeline) -> None:
    """Exit when the main process dies. `lifeline` is the read end of a pipe whose write
    end only the main process holds: it reads as closed the moment that process dies, by
    any signal, under every start method and platform (a thread waits on it). Under
    forkserver a worker's parent is the fork server, and the fork server exits only once
    every worker has (each holds its 'alive' pipe): watching the parent alone, a busy
    worker and the fork server waited on each other, and the resource tracker on both, for
    as long as the job ran. On Linux the kernel's parent-death signal also ends a worker
    the moment its parent dies."""
    if sys.platform.startswith("linux"):
        try:
            import ctypes
            libc = ctypes.CDLL("libc.so.6", use_errno=True)
            libc.prctl(1, signal.SIGKILL)  # PR_SET_PDEATHSIG
        except (OSError, AttributeError):
            pass

    def watch():
        try:
            lifeline.poll(None)  # nothing is ever sent: readable means the write end is gone
        finally:
            os._exit(1)

    threading.Thread(target=watch, name="exit with the main process", daemon=True).start()


def _worker(conn, ctx: Context, lifeline) -> None:
    _die_with_parent(lifeline)
    signal.signal(signal.SIGINT, signal.SIG_IGN)   # the main process handles interrupts
    signal.signal(signal.SIGTERM, signal.SIG_DFL)
    resolver = ctx.resolver()
    resolver.families  # loaded before the first job's clock starts
    conn.send("ready")
    while True:
        idle = time.perf_counter()
        try:
            task = conn.recv()
        except (EOFError, OSError):
            return
        if task is None:
            return
        conn.send(perform(task, resolver, waited_s=time.perf_counter() - idle))


def _signal_name(exitcode: int | None) -> str:
    if exitcode is None:
        return "it stopped answering"
    if exitcode < 0:
        try:
            return f"killed by signal {signal.Signals(-exitcode).name} ({-exitcode})"
        except ValueError:
            return f"killed by signal {-exitcode}"
    return f"it exited with code {exitcode}"


class _Slot:
    """One worker process and the tasks it holds: the one it runs, then those sent ahead
    (a worker answers in order, so the first unanswered task is the one running)."""

    def __init__(self, mpctx, ctx: Context):
        self.conn, child = mpctx.Pipe()
        lifeline, self.lifeline = mpctx.Pipe(duplex=False)  # its read end and write end: _die_with_parent
        self.process = mpctx.Process(target=_worker, args=(child, ctx, lifeline), daemon=True)
        self.process.start()
        child.close()
        lifeline.close()
        self.tasks: collections.deque = collections.deque()  # sent, not answered, in order
        self.started = 0.0  # when the running task (the first of `tasks`) began
        self.ready = False  # the worker has loaded the families and waits for tasks
        self.cpu_s = 0.0    # the process's CPU (user + system) as of its last answer

    @property
    def job(self):
        """The task it runs now (None: idle)."""
        return self.tasks[0] if self.tasks else None

    def give(self, task, message: bytes) -> None:
        """Hand a task over, `message` its pickle (a worker that died meanwhile is found by
        its sentinel)."""
        if not self.tasks:
            self.started = time.monotonic()
        self.tasks.append(task)
        try:
            self.conn.send_bytes(message)
        except (BrokenPipeError, OSError):
            pass

    def answered(self, result) -> None:
        """The running task's result arrived: the next one sent ahead runs from now."""
        self.tasks.popleft()
        self.started = time.monotonic()
        timing = getattr(result, "timing", None)
        if timing is not None:
            self.cpu_s = timing.process_cpu_s

    def kill(self) -> None:
        if self.process.is_alive():
            self.process.kill()
        self.process.join(timeout=2)
        self.conn.close()
        self.lifeline.close()


# A worker holds at most this many tasks beyond the one it runs, so that it starts the next
# the moment it answers one instead of waiting for the main process to read the answer,
# store its rows and send another (a round trip of 0.1-20 ms, the store's disk write
# included). Only while the queue holds more than SEND_AHEAD_QUEUE tasks per worker: near
# the end, a long task sent ahead to a busy worker would wait while another worker idles.
SEND_AHEAD = 1
SEND_AHEAD_QUEUE = 4
# ... and only a task whose message fits the pipe's buffer whole: a worker that is busy
# does not read, and one that ends its job sends its result before it reads again, so a
# larger task sent ahead could block the main process in send while the worker blocks
# sending a large result, each waiting for the other to read (Linux's socket buffers hold
# about 200 KiB; a larger task waits for an idle worker, which reads at once).
SEND_AHEAD_BYTES = 64 * 1024


class LocalExecutor:
    """Tasks on `workers` local processes, each task in a worker, crashes and time-outs
    isolated. Use as a context manager: its workers live until it closes, across every
    `run(tasks)` (which yields results as tasks finish), so imports, families and an
    engine's first-run costs (numba loading or compiling the reference's formulations)
    are paid once per worker, not per task or per call.

    Scheduling never changes what a task computes; it chooses where and when it runs:
    - each worker holds up to SEND_AHEAD tasks beyond the one it runs (see there);
    - an engine's first task in this executor runs before any other of that engine's
      where other work is waiting, so a first-run cost (a compilation that fills a cache)
      is paid by one worker, and the other workers find the cache filled."""

    def __init__(self, ctx: Context = Context(), workers: int = 1, job_timeout: float | None = DEFAULT_JOB_TIMEOUT,
                 start_method: str | None = None):
        self.ctx = ctx
        self.workers = max(1, workers)
        self.job_timeout = job_timeout or None
        self.mpctx = mp.get_context(start_method or default_start_method())
        start_fork_server(self.mpctx.get_start_method())
        self._slots: list[_Slot] = []
        self._begun: set[str] = set()     # engines whose first job has been handed out
        self._finished: set[str] = set()  # engines with a job finished (their first-run costs paid)
        self.started = 0                  # worker processes started (replacements included)
        self._retired_cpu_s = 0.0         # CPU of the workers stopped so far (as last reported)

    def __enter__(self):
        return self

    def __exit__(self, *exc):
        self.close()

    @contextlib.contextmanager
    def time_limit(self, seconds: float | None):
        """Within it, the per-task time limit is `seconds` (None: none); the workers stay."""
        before, self.job_timeout = self.job_timeout, seconds or None
        try:
            yield self
        finally:
            self.job_timeout = before

    def close(self) -> None:
        """Stop every worker at once (what has finished is already with the caller): all
        are sent SIGKILL before any is waited for, so the waits overlap."""
        for s in self._slots:
            if s.process.is_alive():
                s.process.kill()
        for s in self._slots:
            s.kill()
            self._retired_cpu_s += s.cpu_s
        self._slots = []

    @property
    def worker_cpu_s(self) -> float:
        """The workers' CPU (user + system) so far, as each last reported it (a worker's
        start-up included, the job it died in or was stopped in not)."""
        return self._retired_cpu_s + sum(s.cpu_s for s in self._slots)

    def run(self, tasks) -> "collections.abc.Iterator":
        """Yield each task's result (an Outcome for a Job, a CallResult for a Call) as it
        finishes. `tasks`: any iterable; a collections.deque is read live, so tasks the
        caller adds to it while the run goes (between two results) run too, those added on
        the left first."""
        resolver = self.ctx.resolver()
        queue = tasks if isinstance(tasks, collections.deque) else collections.deque(tasks)
        failed_starts = 0
        complete = False
        try:
            while queue or any(s.tasks for s in self._slots):
                while queue and len(self._slots) < self.workers:
                    self._slots.append(_Slot(self.mpctx, self.ctx))
                    self.started += 1
                for s in self._slots:
                    self._fill(s, queue)
                watched = [s for s in self._slots if s.tasks or not s.ready]
                waits = {s.conn: s for s in watched} | {s.process.sentinel: s for s in watched}
                ready = mp.connection.wait(list(waits), timeout=self._next_deadline(watched))
                done = set()
                results = []
                for r in ready:
                    s = waits[r]
                    if s in done:
                        continue
                    if not s.ready:  # a starting worker: its greeting, or its death
                        if self._greeted(s):
                            failed_starts = 0
                        elif not s.process.is_alive():
                            done.add(s)
                            self._replace(s, queue)
                            failed_starts += 1
                            if failed_starts > 3 * self.workers:
                                why = _signal_name(s.process.exitcode)
                                while queue:
                                    yield lost(queue.popleft(), resolver,
                                               f"worker processes die as they start ({why})")
                        continue
                    got = self._collect(s, resolver, queue)
                    if got:
                        done.add(s)
                        results += got
                for s in watched:
                    if s in done or not s.tasks or self.job_timeout is None:
                        continue
                    if time.monotonic() - s.started > self.job_timeout:
                        task = s.job
                        self._replace(s, queue)
                        results.append(lost(task, resolver, f"the job ran longer than the per-job time limit of "
                                                            f"{self.job_timeout:g} s (--job-timeout) and was stopped"))
                # the workers that answered get their next tasks before the caller reads (and
                # stores) the results: they work while it does
                for s in done:
                    if s in self._slots:
                        self._fill(s, queue)
                yield from results
            complete = True
        finally:
            if not complete:  # stopped early (an interrupt, or the caller left): no task may outlive its run
                self.close()

    def _fill(self, s: _Slot, queue: collections.deque) -> None:
        """Hand `s` tasks until it holds what it may (see SEND_AHEAD)."""
        if not s.ready:
            return
        while queue:
            limit = 1 + (SEND_AHEAD if len(queue) > SEND_AHEAD_QUEUE * self.workers else 0)
            if len(s.tasks) >= limit:
                return
            i = self._next(queue)
            message = ForkingPickler.dumps(queue[i])
            if s.tasks and len(message) > SEND_AHEAD_BYTES:
                return  # too large to send ahead (see SEND_AHEAD_BYTES): it waits for an idle worker
            task = queue[i]
            del queue[i]
            engine = getattr(task, "engine", None)
            if engine is not None:
                self._begun.add(engine)
            s.give(task, message)

    def _next(self, queue: collections.deque) -> int:
        """Where the next task is: the first, but not a second job of an engine whose first
        is still running if any other task can go instead (its first-run costs are being paid)."""
        for i, task in enumerate(queue):
            engine = getattr(task, "engine", None)
            if engine is None or engine in self._finished or engine not in self._begun:
                return i
        return 0  # nothing else to do: no worker waits for the first job

    @staticmethod
    def _greeted(s: _Slot) -> bool:
        try:
            if s.conn.poll() and s.conn.recv() == "ready":
                s.ready = True
        except (EOFError, OSError):
            pass
        return s.ready

    def _next_deadline(self, watched) -> float | None:
        busy = [s for s in watched if s.tasks]
        if self.job_timeout is None or not busy:
            return None
        left = min(s.started + self.job_timeout - time.monotonic() for s in busy)
        return max(0.0, min(left, 1.0))

    def _collect(self, s: _Slot, resolver, queue: collections.deque) -> list:
        """The results the worker has sent; or, if it died, the running task's rows saying
        so (the tasks sent ahead go back to the front of the queue: they never began)."""
        got = []
        try:
            while s.tasks and s.conn.poll():
                result = s.conn.recv()
                s.answered(result)
                engine = getattr(getattr(result, "job", None), "engine", None)
                if engine is not None:
                    self._finished.add(engine)
                got.append(result)
        except (EOFError, OSError):
            pass
        if got or s.process.is_alive():
            return got  # (woken by the pipe without a whole message: wait again)
        s.process.join(timeout=1)
        task, why = s.job, _signal_name(s.process.exitcode)
        self._replace(s, queue)
        return [lost(task, resolver, f"the worker process running this job died: {why}")]

    def _replace(self, s: _Slot, queue: collections.deque) -> None:
        """Stop the worker; the tasks it held but had not begun go back to the front of the queue."""
        s.kill()
        self._slots.remove(s)
        self._retired_cpu_s += s.cpu_s
        if s.tasks:
            engine = getattr(s.tasks.popleft(), "engine", None)
            if engine not in self._finished:
                self._begun.discard(engine)  # its next job pays the first-run costs again
            queue.extendleft(reversed(s.tasks))
            s.tasks.clear()


# --- Dask ----------------------------------------------------------------------------------

def _run_batch(tasks: list, ctx: Context) -> list:
    resolver = ctx.resolver()
    return [perform(t, resolver) for t in tasks]


def check_address(address: str) -> None:
    """A scheduler address as Dask reads it, checked before any Client exists: a Client
    built on a malformed address raises, and at exit its __del__ prints a traceback
    after a 6 s wait for a connection that never was."""
    from distributed.comm import get_address_host_port, parse_address
    from distributed.comm.registry import get_backend
    try:
        scheme, _ = parse_address(address)
        get_backend(scheme)  # a scheme Dask knows
        if scheme in ("tcp", "tls", "ws", "wss"):  # inproc:// (one process) and ucx:// have no host:port
            get_address_host_port(address)
    except ValueError as exc:
        raise ExecutorError(f"--scheduler {address!r}: not a Dask scheduler address; give "
                            f"tcp://HOST:PORT or tls://HOST:PORT ({exc})") from None


class DaskExecutor:
    """Jobs in batches on an existing Dask distributed cluster."""

    def __init__(self, address: str, ctx: Context = Context(), connect_timeout: float = 3.0):
        try:
            from distributed import Client
        except ImportError:
            raise ExecutorError("--scheduler needs dask's distributed package: pip install 'dask[distributed]'") from None
        self.ctx = ctx
        self.client = None
        check_address(address)
        try:
            self.client = Client(address, timeout=connect_timeout, set_as_default=False)
        except (OSError, TimeoutError, ValueError, TypeError) as exc:
            raise ExecutorError(f"--scheduler {address}: cannot reach a Dask scheduler there within "
                                f"{connect_timeout:g} s ({type(exc).__name__}: {exc})") from None

    def __enter__(self):
        return self

    def __exit__(self, *exc):
        self.close()

    def close(self) -> None:
        if getattr(self, "client", None) is not None:
            self.client.close()
            self.client = None

    def batches(self, jobs: list[Job]) -> list[list[Job]]:
        """Consecutive jobs grouped until each batch holds at least MIN_BATCH_STEPS steps."""
        resolver = self.ctx.resolver()
        out, current, steps = [], [], 0
        for j in jobs:
            current.append(j)
            if not isinstance(j, Job):  # a Call is a batch of its own
                out.append(current)
                current, steps = [], 0
                continue
            steps += steps_of(j, resolver.family(j.family)) * (1 + dict(j.probe_args).get("repeats", 0))
            if steps >= MIN_BATCH_STEPS:
                out.append(current)
                current, steps = [], 0
        if current:
            out.append(current)
        return out

    def run(self, jobs):
        """As LocalExecutor.run: a collections.deque is read live (jobs the caller adds
        between two outcomes are batched and submitted in turn)."""
        from distributed import as_completed
        resolver = self.ctx.resolver()
        queue = jobs if isinstance(jobs, collections.deque) else collections.deque(jobs)
        pending = {}
        seq = as_completed([], loop=self.client.loop)

        def submit(batch: list) -> None:
            fut = self.client.submit(_run_batch, batch, self.ctx, pure=False, retries=0)
            pending[fut] = batch
            seq.add(fut)

        try:
            while queue or pending:
                for batch in self.batches(list(queue)):
                    submit(batch)
                queue.clear()
                for fut in seq:
                    batch = pending.pop(fut)
                    try:
                        outcomes = fut.result()
                    except Exception as exc:  # a worker that died under the batch (KilledWorker) or lost it
                        if len(batch) > 1:  # split: each job alone, so only the guilty one is lost
                            for j in batch:
                                submit([j])
                            continue
                        outcomes = [lost(batch[0], resolver,
                                         f"the Dask worker running this job failed: {type(exc).__name__}: {exc}")]
                    yield from outcomes
                    if queue:  # added by the caller meanwhile
                        for batch in self.batches(list(queue)):
                            submit(batch)
                        queue.clear()
        finally:
            for fut in pending:
                fut.cancel()


def make_executor(ctx: Context, workers: int = 1, scheduler: str | None = None,
                  job_timeout: float | None = DEFAULT_JOB_TIMEOUT, start_method: str | None = None):
    """A Dask executor for `scheduler`, else local worker processes."""
    if scheduler:
        return DaskExecutor(scheduler, ctx)
    return LocalExecutor(ctx, workers, job_timeout, start_method)
