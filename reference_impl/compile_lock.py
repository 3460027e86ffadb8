"""One compile per machine and cache: a process that is about to compile a function of this
package first waits for any other process compiling into the same on-disk cache, then
finds there what that process saved and loads it instead of compiling it again.

numba alone has no such lock: processes that start together on an empty cache (the
workers of a run, the workers of a test session) each compile the same functions, each
paying the whole compile (minutes of CPU for every formulation), and the last to finish
writes the cache. With the lock the first compiles and the others wait, then load.

One lock file per cache folder (the folder numba's locator picked, compiled.py), held
by a process's outermost compile only: compiling a function compiles the functions it
calls within it, so one lock for the whole package cannot deadlock. It is taken inside
numba's own compiler lock (one compile at a time per process), so threads of one process
never contend for it. The operating system drops it when its holder exits or dies.
Without fcntl (Windows), or where the folder cannot be written, nothing is locked and
each process compiles for itself, as numba does.
"""
from __future__ import annotations

import os
from contextlib import contextmanager

try:
    import fcntl
except ImportError:  # pragma: no cover - not POSIX
    fcntl = None

LOCK_NAME = "numba-compile.lock"
_depth = 0  # compiles entered in this process (changed only under numba's compiler lock)


@contextmanager
def one_compile_at_a_time(cache_path: str | None):
    """While inside: the only process compiling into the cache folder `cache_path` (None: no
    on-disk cache, no lock). Re-entered by the compiles a compile starts: only the outermost
    locks. Enter it holding numba's compiler lock."""
    global _depth
    lock = None
    if _depth == 0 and fcntl is not None and cache_path:
        try:
            os.makedirs(cache_path, exist_ok=True)
            lock = open(os.path.join(cache_path, LOCK_NAME), "a")
        except OSError:
            lock = None
        else:
            fcntl.flock(lock, fcntl.LOCK_EX)
    _depth += 1
    try:
        yield
    finally:
        _depth -= 1
        if lock is not None:
            lock.close()  # releases the lock
