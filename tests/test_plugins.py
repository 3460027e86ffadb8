"""Engines from outside the repository (issue #13 part 1): the example plug-in package
(examples/physval-engine-example, engine `mujoco-soft`) installed with pip into a folder of
its own is found through its entry point and runs under every command, every worker start
method and on Dask workers, judged by the known-deviation file it ships; adapters named
ad hoc with `--adapter module:Class` or `--adapter path/file.py:Class` run under spawn.

Every command runs in a subprocess with the install folder on PYTHONPATH, as a user's
shell would have it: entry points are found from any sys.path entry holding the package's
dist-info, in the main process and in each worker it starts.
"""
from __future__ import annotations

import csv
import os
import shutil
import subprocess
import sys
import textwrap
from pathlib import Path

import pytest

from physval.core import deviations
from physval.core.store import read_results
from physval.core.executor import START_METHODS

pytest.importorskip("mujoco", reason="the example plug-in wraps MuJoCo")

ROOT = Path(__file__).resolve().parent.parent
EXAMPLE = ROOT / "examples" / "physval-engine-example"
ENGINE = "mujoco-soft"
CASE = "central_impact[e=0.5,m=1:3]"  # v1_after, v2_after, energy_lost deviate (recorded); momentum_after passes
DEVIATING = {"v1_after", "v2_after", "energy_lost"}


@pytest.fixture(scope="module")
def site(tmp_path_factory) -> Path:
    """The example package installed by pip (from a copy, so the repository stays clean)."""
    tmp = tmp_path_factory.mktemp("plugin")
    src = shutil.copytree(EXAMPLE, tmp / "src", ignore=shutil.ignore_patterns("build", "*.egg-info", "__pycache__"))
    target = tmp / "site"
    proc = subprocess.run([sys.executable, "-m", "pip", "install", "--quiet", "--no-deps",
                           "--disable-pip-version-check", "--target", str(target), str(src)],
                          capture_output=True, text=True, timeout=600)
    assert proc.returncode == 0, f"pip install failed:\n{proc.stdout}\n{proc.stderr}"
    assert (target / "physval_engine_example" / "xfails" / f"{ENGINE}.txt").is_file(), "package data not installed"
    return target


def _run(args: list[str], *path: Path, timeout: float = 300) -> subprocess.CompletedProcess:
    inherited = [p for p in os.environ.get("PYTHONPATH", "").split(os.pathsep) if p]
    env = {**os.environ, "PYTHONPATH": os.pathsep.join([*map(str, path), str(ROOT), *inherited])}
    return subprocess.run([sys.executable, *args], cwd=ROOT, env=env, capture_output=True, text=True,
                          timeout=timeout)


def physval(*args: str, path=()) -> subprocess.CompletedProcess:
    proc = _run(["-m", "physval", *args], *path)
    assert proc.returncode == 0, f"physval {' '.join(args)} exited {proc.returncode}:\n{proc.stderr[-3000:]}"
    return proc


def rows(path: Path) -> list[dict]:
    with open(path, newline="") as f:
        return list(csv.DictReader(f))


def assert_judged_by_its_own_file(found: list[dict]) -> None:
    """The case ran on the plug-in in a worker, and the plug-in's shipped deviation file
    turned exactly its recorded checks into deviations within their bands."""
    shipped = deviations.parse(EXAMPLE / "physval_engine_example" / "xfails" / f"{ENGINE}.txt")
    mine = {r["metric"]: r for r in found if r["engine"] == ENGINE and r["case"] == "central_impact"}
    assert set(mine) == DEVIATING | {"momentum_after"}, found
    for metric, r in mine.items():
        entry = deviations.find(shipped, "central_impact", r["variant"], metric)
        band = entry.band(ENGINE, r["variant"], metric) if entry else None
        if metric in DEVIATING:
            assert r["status"] == "deviation", r["reason"]
            assert r["known_deviation"] == entry.reason and r["band"] == band.describe(), r
        else:
            assert r["status"] == "pass" and band is None, r["reason"]


def test_the_installed_plugin_is_listed_with_where_it_comes_from(site):
    out = physval("list", "--engines", path=[site]).stdout
    (line,) = [x for x in out.splitlines() if x.startswith(f"{ENGINE}\t")]
    name, version, origin, shapes, caps = line.split("\t")
    assert origin == "entry point (physval-engine-example 0.1.0)"
    assert version != "not installed" and "impacts: compliant" in caps and shapes.startswith("shapes: ")


@pytest.mark.parametrize("method", START_METHODS)
def test_the_plugin_runs_under_every_start_method(site, tmp_path, method):
    physval("run", "--cases", CASE, "--engines", ENGINE, "--workers", "1", "--start-method", method,
            "--quiet", "--out", str(tmp_path), path=[site])
    assert_judged_by_its_own_file(rows(tmp_path / "results.csv"))


