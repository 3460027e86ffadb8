"""`pytest --engine NAME` (repeatable, or comma-separated) selects engines; default: all."""
from __future__ import annotations

import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
if str(ROOT) not in sys.path:
    sys.path.insert(0, str(ROOT))


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
