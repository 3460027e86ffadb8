"""Imported once by the fork server that local workers start from (forkserver start
method), so each worker begins with the harness and the built-in families loaded, and,
when the process that started the server asked for it ($PHYSVAL_PRELOAD_REFERENCE=1,
physval.core.executor.start_fork_server), with the reference's compiled step loaded: one
step of a ball on a ground, only where the numba cache holds it already (loading: ~1 s;
on a fresh install it would compile for minutes before any worker could start, so the
workers compile it as before, the first one while the others wait for its cache)."""
import os

from cases.registry import builtin_families
from physval.core import jobs  # noqa: F401
from physval.core.executor import PRELOAD_REFERENCE

builtin_families()


def _reference_step_cached() -> bool:
    from reference_impl.compiled import cached
    from reference_impl.world import begin, end
    return cached(begin) and cached(end)


if os.environ.pop(PRELOAD_REFERENCE, None) == "1" and _reference_step_cached():
    from physval.core.dry_run import warm
    warm("reference")
