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
    from cases.registry import builtin_families
    from physval import conformance
    from physval.runner import plan
    for name, fams in (("job", builtin_families), ("conformance_job", lambda: {"conformance": conformance.FAMILY})):
        if name in metafunc.fixturenames:
            jobs = plan(fams(), selected_engines(metafunc.config))
            metafunc.parametrize(name, jobs, ids=[j.test_id for j in jobs])
