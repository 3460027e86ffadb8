"""Processes that start together on an empty numba cache compile a function once: the
others wait for it and load what it saved (reference_impl/compile_lock.py)."""
from __future__ import annotations

import subprocess
import sys
import textwrap
import time
from pathlib import Path

import pytest

from reference_impl.compiled import JIT

ROOT = Path(__file__).resolve().parents[2]

TINY = """
from reference_impl.compiled import njit


@njit
def twice(x):
    return 2.0 * x
"""

# says it is ready (numba imported), waits for the go file, calls twice (compiled or loaded from the cache), prints what numba
# counted: the compiles it made (cache misses) and the cached results it loaded (hits)
CALLER = """
import os, sys, time
sys.path[:0] = [sys.argv[1], sys.argv[2]]
import tiny
open(os.path.join(sys.argv[1], f"ready{os.getpid()}"), "w").close()
while not os.path.exists(sys.argv[3]):
    time.sleep(0.005)
assert tiny.twice(1.5) == 3.0
stats = tiny.twice.stats
print(sum(stats.cache_misses.values()), sum(stats.cache_hits.values()))
"""


@pytest.mark.skipif(not JIT, reason="compiled code only (numba installed, NUMBA_DISABLE_JIT unset)")
def test_two_processes_on_an_empty_cache_compile_once(tmp_path):
    (tmp_path / "tiny.py").write_text(textwrap.dedent(TINY))
    go = tmp_path / "go"
    callers = [subprocess.Popen([sys.executable, "-c", CALLER, str(tmp_path), str(ROOT), str(go)],
                                stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True) for _ in range(2)]
    deadline = time.monotonic() + 120
    while len(list(tmp_path.glob("ready*"))) < 2 and time.monotonic() < deadline:
        time.sleep(0.01)
    go.touch()  # both call within milliseconds: without the lock, both would compile
    outs = [c.communicate(timeout=120) for c in callers]
    assert all(c.returncode == 0 for c in callers), [err[-2000:] for _, err in outs]
    counts = sorted(tuple(map(int, out.split())) for out, _ in outs)
    assert counts == [(0, 1), (1, 0)], f"(compiled, loaded) per process: {counts}, should be one each"
