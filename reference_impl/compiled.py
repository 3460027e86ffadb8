"""The one switch between compiled and plain Python: `njit`.

The inner loops of the formulations (PGS and sequential-impulse sweeps, Lemke's pivots,
the pairwise Newton-Coulomb loop, the compliant substeps) and of the world around them
(the box-box narrow phase, a step's contact rows) are written once, as plain
Python on numpy arrays and floats, and decorated with `njit`: with numba installed (a
dependency of the project) they run compiled by it, in nopython mode, each compiled once
per machine and kept in numba's on-disk cache (`__pycache__` beside the module, or
$NUMBA_CACHE_DIR); without numba, or with NUMBA_DISABLE_JIT=1, the very same functions
run as Python (the same results, slower). Compiled code keeps Python's float semantics:
no fastmath, so each operation rounds as it does in Python.
"""
from __future__ import annotations

try:
    from numba import njit as _numba_njit
except ImportError:  # pragma: no cover - numba is a dependency; this keeps the code runnable without it
    _numba_njit = None


def njit(function):
    """`function` compiled by numba (nopython, cached on disk), or unchanged without numba."""
    if _numba_njit is None:
        return function
    return _numba_njit(cache=True)(function)