def test_the_plugin_runs_on_dask_workers_in_their_own_processes(site, tmp_path):
    """A LocalCluster with processes=True: the worker is a separate (spawned) process that
    must find the plug-in itself."""
    pytest.importorskip("distributed")
    script = tmp_path / "on_dask.py"
    script.write_text(textwrap.dedent(f"""
        import sys
        from distributed import LocalCluster
        from physval.cli import main

        if __name__ == "__main__":
            with LocalCluster(n_workers=1, threads_per_worker=1, processes=True, dashboard_address=None) as cluster:
                code = main(["run", "--cases", {CASE!r}, "--engines", {ENGINE!r}, "--quiet",
                             "--out", {str(tmp_path / "out")!r}, "--scheduler", cluster.scheduler_address])
            sys.exit(code)
    """))
    proc = _run([str(script)], site)
    assert proc.returncode == 0, proc.stderr[-3000:]
    assert_judged_by_its_own_file(rows(tmp_path / "out" / "results.csv"))


def test_sweep_takes_the_plugin(site, tmp_path):
    physval("sweep", "--cases", CASE, "--engines", ENGINE, "--repeats", "1", "--workers", "1", "--quiet",
            "--out", str(tmp_path / "sweep"), path=[site])
    points = [r for r in rows(tmp_path / "sweep" / "sweep.csv") if r["engine"] == ENGINE]
    assert points and {r["status"] for r in points} <= {"pass", "fail", "deviation"}
    # bands hold at the family's dt and the adapter's default iterations: there, and only
    # there, the recorded checks are deviations
    assert {r["metric"] for r in points if r["status"] == "deviation"} == DEVIATING
    assert all(float(r["dt"]) == 1e-3 and r["iterations_asked"] == "default" for r in points if r["status"] == "deviation")


def test_stress_takes_the_plugin(site, tmp_path):
    physval("stress", "--cases", "robustness_overlap[box_in_ground,2D]", "--engines", ENGINE, "--no-map",
            "--workers", "1", "--quiet", "--out", str(tmp_path / "stress"), path=[site])
    judged = {r["metric"]: r for r in rows(tmp_path / "stress" / "stress_results.csv") if r["engine"] == ENGINE}
    assert judged["drift"]["status"] == "deviation" and judged["drift"]["band"], judged["drift"]
    assert judged["penetration"]["status"] == "pass"


def test_pytest_engine_runs_the_battery_on_the_plugin(site):
    """`pytest --engine mujoco-soft` parametrizes the case and conformance tests with the
    plug-in: a recorded deviation is an expected failure, a conformance check passes."""
    ids = [f"tests/test_cases.py::test_case[{CASE}-{ENGINE}]",
           f"tests/test_cases.py::test_conformance[conformance[free_fall_matches_discrete_closed_form,3D]-{ENGINE}]"]
    proc = _run(["-m", "pytest", "-q", "-p", "no:cacheprovider", "--engine", ENGINE, *ids], site)
    assert proc.returncode == 0, proc.stdout[-3000:] + proc.stderr[-2000:]
    assert "1 passed, 1 xfailed" in proc.stdout, proc.stdout[-2000:]


def test_adapters_named_ad_hoc_run_under_spawn(tmp_path):
    """Not installed: a module on the path (`module:Class`, with its deviation file beside
    it) and a file of the user's own (`path/file.py:Class`), loaded again in each spawned
    worker."""
    (tmp_path / "stiff.py").write_text(textwrap.dedent("""
        from adapters.mujoco_engine import MuJoCoAdapter

        class StiffMuJoCo(MuJoCoAdapter):
            name = "mujoco-stiff"

            def __init__(self):
                super().__init__(contact_steps=8)
    """))
    adhoc = ["--adapter", "physval_engine_example:SoftMuJoCo", "--adapter", f"{tmp_path / 'stiff.py'}:StiffMuJoCo"]
    listed = physval("list", "--engines", *adhoc, path=[EXAMPLE]).stdout
    origins = {x.split("\t")[0]: x.split("\t")[2] for x in listed.splitlines()}
    assert origins[ENGINE] == "--adapter" and origins["mujoco-stiff"] == "--adapter"
    out = tmp_path / "out"
    physval("run", *adhoc, "--cases", CASE, "--engines", ENGINE, "mujoco-stiff", "--workers", "1",
            "--start-method", "spawn", "--quiet", "--out", str(out), path=[EXAMPLE])
    found = read_results(out)  # each row's knobs from knobs.json
    assert_judged_by_its_own_file(found)
    stiff = [r for r in found if r["engine"] == "mujoco-stiff"]
    assert stiff and {r["status"] for r in stiff} <= {"pass", "fail"}  # no deviation file of its own
    assert '"contact_steps_n": 8' in stiff[0]["knobs"]


