"""`pytest --engine NAME` (repeatable, or comma-separated; globs allowed) runs the tests of
those engines only: the tests parametrized on an engine (a job of the case battery or the
conformance battery, an agreement pairing, an `engine` argument) whose engine is selected,
and the tests marked `@pytest.mark.engine(GLOB)` (an adapter's own mapping tests) whose
glob matches a selected engine; every other test (the harness, closed forms, the
reference implementation's units) is deselected. A named engine runs every family it can
represent; without --engine every test runs on every engine, built-in or plug-in (a
missing one is skipped). Property tests run derandomized by default (profile "ci");
`pytest --hypothesis-profile=wide` searches widely at random."""
from __future__ import annotations

import os
import sys
import tempfile
from pathlib import Path

import pytest
from hypothesis import settings

import physval  # noqa: F401 - first of the project: one BLAS thread before numpy loads (physval/__init__)

ROOT = Path(__file__).resolve().parent.parent
if str(ROOT) not in sys.path:
    sys.path.insert(0, str(ROOT))
# Folders made by the session's first process, inherited by its pytest-xdist workers (and the
# processes tests start), removed at its end (one was left behind by every pytest process):
# PHYSVAL_CACHE_DIR: engine-wide readings cache their jobs here (physval.core.store.cache_dir),
# not in the user's cache; PHYSVAL_TEST_ROWS: one run's rows of each built-in job, shared by the
# tests that read them (tests.helpers.shared_rows)
for _name, _prefix in (("PHYSVAL_CACHE_DIR", "physval-test-cache-"), ("PHYSVAL_TEST_ROWS", "physval-test-rows-")):
    if _name not in os.environ:
        import atexit
        import shutil
        os.environ[_name] = tempfile.mkdtemp(prefix=_prefix)
        atexit.register(shutil.rmtree, os.environ[_name], ignore_errors=True)
# NUMBA_CACHE_DIR (unless set): the reference's compiled functions, kept across sessions in the
# checkout (tests/__pycache__, ignored by git) and shared by every copy of reference_impl the
# session runs: its own, the virtual environment's that `physval` subprocesses import, the
# installed wheel's (tests/test_installed.py): each compiles once for all (reference_impl/compiled.py)
os.environ.setdefault("NUMBA_CACHE_DIR", str(ROOT / "tests" / "__pycache__" / "numba"))


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
    config.addinivalue_line("markers", "engine(*globs): a test about these engines, kept by `pytest --engine`")


def pytest_addoption(parser):
    parser.addoption("--engine", action="append", default=[], metavar="NAME",
                     help="run the case tests on these engines only (repeatable or comma-separated; globs allowed)")


def selected_engines(config) -> tuple[list[str], bool]:
    """(engines, named): the --engine selection, or every registered engine."""
    from adapters.registry import engine_names
    from physval.core.selection import SelectionError, select_engines
    values = config.getoption("--engine")
    try:
        return select_engines(values or None, engine_names(), engine_names(), "--engine"), bool(values)
    except SelectionError as exc:
        raise pytest.UsageError(str(exc)) from None


# The suite's own speed table (scikit-learn keeps one too): jobs of the default run that
# cost the suite more than its share of the 10-minute budget on 2 cores, run here with
# `pytest -m slow` (and in every `physval run`). (engine glob, test id glob): why.
SLOW_IN_THE_SUITE = {
    ("reference-newton-coulomb", "resting_blocks[[]n=[345]]*"):
        "pairwise impulses run all 200 sweeps each step on a resting stack: 25-77 s each on 2 shared cores",
    ("reference-lemke", "resting_blocks[[]n=[45]]*"): "a dense pivoting tableau per step: 14-19 s each",
    # the formulations' heaviest runs outside the core families (measured on 2 shared cores)
    ("reference-lemke", "bounce_series*"): "a pivoting tableau on every step of 40 bounces: 12 s",
    ("reference-force", "bounce_series*"): "two Lemke solves a step over 40 bounces: 10 s",
    ("reference-newton-coulomb", "bounce_series*"): "the pairwise loop over 40 bounces: 4-5 s each",
    ("reference-newton-coulomb", "stack_forces*"): "all 200 pairwise sweeps a step on a resting stack: 1-4 s each",
    ("reference-newton-coulomb", "stack_strike*"): "all 200 pairwise sweeps a step on a resting stack: 1-2 s each",
    # CENIC integrates a rocking stack to its accuracy target: 32-38 of its 45-56 job-s in a default run
    ("drake-cenic", "resting_blocks*"): "CENIC shortens its steps on the rocking point-contact stack: 1-14 s each",
    # MuJoCo Warp steps MuJoCo's own model (tests/test_mujoco_warp_mapping.py; `physval parity`):
    # its conformance battery stays in the suite, its core families (53 jobs, 1-2 min on 2 cores
    # with Warp's per-process start) run with -m slow and in every `physval run`
    ("mujoco-warp", "central_impact*"): "MuJoCo's model on Warp's CPU kernels: 1-3 s a job",
    ("mujoco-warp", "incline_threshold*"): "MuJoCo's model on Warp's CPU kernels: 1-3 s a job",
    ("mujoco-warp", "resting_blocks*"): "MuJoCo's model on Warp's CPU kernels: 1-3 s a job",
    # Newton's five configurations run their conformance battery and core families in every
    # `physval run` (365 jobs, 431 s of stepping on 2 cores with a warm kernel cache), here with -m slow
    ("newton-*", "*"): "Warp's CPU kernels, 0.4-2.6 ms a step, and 10-60 s of compiling a solver in an empty cache",
}


