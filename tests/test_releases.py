"""`physval versions ENGINE RELEASE ...`: bad input stops in one line before any environment
is made; an environment per release is made once and reused, holds the release, and runs
this checkout's physval; the whole command on a stand-in engine whose releases are those of
a tiny PyPI package (tests.fakes.ReleaseBallistic, iniconfig 1.1.1 and 2.0.0). The tests that
install are skipped when pip cannot reach the registry."""
from __future__ import annotations

import csv
import os
import subprocess
import sys
from pathlib import Path

import pytest

from physval.cli import main
from physval.core import envs

ROOT = Path(__file__).resolve().parent.parent
FAKE = ["--adapter", "tests.fakes:ReleaseBallistic"]
FREE_FALL = ["--cases", "conformance[free_fall_matches_discrete_closed_form,3D]"]


@pytest.fixture(scope="module")
def cache(tmp_path_factory):
    """One cache folder for this module's environments (made once, reused by the next test)."""
    with pytest.MonkeyPatch.context() as mp:
        folder = tmp_path_factory.mktemp("cache")
        mp.setenv("PHYSVAL_CACHE_DIR", str(folder))
        yield folder


@pytest.mark.parametrize("argv, message", [
    (["fake-release", "1.1.1", "3.0.0"], "iniconfig 3.0.0 is outside the supported range >=1.1.1,<3 of adapter "
                                         "fake-release"),
    (["fake-release", "1.0", "2.0.0"], "iniconfig 1.0 is outside the supported range"),
    # the package names the engine too (as `newton` names newton-xpbd, newton-vbd, ...)
    (["iniconfig", "1.1.1", "3.0.0"], "iniconfig 3.0.0 is outside the supported range >=1.1.1,<3 of adapter "
                                      "fake-release"),
    (["fake-release", "2.0.0"], "name at least two releases to compare"),
    (["fake-release", "2.0.0", "2.0"], "releases 2.0.0 2.0: each release once"),
    (["fake-release", "2.0.0", "latest"], "Invalid version: 'latest'"),
    (["reference", "0.1.0", "0.2.0"], "engine reference declares no releases of its own"),
    (["fake-release", "1.1.1", "2.0.0", "--engines", "mujoco"], "unknown engine 'mujoco': choose from fake-release"),
    (["fake-release", "1.1.1", "2.0.0", "--cases", "no_such_family"], "unknown case 'no_such_family'"),
    (["no-such-engine", "1.1.1", "2.0.0"], "unknown engine 'no-such-engine'"),
    (["fake-release", "1.1.1", "2.0.0@"], "release 2.0.0@: name a Python after @ (e.g. 2.0.0@3.12)"),
    (["fake-release", "1.1.1", "2.0.0@/no/such/python"], "--python /no/such/python: no interpreter at /no/such/python"),
    (["fake-release", "1.1.1", "2.0.0", "--python", "3.99"], "--python 3.99: no python3.99 on PATH"),
])
def test_bad_input_stops_before_any_environment(argv, message, capsys, tmp_path, monkeypatch):
    monkeypatch.setenv("PHYSVAL_CACHE_DIR", str(tmp_path / "cache"))
    assert main(["versions", *argv, *FAKE, "--out", str(tmp_path / "out")]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and message in err[0], err
    assert not (tmp_path / "cache").exists() and not (tmp_path / "out").exists()


def _ensure(requirements):
    try:
        return envs.ensure(requirements)
    except envs.EnvError as exc:
        if "pip cannot install" in str(exc) or "pip cannot reach" in str(exc):
            pytest.skip(str(exc))
        raise


def test_an_environment_is_made_once_and_runs_this_physval_with_its_release(cache):
    made = _ensure(["iniconfig==1.1.1"])
    assert made.created and made.installed == {"iniconfig": "1.1.1"}
    again = envs.ensure(["iniconfig==1.1.1"])
    assert not again.created and again.path == made.path and again.seconds == pytest.approx(made.seconds, abs=0.01)
    probe = ("import iniconfig, physval; from importlib.metadata import version; "
             "print(version('iniconfig'), physval.__file__)")
    done = subprocess.run(again.command("-c", probe), env=again.environ(), capture_output=True, text=True,
                          cwd=cache)
    assert done.returncode == 0, done.stderr
    release, where = done.stdout.split()
    assert release == "1.1.1" and Path(where) == ROOT / "physval" / "__init__.py"


def test_another_python_is_found_and_its_environment_sees_only_physvals_folder(monkeypatch):
    here = envs.interpreter(sys.executable)
    assert not here.foreign and here == envs.this_interpreter()
    other = envs.Interpreter(Path("/usr/bin/python3.99"), "3.99.0 (main)", True)
    assert envs.folder(["iniconfig==1.1.1"], other).name.startswith("iniconfig-1.1.1-py399-")
    assert envs.folder(["iniconfig==1.1.1"], other) != envs.folder(["iniconfig==1.1.1"])
    foreign = envs.Env(Path("/nowhere"), ("iniconfig==1.1.1",), False, 0.0, {}, other)
    assert foreign.environ()[envs.PATH_VARIABLE] == str(ROOT)  # no site folder of this Python's
    assert envs.Env(Path("/nowhere"), (), False, 0.0).environ()[envs.PATH_VARIABLE].count(os.pathsep) >= 1
    assert {r.split(">")[0] for r in envs.own_requirements()} >= {"numpy", "numba", "pandas"}


def _other_python():
    """A Python 3.11-3.13 other than this one, on PATH, or None."""
    for minor in (12, 13, 11):
        try:
            found = envs.interpreter(f"3.{minor}")
        except envs.EnvError:
            continue
        if found.foreign:
            return found
    return None


@pytest.mark.slow  # installs physval's requirements (numpy, scipy, pandas, numba...) for another Python
def test_a_release_on_another_python_runs_this_physval(cache):
    other = _other_python()
    if other is None:
        pytest.skip("no other Python 3.11-3.13 on PATH")
    try:
        made = envs.ensure(["iniconfig==1.1.1"], python=other)
    except envs.EnvError as exc:
        pytest.skip(str(exc))
    probe = "import sys, iniconfig, physval, numpy; print(sys.version.split()[0], physval.__file__)"
    done = subprocess.run(made.command("-c", probe), env=made.environ(), capture_output=True, text=True, cwd=cache)
    assert done.returncode == 0, done.stderr
    version, where = done.stdout.split()
    assert version.startswith(other.short) and Path(where) == ROOT / "physval" / "__init__.py"


def test_a_make_cut_short_is_made_again(cache):
    made = _ensure(["iniconfig==1.1.1"])
    (made.path / envs.MARK).unlink()  # as a kill during pip would leave it
    again = envs.ensure(["iniconfig==1.1.1"])
    assert again.created and (again.path / envs.MARK).is_file()


def test_versions_runs_each_release_and_compares_them(cache, tmp_path, capfd):
    argv = ["versions", "fake-release", "2.0.0", "1.1.1", *FAKE, *FREE_FALL, "--out", str(tmp_path), "--workers", "1",
            "--save-trajectories"]
    code = main(argv)
    if code == 2 and "pip cannot install" in capfd.readouterr().err:
        pytest.skip("pip cannot reach the registry")
    assert code == 1  # from 2.0 the stand-in's gravity is 0.1 % strong
    out = tmp_path / "fake-release"
    for release in ("1.1.1", "2.0.0"):
        rows = list(csv.DictReader(open(out / release / "results.csv")))
        assert {r["engine_version"] for r in rows} == {release}
    changes = {r["metric"]: r for r in csv.DictReader(open(out / "compare" / "1.1.1-vs-2.0.0" / "compare.csv"))}
    assert changes["discrete_error"]["change"] == "status"
    assert (changes["discrete_error"]["status_a"], changes["discrete_error"]["status_b"]) == ("pass", "fail")
    assert changes["continuous_error"]["direction"] == "away"
    parts = (out / "compare" / "1.1.1-vs-2.0.0" / "compare.md").read_text().split("## Trajectories")[1]
    # they part in the first step, in the velocity (symplectic Euler: velocity first, then position)
    assert "1 part" in parts and "|               1 |    0.001 | body velocity[2] |" in parts
    report = (out / "versions.md").read_text()
    assert "| 1.1.1 | 2.0.0 |                2 |" in report  # both free-fall checks fail from 2.0
    assert "| 1 of 1 jobs, first at 0.001 s |" in report
    capfd.readouterr()
    assert main(argv) == 1  # again: both environments and every job reused
    said = capfd.readouterr()  # the runs' own lines too (they are processes of their own)
    assert said.out.count("0 runs now, 1 reused") == 2 and said.err.count("environment from the cache") == 2
    assert "from the cache" in (out / "versions.md").read_text()


def test_a_run_that_reports_another_release_stops_the_command(cache, tmp_path, capfd, monkeypatch):
    """The guard behind every run: an environment that ran a release other than the one it
    was made for (here: 1.1.1's, handed out for 2.0.0) stops the command, exit 2."""
    old = _ensure(["iniconfig==1.1.1"])
    monkeypatch.setattr(envs, "ensure", lambda requirements, say=None, python=None: old)
    argv = ["versions", "fake-release", "1.1.1", "2.0.0", *FAKE, *FREE_FALL, "--out", str(tmp_path), "--quiet",
            "--workers", "1"]
    assert main(argv) == 2
    assert "fake-release/2.0.0 reports fake-release '1.1.1', not release 2.0.0" in capfd.readouterr().err
    assert not (tmp_path / "fake-release" / "versions.md").exists()


def test_an_index_pip_cannot_reach_is_named_as_the_network(tmp_path, capsys, monkeypatch):
    """pip pointed at a port where nothing listens (as a machine offline): the line names
    the network and what pip met, not a release that does not exist (before: "No matching
    distribution found for iniconfig==1.1.1")."""
    (tmp_path / "no-wheels").mkdir()
    for name, value in {"PIP_CONFIG_FILE": "/dev/null", "PIP_INDEX_URL": "http://127.0.0.1:9/simple",
                        "PIP_EXTRA_INDEX_URL": "", "PIP_FIND_LINKS": str(tmp_path / "no-wheels"), "PIP_RETRIES": "1",
                        "PIP_DEFAULT_TIMEOUT": "5", "PHYSVAL_CACHE_DIR": str(tmp_path / "cache")}.items():
        monkeypatch.setenv(name, value)
    assert main(["versions", "fake-release", "1.1.1", "2.0.0", *FAKE, "--quiet", "--out", str(tmp_path / "out")]) == 2
    (line,) = capsys.readouterr().err.strip().splitlines()
    assert line.startswith("physval: error: pip cannot reach the package index to install iniconfig==1.1.1 ("), line
    assert "Connection refused" in line and "check the network connection" in line, line


def test_a_site_packages_on_the_import_path_is_installed_code_not_the_users(tmp_path, monkeypatch):
    """A run in a release environment sees the machine's site-packages through the
    environment's .pth file (physval.core.envs), a folder the environment's own Python does
    not list as its site-packages. Its modules are installed code: the cache key of a user's
    adapter takes the user's own modules only, not every installed module they import
    (before: 2900 modules of numpy, scipy, pandas... parsed, 38-80 s in every run there)."""
    from physval.core import store
    site = tmp_path / "lib" / "site-packages"
    (site / "heavy").mkdir(parents=True)
    (site / "heavy" / "__init__.py").write_text("import heavy.part\n")
    (site / "heavy" / "part.py").write_text("")
    user = tmp_path / "mine"
    user.mkdir()
    (user / "helper.py").write_text("import heavy\n")
    (user / "my_adapter.py").write_text("import helper\nimport heavy.part\n")
    monkeypatch.setattr(sys, "path", [str(user), str(site), *sys.path])
    store._installed_folders.cache_clear()
    try:
        found = {f.name for f in store.user_sources([user / "my_adapter.py"])}
    finally:
        store._installed_folders.cache_clear()
    assert found == {"my_adapter.py", "helper.py"}


@pytest.mark.parametrize("extra, forwarded", [([], False), (["--on-demand"], True)])
def test_on_demand_reaches_each_releases_run(extra, forwarded, tmp_path):
    """Newton's solvers run their families beyond the core ones on demand: without
    --on-demand reaching each release's `physval run`, a reading across releases would leave
    them out."""
    from physval.cli import parser
    from physval.commands.versions import run_command
    argv = ["versions", "drake", "1.51.1", "1.58.0@3.12", "--engines", "drake-cenic", *extra]
    words = run_command(parser(argv).parse_args(argv), ["drake-cenic"], tmp_path)
    assert ("--on-demand" in words) is forwarded and words[:3] == ["-m", "physval", "run"]