# --- a plug-in's deviation file ---------------------------------------------------------------

def test_band_lines_written_for_any_metric_name_parse_again(tmp_path):
    """`physval known --write` writes Band.text(); metric names may hold dots (friction_isotropy's
    deceleration_22.5deg), and the file must read back the same bands."""
    band = deviations.Band("mujoco-soft", "mu=0.2", "deceleration_22.5deg", 1.9310836, 0.00155)
    path = tmp_path / "eng.txt"
    path.write_text("friction_isotropy[*]:deceleration_*  # chattering box\n" + band.text() + "\n")
    (entry,) = deviations.parse(path)
    got = entry.band("mujoco-soft", "mu=0.2", "deceleration_22.5deg")
    assert (got.value, got.width) == (band.value, pytest.approx(band.width, rel=1e-3))


def test_a_deviation_file_that_does_not_parse_stops_the_run_with_one_line(tmp_path, capsys):
    """A plug-in whose shipped file is broken: exit 2 naming the file and line, before any
    job (not a worker dying in every job)."""
    from physval.cli import main
    (tmp_path / "xfails").mkdir()
    (tmp_path / "xfails" / "reference-broken.txt").write_text(
        "central_impact[*]:v1_after  # a cause\n    reference-broken [e=0.5,m=1:3]:v1_after = oops\n")
    (tmp_path / "broken.py").write_text(textwrap.dedent("""
        from adapters.reference_engine import ReferenceAdapter

        class Broken(ReferenceAdapter):
            def __init__(self):
                super().__init__(name="reference-broken")
    """))
    code = main(["run", "--adapter", f"{tmp_path / 'broken.py'}:Broken", "--engines", "reference-broken",
                 "--cases", CASE, "--workers", "1", "--quiet", "--out", str(tmp_path / "out")])
    err = capsys.readouterr().err
    assert code == 2 and "reference-broken.txt:2" in err and len(err.strip().splitlines()) == 1, err
    assert not (tmp_path / "out" / "results.csv").exists()


# --- resuming: a plug-in's code is part of the resume key --------------------------------------

def _to_run(proc: subprocess.CompletedProcess) -> tuple[int, int]:
    """(runs, runs to run) from `physval run`'s first progress line."""
    import re
    m = re.search(r"^physval: (\d+) runs \(.*?\), (\d+) to run", proc.stderr, re.M)
    assert m, proc.stderr
    return int(m[1]), int(m[2])


def _edited_rerun(args, edited: Path, path) -> list[tuple[int, int]]:
    """(runs, to run) of `physval run ARGS` three times: first, again, and after a comment
    is added to `edited` (its behaviour and the engine's version string unchanged)."""
    counts = [_to_run(physval(*args, path=path)), _to_run(physval(*args, path=path))]
    edited.write_text(edited.read_text() + "\n# tuned\n")
    return counts + [_to_run(physval(*args, path=path))]


def test_an_adapter_module_that_changed_runs_its_jobs_again(tmp_path):
    """`--adapter module:Class` on the path: its source is part of the resume key, as a
    case file's is (before: the jobs were reused). The adapter wraps MuJoCo, whose jobs take
    milliseconds: on the reference, the first run compiled its sequential impulses into an
    empty numba cache (a fresh clone's), or waited for the process compiling them, which
    under a load of 12-15 on 2 cores outlasted the command's 300 s limit (measured: timed out)."""
    (tmp_path / "mine_engine.py").write_text(textwrap.dedent("""
        from adapters.mujoco_engine import MuJoCoAdapter

        class Mine(MuJoCoAdapter):
            name = "mujoco-mine"
    """))
    args = ["run", "--adapter", "mine_engine:Mine", "--engines", "mujoco-mine", "--cases", CASE,
            "--workers", "1", "--out", str(tmp_path / "out")]
    (n, first), (_, again), (_, edited) = _edited_rerun(args, tmp_path / "mine_engine.py", [tmp_path])
    assert n >= 1 and (first, again, edited) == (n, 0, n)


def test_an_installed_plugin_whose_code_changed_runs_its_jobs_again(site, tmp_path):
    """The entry-point plug-in's package source is part of the resume key: a change that
    keeps its version string runs its jobs again (before: they were reused)."""
    args = ["run", "--engines", ENGINE, "--cases", CASE, "--workers", "1", "--out", str(tmp_path / "out")]
    (n, first), (_, again), (_, edited) = _edited_rerun(args, site / "physval_engine_example" / "__init__.py", [site])
    assert n >= 1 and (first, again, edited) == (n, 0, n)