def _suite_speed(param):
    from fnmatch import fnmatchcase
    job = param.values[0]
    slow = any(fnmatchcase(job.engine, e) and fnmatchcase(job.variant.test_id, v) for e, v in SLOW_IN_THE_SUITE)
    return pytest.param(*param.values, id=param.id, marks=[*param.marks, pytest.mark.slow]) if slow else param


def pytest_generate_tests(metafunc):
    """The jobs of the default run, each a test; the on-demand ones (minutes each) and
    those SLOW_IN_THE_SUITE lists are marked slow and run with `pytest -m slow`."""
    from physval.testing import engine_checks
    for name, conformance in (("job", False), ("conformance_job", True)):
        if name in metafunc.fixturenames:
            engines, named = selected_engines(metafunc.config)
            metafunc.parametrize(name, [_suite_speed(p) for p in engine_checks(engines, conformance, named)])


def engines_of(item) -> tuple[set[str], list[str]]:
    """(the engines a test is parametrized on, the engine globs it is marked with)."""
    params = getattr(item, "callspec", None)
    engines = set()
    for name, value in (params.params.items() if params else ()):
        if name == "engine" and isinstance(value, str):
            engines.add(value)
        elif isinstance(getattr(value, "engine", None), str):  # a Job, an agreement pairing
            engines.add(value.engine)
    return engines, [g for mark in item.iter_markers("engine") for g in mark.args]


def pytest_collection_modifyitems(config, items):
    """Under --engine, deselect every test that is not about a selected engine; then put
    the tests in the order the suite's workers take them (in_worker_order)."""
    _deselect_other_engines(config, items)
    in_worker_order(items)


# Test files whose tests share one costly set-up (a module fixture, or rows cached in the
# process) run on one pytest-xdist worker (pytest_xdist_make_scheduler): with `-n 2`'s
# `--dist load` each worker that ran one of their tests made the set-up again. Heaviest
# first where measured (CPU s of the file in an earlier `pytest -n 2` under load: installed
# 187, faults 185, plugins 58, real 38, catches 35; bad_input 83 with its physval processes,
# `-n 2` quiet), so that the longest chain starts at once and the other worker fills in beside it.
ONE_WORKER = {
    "test_installed.py": "the wheel built and installed in a fresh environment, whose first reference run compiles",
    "test_faults.py": "each fault's rows on each engine, cached in the process (and the unmodified wrapper's)",
    "test_bad_input.py": "the crashing families, bad adapters and refused paths, each set tried in one process",
    "test_plugins.py": "the example plug-in installed by pip",
    "test_real.py": "the packaged tosses and the synthetic tosses MuJoCo makes",
    "test_testing.py": "physval and the example plug-in installed by pip",
    "test_catches.py": "each variant's rows without the fault, cached in the process",
    "test_site.py": "a small run's report",
    "test_releases.py": "the release environments, made once and reused",
    "test_observer_faults.py": "each fault's rows, cached in the process",
    "test_shape_mapping.py": "each engine's run of the shape scene, cached in the process",
}


