"""`pytest --engine NAME` (repeatable, or comma-separated) selects engines; default: all."""
from __future__ import annotations

import sys
from pathlib import Path

from hypothesis import settings

ROOT = Path(__file__).resolve().parent.parent
if str(ROOT) not in sys.path:
    sys.path.insert(0, str(ROOT))


# Hypothesis profiles. "ci" (the default): derandomized, so every run draws the same
# examples and a test fails only when the code changes; 60 examples a test unless the test
# sets its own max_examples. "wide", on demand: a fresh random search with 2000 examples a
# test (those without their own max_examples), failures printed with their reproduction
# blob:  python -m pytest tests/reference -p no:cacheprovider --hypothesis-profile=wide
# (hypothesis's own pytest option). Run it to look for new counter-examples; pin what it
# finds as a documented test, never by loosening the property.
settings.register_profile("ci", derandomize=True, max_examples=60, deadline=None, database=None)
settings.register_profile("wide", derandomize=False, max_examples=2000, deadline=None, database=None,
                          print_blob=True)


def pytest_configure(config):
    """Load --hypothesis-profile if given, else "ci"; before the test modules are imported,
    so their @settings inherit it."""
    settings.load_profile(config.getoption("--hypothesis-profile", default=None) or "ci")


def pytest_addoption(parser):
    parser.addoption("--engine", action="append", default=[], metavar="NAME",
                     help="run the case tests on these engines only (repeatable or comma-separated)")


def selected_engines(config) -> list[str]:
    from adapters.registry import engine_names
    chosen = [e.strip() for v in config.getoption("--engine") for e in v.split(",") if e.strip()]
    unknown = [e for e in chosen if e not in engine_names()]
    if unknown:
        import pytest
        raise pytest.UsageError(f"--engine {', '.join(unknown)}: unknown; choose from {', '.join(engine_names())}")
    return chosen or engine_names()


def pytest_generate_tests(metafunc):
    """The jobs of the default run (reference formulations on the core families); the
    on-demand ones (minutes each) are marked slow and run with `pytest -m slow`."""
    import pytest
    from cases.registry import builtin_families
    from physval import conformance
    from physval.runner import default_jobs, on_demand
    for name, fams in (("job", builtin_families), ("conformance_job", lambda: {"conformance": conformance.FAMILY})):
        if name in metafunc.fixturenames:
            jobs = default_jobs(fams(), selected_engines(metafunc.config), include_on_demand=True)
            params = [pytest.param(j, id=j.test_id, marks=[pytest.mark.slow] if on_demand(j) else [])
                      for j in jobs]
            metafunc.parametrize(name, params)
