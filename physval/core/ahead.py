"""Compiling ahead, inside the job queue: what the engines of a run compile on first use and
the cache lacks (Adapter.uncompiled: the reference's step on a fresh install, minutes of
numba) goes to the head of the queue, one part a task, so the workers compile the parts
side by side while every other engine's jobs run beside them; the jobs of an engine that
compiles are held back until its parts are in. Otherwise each engine's first job compiled
its parts one after the other while every other worker at a job of that engine waited for
the cache; and compiling every part before any job left a worker idle whenever fewer parts
than workers were left.
"""
from __future__ import annotations

import collections

from adapters.base import Adapter
from physval.core.context import Context
from physval.core.jobs import Call, CallResult


class Ahead:
    """One run's compiling ahead (`start`): the question of what is uncompiled, asked in a
    worker (its answer loads the engine's code, which that worker's jobs need anyway), then
    a Call per part. `hold` keeps back the tasks of an engine whose parts are not in yet;
    `arrived` takes a Call's result and gives back the tasks it releases. A part that fails
    is left to the jobs, which report it. `results`: the Calls' results (their timing)."""

    def __init__(self, ctx: Context, engines: list[str]):
        self.ctx = ctx
        self.waits: dict[str, set | None] = {e: None for e in engines}  # None: not asked yet
        self.held: dict[str, list] = collections.defaultdict(list)
        self.results: list[CallResult] = []

    @classmethod
    def start(cls, queue: collections.deque, ctx: Context, beside: bool) -> "Ahead | None":
        """The compiling ahead of the tasks in `queue`, its question put at the queue's head
        and their tasks held; None where nothing goes ahead: no engine compiles, or nothing
        can run `beside` a part (one local worker: the jobs compile what they need)."""
        if not beside:
            return None
        resolver = ctx.resolver()
        engines = [e for e in dict.fromkeys(getattr(t, "engine", None) for t in queue)
                   if e is not None and _compiles(resolver, e)]
        if not engines:
            return None
        ahead = cls(ctx, engines)
        kept = ahead.hold(list(queue))
        queue.clear()
        queue.extend(kept)
        queue.appendleft(Call(_uncompiled, (ctx, engines)))
        return ahead

    @property
    def compiling(self) -> bool:
        return bool(self.waits)

    def hold(self, tasks: list) -> list:
        """The `tasks` that may run now; the others (of an engine still compiling) are held."""
        free = []
        for t in tasks:
            engine = getattr(t, "engine", None)
            (self.held[engine] if engine in self.waits else free).append(t)
        return free

    def arrived(self, result: CallResult, queue: collections.deque) -> None:
        """A Call of this compiling ahead finished: after the question, its parts go to the
        head of `queue`; after a part, the tasks of the engines that waited only for it go
        there (ahead of the rest, as they were before they were held)."""
        self.results.append(result)
        if result.call.fn is _uncompiled:
            answer = result.value or []  # (none: the question failed; the jobs will say why)
            for engine in self.waits:
                self.waits[engine] = {part for e, part in answer if e == engine}
            first = {}  # part -> the first engine that named it: compiled once, for all of them
            for engine, part in answer:
                first.setdefault(part, engine)
            queue.extendleft(reversed([Call(compile_part, (self.ctx, engine, part)) for part, engine in first.items()]))
        else:
            done = result.call.arg[2]
            for engine in self.waits:
                self.waits[engine].discard(done)
        for engine in [e for e, left in self.waits.items() if left is not None and not left]:
            del self.waits[engine]
            queue.extendleft(reversed(self.held.pop(engine, [])))

    def owns(self, result) -> bool:
        return isinstance(result, CallResult) and result.call.fn in (_uncompiled, compile_part)

    @property
    def worker_s(self) -> float:
        """The workers' time in this compiling ahead (the question included)."""
        return sum(r.timing.wall_s for r in self.results if r.timing)

    @property
    def cpu_s(self) -> float:
        return sum(r.timing.cpu_s for r in self.results if r.timing)


def _compiles(resolver, engine: str) -> bool:
    """Whether `engine`'s adapter says what it compiles on first use (Adapter.uncompiled)."""
    try:
        return type(resolver.adapter(engine)).uncompiled is not Adapter.uncompiled
    except Exception:  # noqa: BLE001 - the engine's jobs report what is wrong with it
        return False


def _uncompiled(item) -> list[tuple]:
    ctx, engines = item
    return uncompiled_parts(engines, ctx)


def uncompiled_parts(engines, ctx: Context) -> list[tuple]:
    """(engine, part) for each part each of the `engines` compiles on first use and has not
    compiled yet (Adapter.uncompiled); a part that several engines share is listed for each."""
    resolver = ctx.resolver()
    out = []
    for engine in dict.fromkeys(engines):
        try:
            out += [(engine, part) for part in resolver.adapter(engine).uncompiled()]
        except Exception:  # noqa: BLE001 - the engine's jobs report what is wrong with it
            continue
    return out


def compile_part(item) -> None:
    """Compile (ctx, engine, part), one of uncompiled_parts, in this process (a worker)."""
    ctx, engine, part = item
    ctx.resolver().adapter(engine).compile_part(part)
