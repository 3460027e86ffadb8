"""`pytest --engine NAME` (repeatable, or comma-separated; globs allowed) selects engines
(default: every engine, built-in or plug-in; a missing one is skipped); a named engine
runs every family it can represent. Property tests run derandomized by default (profile
"ci"); `pytest --hypothesis-profile=wide` searches widely at random."""
from __future__ import annotations

import os
import sys
import tempfile
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
if str(ROOT) not in sys.path:
    sys.path.insert(0, str(ROOT))
# engine-wide readings cache their jobs here (physval.core.store.cache_dir), not in the user's cache
os.environ.setdefault("PHYSVAL_CACHE_DIR", tempfile.mkdtemp(prefix="physval-test-cache-"))

try:
    from hypothesis import settings as _hypothesis_settings
except ImportError:  # pragma: no cover
    _hypothesis_settings = None
else:
    # CI: the same examples every run (a failure reproduces); wide: a fresh random search.
    _hypothesis_settings.register_profile("ci", derandomize=True, deadline=None, print_blob=True)
    _hypothesis_settings.register_profile("wide", derandomize=False, deadline=None, max_examples=2000)
    _hypothesis_settings.load_profile("ci")


def pytest_addoption(parser):
    parser.addoption("--engine", action="append", default=[], metavar="NAME",
                     help="run the case tests on these engines only (repeatable or comma-separated; globs allowed)")


def selected_engines(config) -> tuple[list[str], bool]:
    """(engines, named): the --engine selection, or every registered engine."""
    import pytest
    from adapters.registry import engine_names
    from physval.core.selection import SelectionError, select_engines
    values = config.getoption("--engine")
    try:
        return select_engines(values or None, engine_names(), engine_names(), "--engine"), bool(values)
    except SelectionError as exc:
        raise pytest.UsageError(str(exc)) from None


def pytest_generate_tests(metafunc):
    """The jobs of the default run (reference formulations on the core families); the
    on-demand ones (minutes each) are marked slow and run with `pytest -m slow`."""
    import pytest
    from physval.core import Context
    from physval.validation import plan
    for name, conformance in (("job", False), ("conformance_job", True)):
        if name not in metafunc.fixturenames:
            continue
        engines, named = selected_engines(metafunc.config)
        resolver = Context().resolver()
        fams = {n: [v for v in f.variants] for n, f in resolver.families.items()
                if ("conformance" in f.tags) == conformance}
        jobs, later = plan(fams, engines, resolver, named, on_demand=False)
        params = [pytest.param(j, id=j.test_id) for j in jobs]
        params += [pytest.param(j, id=j.test_id, marks=[pytest.mark.slow]) for j in later]
        metafunc.parametrize(name, params)
