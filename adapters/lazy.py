"""Engines imported when a scene is first built, not when an adapter is made.

Planning a run reads every adapter's capabilities, and under the forkserver and spawn
start methods the workers import their engines themselves, so an engine imported by the
planning process is time spent for nothing (pydrake ~0.15 s, MuJoCo ~0.15 s, dartpy
~0.06 s). Such an adapter calls `require("dartpy")` at its top, which raises ImportError at
once if the engine is not installed (the registry then reports it as such) without running
it, and imports the engine in the functions that build a scene.

(importlib.util.LazyLoader is not used: before Python 3.12 a module it defers can be seen
half-loaded by a second thread, and a Dask worker runs jobs in threads.)
"""
from __future__ import annotations

import importlib.machinery
import importlib.util
import sys


def require(name: str) -> importlib.machinery.ModuleSpec:
    """The spec of the top-level module `name`, without running it; ImportError if it is
    not installed (or blocked by None in sys.modules, as `import` treats it)."""
    spec = None if name in sys.modules and sys.modules[name] is None else importlib.util.find_spec(name)
    if spec is None:
        raise ImportError(f"No module named {name!r}", name=name)
    return spec
