"""Running jobs in the test process (no worker), with stand-in adapters and known deviations;
one run's rows of a built-in job shared by every test that reads them; and a built-in
variant's scene at its family's dt, for the tests that build an engine directly."""
from __future__ import annotations

import fcntl
import functools
import hashlib
import os
import pickle
from pathlib import Path

from physval.core import Context, Job, execute
from physval.core.context import Resolver

SHARED_ROWS = "PHYSVAL_TEST_ROWS"  # the session's folder of shared job rows (tests/conftest.py)
_rows: dict[str, tuple[dict, ...]] = {}


def shared_rows(job: Job) -> list[dict]:
    """The rows of `job` (built-in families and engines, no stand-ins) as this test session
    ran it once: the battery (tests/test_cases.py), the agreement tests and the faults'
    unmodified runs read the same job's rows, and run it only if no test of the session
    has, in this process or in another pytest-xdist worker (the folder $PHYSVAL_TEST_ROWS
    they share, one lock file a job; without it, this process only). Each caller gets its
    own copies."""
    rows = _rows.get(job.key)
    if rows is None:
        folder = os.environ.get(SHARED_ROWS)
        if not folder:
            rows = tuple(execute(job, Context().resolver()).rows)
        else:
            path = Path(folder) / (hashlib.sha256(job.key.encode()).hexdigest()[:32] + ".pickle")
            # one process runs the job while another that wants it waits for its rows (two
            # workers asking at once both ran it); the lock goes with its holder's death
            with open(path.with_suffix(".lock"), "a") as lock:
                fcntl.flock(lock, fcntl.LOCK_EX)
                if path.is_file():
                    rows = pickle.loads(path.read_bytes())
                else:
                    rows = tuple(execute(job, Context().resolver()).rows)
                    tmp = path.with_name(f".{path.name}.{os.getpid()}")
                    tmp.write_bytes(pickle.dumps(rows))
                    os.replace(tmp, path)  # whole or absent
        _rows[job.key] = rows
    return [dict(r) for r in rows]  # from this call's own reference: another thread may clear _rows


@functools.cache
def _not_installed(engine: str) -> str | None:
    """Why `engine` cannot run here (the resolver's message), or None; asked once a process."""
    try:
        Context().resolver().adapter(engine)
    except Exception as exc:
        return str(exc)
    return None


def skip_if_not_installed(engine: str) -> None:
    """Skip a test of an engine not installed here, with the message physval.testing.check
    gives, before its job runs: the job of an engine that is not installed still went
    through execute (an error row, a lock file and a pickle) and the resolver's import
    attempt, 30 ms a test for the 1518 battery tests of the five engines `.[all,more]`
    leaves out here."""
    import pytest
    why = _not_installed(engine)
    if why is not None:
        pytest.skip(why)


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


def adapter_or_skip(name: str):
    """The registry's adapter of engine `name`; the test is skipped where it is not installed."""
    import pytest
    from adapters import registry
    try:
        return registry.get(name)
    except registry.EngineError as exc:
        pytest.skip(str(exc))


def engines_declaring(need) -> list[str]:
    """Every registered engine whose capabilities satisfy `need(capabilities)` (one not
    installed here is left out)."""
    from adapters import registry
    out = []
    for name in registry.engine_names():
        try:
            caps = registry.get(name).capabilities
        except Exception:
            continue
        if need(caps):
            out.append(name)
    return out
