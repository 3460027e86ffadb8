"""The battery as tests: `pytest --engine NAME` keeps only that engine's tests, and
physval.testing runs the battery in an engine's own repository from the installed
package (examples/physval-engine-example/tests/test_battery.py), with no physval
checkout on the path."""
from __future__ import annotations

import functools
import os
import re
import shutil
import subprocess
import sys
from pathlib import Path

import pytest

from cases.relations import RELATIONS

ROOT = Path(__file__).resolve().parent.parent
EXAMPLE = ROOT / "examples" / "physval-engine-example"
# test_cases.py: the jobs; test_bulk_reads.py: an `engine` argument; test_box2d_rapier_mapping.py:
# engine marks; test_harness.py: about no engine
FILES = ["tests/test_cases.py", "tests/test_bulk_reads.py", "tests/test_box2d_rapier_mapping.py",
         "tests/test_harness.py"]


@functools.cache  # the whole collection, asked by each engine's test, made once (ONE_WORKER: one process)
def _collect(*args: str) -> tuple[list[str], str]:
    proc = subprocess.run([sys.executable, "-m", "pytest", "--collect-only", "-q", "-p", "no:cacheprovider", *args],
                          cwd=ROOT, capture_output=True, text=True, timeout=300)
    assert proc.returncode == 0, proc.stdout[-3000:] + proc.stderr[-2000:]
    return [x for x in proc.stdout.splitlines() if "::" in x], proc.stdout.strip().splitlines()[-1]


RELATION = f"(-({'|'.join(r.name for r in RELATIONS)}))?"  # the invariance battery's ids end in the relation


@pytest.mark.parametrize("engine, kept", [
    ("reference", r"tests/test_cases\.py::test_(case|conformance)\[.*-reference" + RELATION + r"\]"
                  r"|tests/test_bulk_reads\.py::test_\w+\[reference-[23]D\]"),
    ("box2d", r"tests/test_cases\.py::test_(case|conformance)\[.*-box2d" + RELATION + r"\]"
              r"|tests/test_bulk_reads\.py::test_\w+\[box2d-[23]D\]|tests/test_box2d_rapier_mapping\.py::test_box2d_\w+.*"),
])
def test_pytest_engine_keeps_that_engines_tests_only(engine, kept):
    every, _ = _collect(*FILES)
    ids, summary = _collect("--engine", engine, *FILES)
    assert ids and all(re.fullmatch(kept, i) for i in ids), [i for i in ids if not re.fullmatch(kept, i)][:5]
    assert sorted(ids) == sorted(i for i in every if re.fullmatch(kept, i)), "every test of the engine is kept"
    assert re.search(r"\d+ deselected", summary) and any("test_harness.py" in i for i in every)


@pytest.fixture(scope="module")
def installed(tmp_path_factory) -> tuple[Path, Path]:
    """(a folder holding physval and the example plug-in as pip installs them, a copy of
    the example's repository): what an engine developer has, with no physval checkout."""
    pytest.importorskip("mujoco", reason="the example plug-in wraps MuJoCo")
    tmp = tmp_path_factory.mktemp("installed")
    src = tmp / "physval-src"
    src.mkdir()
    for name in ("pyproject.toml", "README.md"):
        shutil.copy(ROOT / name, src / name)
    for package in ("physval", "cases", "adapters", "reference_impl"):
        shutil.copytree(ROOT / package, src / package, ignore=shutil.ignore_patterns("__pycache__"))
    repo = shutil.copytree(EXAMPLE, tmp / "engine-repo", ignore=shutil.ignore_patterns("build", "*.egg-info",
                                                                                      "__pycache__"))
    site = tmp / "site"
    for what in (src, repo):
        proc = subprocess.run([sys.executable, "-m", "pip", "install", "--quiet", "--no-deps",
                               "--disable-pip-version-check", "--target", str(site), str(what)],
                              capture_output=True, text=True, timeout=600)
        assert proc.returncode == 0, f"pip install {what.name} failed:\n{proc.stdout}\n{proc.stderr}"
    assert not (site / "tests").exists()
    return site, repo


def test_the_example_runs_the_battery_from_the_installed_package(installed):
    """The example's tests/test_battery.py, run in a copy of its repository with only the
    installed packages on the path: a recorded deviation is an expected failure, a
    conformance check passes, and physval is the installed copy."""
    site, repo = installed
    env = {**os.environ, "PYTHONPATH": str(site)}
    where = subprocess.run([sys.executable, "-c", "import physval, physval.testing; print(physval.__file__)"],
                           cwd=repo, env=env, capture_output=True, text=True, timeout=60)
    assert where.stdout.strip() == str(site / "physval" / "__init__.py"), where.stdout + where.stderr
    ids = ["tests/test_battery.py::test_battery[central_impact[e=0.5,m=1:3]-mujoco-soft]",
           "tests/test_battery.py::test_battery[conformance[free_fall_matches_discrete_closed_form,3D]-mujoco-soft]"]
    proc = subprocess.run([sys.executable, "-m", "pytest", "-q", "-p", "no:cacheprovider", "-rx", *ids],
                          cwd=repo, env=env, capture_output=True, text=True, timeout=600)
    assert proc.returncode == 0, proc.stdout[-3000:] + proc.stderr[-2000:]
    assert "1 passed, 1 xfailed" in proc.stdout, proc.stdout[-2000:]
    assert "v1_after: e mapped onto a spring-damper lasting 32 steps" in proc.stdout, "the xfail gives the cause"


def test_a_failing_check_reads_as_the_measurement_against_the_closed_form(tmp_path):
    """check() on an engine that ignores contact: the failure names each metric's measured
    and expected value, its tolerance and reason, and the command that reproduces it."""
    from physval.core import Context
    from physval.testing import check, engine_checks
    ctx = Context(adapters=(f"{ROOT / 'tests' / 'fakes.py'}:FakeAdapter",))
    (param,) = [p for p in engine_checks(["fake"], ctx=ctx) if p.id == "central_impact[e=0.5,m=1:3]-fake"]
    with pytest.raises(AssertionError) as failed:
        check(param.values[0], ctx)
    message = str(failed.value)
    assert re.search(r"v1_after = 2 m/s, but should be -1\.3\d* within \S+ \(abs; .+\) -- abs error", message), message
    assert "reproduce: physval run --cases 'central_impact[e=0.5,m=1:3]' --engines fake" in message
