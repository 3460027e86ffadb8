"""One compile per machine and cache: a process that is about to compile a function of this
package for some argument types first waits for any other process compiling the same
function for the same types into the same on-disk cache, then finds there what that
process saved and loads it instead of compiling it again.

numba alone has no such lock: processes that start together on an empty cache (the
workers of a run, the workers of a test session) each compile the same functions, each
paying the whole compile (minutes of CPU for every formulation), and the last to finish
writes the cache. With the lock the first compiles and the others wait, then load.

One lock per function and argument types (a file in the cache folder's `compiling/`), so
processes compiling different formulations go on side by side and meet only where they
compile the same function (the collision phase, the contact rows), one of them waiting
for it only. A compile holds its lock while it compiles the functions it calls; as the
package's functions do not call themselves, no two processes can each hold a lock the
other waits for. Taken inside numba's compiler lock (one compile at a time per process).
The operating system drops a lock when its holder exits or dies. Without fcntl (Windows),
or where the folder cannot be written, nothing is locked and each process compiles for
itself, as numba does.
"""
from __future__ import annotations

import hashlib
import os
from contextlib import contextmanager

try:
    import fcntl
except ImportError:  # pragma: no cover - not POSIX
    fcntl = None

FOLDER = "compiling"  # in the cache folder: one empty lock file per function and argument types
_held: set[str] = set()  # this process's (changed only under numba's compiler lock)


def key_of(function, argument_types) -> str:
    """What one compile produces: the function (module, name, first line) and its argument
    types, the same text in every process and every copy of the package."""
    code = function.__code__
    return f"{function.__module__}.{function.__qualname__}:{code.co_firstlineno}{tuple(argument_types)}"


@contextmanager
def compiling(cache_path: str | None, key: str):
    """While inside: the only process compiling `key` into the cache folder `cache_path`
    (None: no on-disk cache, no lock). Enter it holding numba's compiler lock."""
    lock = None
    if fcntl is not None and cache_path and key not in _held:
        try:
            folder = os.path.join(cache_path, FOLDER)
            os.makedirs(folder, exist_ok=True)
            lock = open(os.path.join(folder, hashlib.sha256(key.encode()).hexdigest()[:24]), "a")
        except OSError:
            lock = None
    if lock is None:
        yield
        return
    with lock:  # closing it releases the lock
        fcntl.flock(lock, fcntl.LOCK_EX)
        _held.add(key)
        try:
            yield
        finally:
            _held.discard(key)
