"""What reference_impl compiles, it compiles once per machine: processes that start together
on an empty numba cache compile a function once (the others wait for it and load what it
saved: reference_impl/compile_lock.py), and under $NUMBA_CACHE_DIR every copy of the
package with the same text (a checkout's, an installed wheel's) shares one cache folder
(reference_impl/compiled.py)."""
from __future__ import annotations

import os
import shutil
import subprocess
import sys
import time
from pathlib import Path

import pytest

from reference_impl.compiled import JIT

pytestmark = pytest.mark.skipif(not JIT, reason="compiled code only (numba installed, NUMBA_DISABLE_JIT unset)")

ROOT = Path(__file__).resolve().parents[2]

TINY = """
from reference_impl.compiled import njit


@njit
def twice(x):
    return 2.0 * x
"""
THRICE = """

@njit
def thrice(x):
    return 3.0 * x
"""

# imports `module` from the folder `path` (says so in the file `ready` when there is one,
# then waits for the file `go`), calls `function`, compiled or loaded from the cache, and prints
# what numba counted: the compiles it made (cache misses), the cached results it loaded (hits)
CALLER = """
import importlib, os, sys, time
path, module, function, ready, go = sys.argv[1:]
sys.path[:0] = [path]
tiny = importlib.import_module(module)
assert tiny.__file__.startswith(path), tiny.__file__
if ready:
    open(ready, "w").close()
    while not os.path.exists(go):
        time.sleep(0.005)
called = getattr(tiny, function)
assert called(1.5) in (3.0, 4.5)
stats = called.stats
print(sum(stats.cache_misses.values()), sum(stats.cache_hits.values()))
"""


def _caller(path: Path, module: str, cache: Path, ready: str = "", go: str = "",
            function: str = "twice") -> subprocess.Popen:
    env = {**os.environ, "PYTHONPATH": str(ROOT), "NUMBA_CACHE_DIR": str(cache)}
    return subprocess.Popen([sys.executable, "-c", CALLER, str(path), module, function, ready, go], env=env,
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)


def _counts(caller: subprocess.Popen) -> tuple[int, int]:
    out, err = caller.communicate(timeout=120)
    assert caller.returncode == 0, err[-2000:]
    compiled, loaded = map(int, out.split())
    return compiled, loaded


def test_two_processes_on_an_empty_cache_compile_once(tmp_path):
    (tmp_path / "tiny.py").write_text(TINY)
    go = tmp_path / "go"
    callers = [_caller(tmp_path, "tiny", tmp_path / "cache", str(tmp_path / f"ready{i}"), str(go)) for i in range(2)]
    deadline = time.monotonic() + 120
    while len(list(tmp_path.glob("ready*"))) < 2 and time.monotonic() < deadline:
        time.sleep(0.01)
    go.touch()  # both call within milliseconds: without the lock, both would compile
    counts = sorted(_counts(c) for c in callers)
    assert counts == [(0, 1), (1, 0)], f"(compiled, loaded) per process: {counts}, should be one each"


def test_a_copy_of_the_package_elsewhere_loads_what_another_compiled(tmp_path):
    """Two copies of reference_impl with the same text in two folders (as the checkout and
    the wheel installed from it): under one $NUMBA_CACHE_DIR, the second loads."""
    for copy in ("checkout", "installed"):
        package = tmp_path / copy / "reference_impl"
        shutil.copytree(ROOT / "reference_impl", package, ignore=shutil.ignore_patterns("__pycache__"))
        (package / "tiny.py").write_text(TINY)
    counts = [_counts(_caller(tmp_path / copy, "reference_impl.tiny", tmp_path / "cache"))
              for copy in ("checkout", "installed")]
    assert counts == [(1, 0), (0, 1)], f"(compiled, loaded): {counts}: the installed copy should load"
    assert [p.name for p in (tmp_path / "cache").iterdir()] == ["reference_impl"]


def test_a_process_waits_only_for_the_function_it_compiles(tmp_path):
    """The lock is per function and argument types: while `twice` is being compiled (its
    lock held here), another process compiles `thrice` at once and waits for `twice`."""
    from types import SimpleNamespace

    from numba import types

    from reference_impl.compile_lock import compiling, key_of
    package = tmp_path / "copy" / "reference_impl"
    shutil.copytree(ROOT / "reference_impl", package, ignore=shutil.ignore_patterns("__pycache__"))
    (package / "tiny.py").write_text(TINY + THRICE)
    line = TINY.splitlines().index("def twice(x):")  # first line of twice (its decorator's), 1-based
    twice = SimpleNamespace(__module__="reference_impl.tiny", __qualname__="twice",
                            __code__=SimpleNamespace(co_firstlineno=line))
    with compiling(str(tmp_path / "cache" / "reference_impl"), key_of(twice, (types.float64,))):
        other = _caller(tmp_path / "copy", "reference_impl.tiny", tmp_path / "cache", function="thrice")
        assert _counts(other) == (1, 0), "thrice compiled while twice's lock was held"
        waiting = _caller(tmp_path / "copy", "reference_impl.tiny", tmp_path / "cache")
        time.sleep(3.0)
        assert waiting.poll() is None, "a compile of twice waits while another holds its lock"
    assert _counts(waiting) == (1, 0)


def test_the_compile_clock_counts_a_compile_and_not_a_compiled_call(tmp_path, monkeypatch):
    """compiling_seconds grows by the wall time of a function's first call (numba compiles
    it: a module of a new folder) and not at its next call (compiled already)."""
    from reference_impl.compiled import compiling_seconds
    (tmp_path / "clocked.py").write_text(TINY)
    monkeypatch.syspath_prepend(str(tmp_path))
    import importlib
    clocked = importlib.import_module("clocked")
    before = compiling_seconds()
    assert clocked.twice(1.5) == 3.0
    first = compiling_seconds()
    assert clocked.twice(2.5) == 5.0
    assert first > before and compiling_seconds() == first


def test_cached_tells_whether_the_cache_holds_a_function_for_those_argument_types(tmp_path, monkeypatch):
    """compiled.cached(function, *args): true once a call compiled it for the types of
    `args` (a float), still false for other types (an int), as the reference's step halves
    are asked per formulation (world.uncompiled_halves)."""
    from reference_impl.compiled import cached
    (tmp_path / "asked.py").write_text(TINY)
    monkeypatch.syspath_prepend(str(tmp_path))
    import importlib
    asked = importlib.import_module("asked")
    assert not cached(asked.twice) and not cached(asked.twice, 1.5)
    assert asked.twice(1.5) == 3.0
    assert cached(asked.twice, 2.5) and cached(asked.twice) and not cached(asked.twice, 2)