@pytest.hookimpl(tryfirst=True, optionalhook=True)
def pytest_xdist_make_scheduler(config, log):
    """`-n N` as `--dist load` hands out tests (one at a time as a worker runs short of
    them, in the order in_worker_order gives), except that each file of ONE_WORKER goes to
    one worker whole. (`--dist loadgroup` would do it from marks, but with pytest 9.2 it
    silently stops grouping: pytest-xdist marks a group in the test's id, which pytest no
    longer reads, pytest-dev/pytest-xdist#1386.) Another --dist is left as asked."""
    if config.getvalue("dist") != "load":
        return None
    from xdist.scheduler import LoadScopeScheduling

    class OneWorkerFiles(LoadScopeScheduling):
        def _split_scope(self, nodeid: str) -> str:
            return one_worker_unit(nodeid)

    config.option.loadscopereorder = False  # keep in_worker_order's order (not the scopes' sizes)
    return OneWorkerFiles(config, log)


def one_worker_unit(nodeid: str) -> str:
    """What pytest-xdist hands to one worker at once: a file of ONE_WORKER whole, else the test."""
    file = nodeid.split("::", 1)[0]
    return file if file.rsplit("/", 1)[-1] in ONE_WORKER else nodeid


def in_worker_order(items) -> None:
    """The order pytest-xdist hands the tests out in: first the files of ONE_WORKER
    (heaviest first), then the jobs of the battery, the costliest first by the shipped cost
    table (physval/readings/costs.csv, as `physval run --plan` prices a job), then the rest
    as collected, short tests, so that the workers end together. Without xdist the order
    changes nothing but when a test runs."""
    order = list(ONE_WORKER)
    grouped, jobs, rest = [], [], []
    for item in items:
        if item.path.name in ONE_WORKER:
            grouped.append(item)
        elif _job_of(item) is not None:
            jobs.append(item)
        else:
            rest.append(item)
    grouped.sort(key=lambda item: order.index(item.path.name))  # stable: a file keeps its own order
    cost = _job_cost()
    jobs.sort(key=lambda item: -cost(_job_of(item)))
    items[:] = grouped + jobs + rest


def pytest_collection_finish(session):
    """In each pytest-xdist worker, before its first test: what the battery's engines compile
    on first use and the cache lacks (Adapter.uncompiled: on a fresh clone, the reference's
    step, several minutes of numba), each part by the first worker that claims it (a file in
    the session's shared folder), as `physval run` has its workers do (physval.core.ahead).
    Otherwise each formulation's first job compiled its parts one after the other while the
    other worker, at a job of the same formulation, waited for the cache. A part that fails
    is left to the tests that need it."""
    if not os.environ.get("PYTEST_XDIST_WORKER"):
        return
    import hashlib
    from physval.core import Context
    from physval.core.ahead import compile_part, uncompiled_parts
    engines = [job.engine for item in session.items if (job := _job_of(item)) is not None]
    claims = Path(os.environ["PHYSVAL_TEST_ROWS"])
    for engine, part in uncompiled_parts(engines, Context()):
        claim = claims / f"compiling-{hashlib.sha256(repr(part).encode()).hexdigest()[:16]}"
        try:
            os.close(os.open(claim, os.O_CREAT | os.O_EXCL))
        except FileExistsError:
            continue  # another worker's
        try:
            compile_part((Context(), engine, part))
        except Exception:  # noqa: BLE001 - the tests that need it fail with the reason
            pass


def _job_of(item):
    params = getattr(item, "callspec", None)
    return params.params.get("job", params.params.get("conformance_job")) if params else None


def _job_cost():
    """Predicted seconds of a job (0 where the table cannot price it)."""
    import math
    from physval.core.jobs import steps_of
    from physval.readings.cost import Model, load_table
    from cases.registry import builtin_families
    model, families = Model.of(load_table(), "shipped"), builtin_families()

    def cost(job) -> float:
        family = families.get(job.family)
        if family is None:
            return 0.0
        seconds, _ = model.predict(job.engine, job.family, steps_of(job, family))
        return 0.0 if math.isnan(seconds) else seconds
    return cost


def _deselect_other_engines(config, items) -> None:
    if not config.getoption("--engine"):
        return
    from fnmatch import fnmatchcase
    selected = set(selected_engines(config)[0])
    keep, drop = [], []
    for item in items:
        engines, globs = engines_of(item)
        ours = engines & selected or any(fnmatchcase(e, g) for g in globs for e in selected)
        (keep if ours else drop).append(item)
    if drop:
        config.hook.pytest_deselected(items=drop)
        items[:] = keep
