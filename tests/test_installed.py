"""physval as a user meets it: the wheel built from this checkout, installed into a fresh
virtual environment, run from a folder outside the repository through the `physval`
console script. Every command line the README, the documentation's pages (docs/) and the
plug-in example's README show is run as written; a command whose full run takes minutes or
hours is narrowed only by options appended to it (fewer engines, fewer cases, a shorter
fit), never rewritten, and one that still costs more than its share of the suite runs with
`pytest -m slow` (Narrowed.slow says why). A shown line that this file does not know fails
the first test, so the documentation cannot grow a command nobody ran.

The environment sees the site packages of the environment the tests run in (the engines and
numpy, which pip would otherwise download again; in a virtual environment, as the README's
test command makes one, those are the virtual environment's) but imports physval, cases,
adapters and reference_impl from the wheel alone: the first test checks where they come from.
It also sees the session's numba cache folder ($NUMBA_CACHE_DIR, tests/conftest.py), so the
wheel's reference_impl, the same text as the checkout's, loads what the session compiled
rather than compiling it a second time; `physval bench compile` still compiles cold (in a
cache folder of its own), and the reference_impl tests show that copies share one folder.
"""
from __future__ import annotations

import os
import re
import shlex
import shutil
import signal
import socket
import subprocess
import sys
import time
from dataclasses import dataclass
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parent.parent
README = ROOT / "README.md"
DOCS = sorted((ROOT / "docs").rglob("*.md"))
FIRST_CASE = ROOT / "docs" / "extend" / "first_case.md"  # the README's own case example, second_bounce
EXAMPLE = ROOT / "examples" / "physval-engine-example"
PACKAGES = ("physval", "cases", "adapters", "reference_impl")


@dataclass(frozen=True)
class Narrowed:
    """How the test runs one README line: `extra` options appended to it (a full run takes
    minutes); `after` a README line whose output it reads; `where` the folder it runs in
    ("user": the user's folder; "example": a copy of the plug-in example)."""
    extra: str = ""
    after: str = ""
    where: str = "user"
    needs: tuple[str, ...] = ()  # engines it runs on (skipped if one is not installed here)
    slow: str = ""  # why the line runs with `pytest -m slow` only (it costs more than its share of the suite)


REAL_QUICK = "--engines mujoco --limit 2 --horizon 0.15 --generations 0 --popsize 2 --bootstrap 10"
NARROWED = {
    # README: useful commands
    "physval list": Narrowed(),
    "physval list --engines": Narrowed(),
    "physval run --cases central_impact --engines reference,mujoco": Narrowed(needs=("mujoco",)),
    'physval run --cases "incline_threshold[mu=0.5*]" --dt 5e-3 --out /tmp/incline': Narrowed("--engines reference"),
    'physval run --cases "central_impact[e=0.5,m=1:3]"': Narrowed("--engines reference pybullet", needs=("pybullet",)),
    "physval run --help": Narrowed(),
    "physval run --scheduler tcp://127.0.0.1:8786": Narrowed('--cases "central_impact[e=0.5,m=1:3]" --engines reference'),
    # known deviations
    "physval known mujoco": Narrowed('--cases "central_impact[drop,e=0.5]"', needs=("mujoco",)),
    "physval known 'drake-*' --write": Narrowed('--cases "central_impact[drop,e=0.5]"', needs=("drake",)),
    # a user's case family
    "physval check-case my_cases/second_bounce.py": Narrowed(),
    "physval run --cases-dir my_cases --cases second_bounce --engines reference,pybullet": Narrowed(needs=("pybullet",)),
    "physval run --cases-dir my_cases --cases second_bounce --save-trajectories traj/": Narrowed("--engines reference"),
    # sweeps, stress, benchmarks
    "physval sweep": Narrowed('--cases "central_impact[drop,e=0.5]" --engines mujoco --repeats 1', needs=("mujoco",)),
    "physval sweep --cases incline_threshold --engines reference,mujoco --workers 2": Narrowed("--repeats 1",
                                                                                             needs=("mujoco",)),
    "physval sweep --cases \"incline_threshold[mu=0.5,theta=atan(mu_s)-1deg]\" --engines "
    "'mujoco,mujoco-defaults,pybullet,pybullet-dantzig,pybullet-pgs'": Narrowed("--repeats 1",
                                                                             needs=("mujoco", "pybullet")),
    "physval stress": Narrowed('--cases "robustness_overlap[box_in_ground,3D]" --engines mujoco --no-map',
                               needs=("mujoco",)),
    "physval stress --long": Narrowed('--cases "robustness_overlap[box_in_ground,3D]" --engines mujoco --no-map',
                                      needs=("mujoco",)),
    "physval bench": Narrowed("overhead --engines mujoco", needs=("mujoco",)),
    "physval bench overhead": Narrowed("--engines mujoco", needs=("mujoco",)),
    "physval bench step": Narrowed("--engines mujoco", needs=("mujoco",)),
    "physval bench sweep-workers": Narrowed("--engines mujoco", needs=("mujoco",)),
    "physval bench pgs": Narrowed(),
    "physval bench compile": Narrowed("--engines reference-hooke", slow=(
        "a cold compile of the reference's step in a numba cache of its own, by design: 82 CPU-s of the "
        "suite's budget for one line; the other lines run the wheel's reference from the session's cache")),
    "physval bench narrow": Narrowed("--engines mujoco", needs=("mujoco",)),
    "physval bench faults": Narrowed('--engines mujoco --cases "central_impact[drop,e=0.5]"', needs=("mujoco",)),
    "physval bench run": Narrowed('--engines mujoco --cases "central_impact[drop,e=0.5]"', needs=("mujoco",)),
    "physval bench run --engines mujoco,pybullet --cases central_impact": Narrowed(needs=("mujoco", "pybullet")),
    # the invariance battery (docs/measure/invariance.md)
    "physval run": Narrowed('--cases "central_impact[drop,e=0.5]" --engines reference'),
    "physval run --cases slide_to_stop --relations all": Narrowed("--engines reference"),
    'physval run --cases "stack_forces[n=4*]" --relations rotate_vertical,body_order --engines mujoco': Narrowed(
        needs=("mujoco",)),
    # a run's predicted cost (nothing is run)
    "physval run --plan": Narrowed(),
    "physval run --plan --cases creep --engines 'reference-*' --workers 2": Narrowed(),
    # an engine's CI gate (exit 1 only if a check falls under --fail-on)
    "physval run --engines mujoco --junitxml physval.xml --fail-on fail,error,unstable,changed": Narrowed(
        '--cases "central_impact[drop,e=0.5]"', needs=("mujoco",)),
    # comparing runs and releases (the same code twice: compare exits 0; central impact is
    # identical to the last bit on MuJoCo 3.11.0, 3.12.0 and 4.0.0: versions exits 0)
    "physval run --cases central_impact --engines reference,mujoco --out before": Narrowed(
        '--cases "central_impact[drop,e=0.5]" --engines reference'),
    "physval run --cases central_impact --engines reference,mujoco --out after": Narrowed(
        '--cases "central_impact[drop,e=0.5]" --engines reference',
        after="physval run --cases central_impact --engines reference,mujoco --out before"),
    "physval compare before after": Narrowed(
        after="physval run --cases central_impact --engines reference,mujoco --out after"),
    "physval versions mujoco 3.11.0 3.12.0 4.0.0 --cases resting_blocks stack_strike --save-trajectories": Narrowed(
        '--cases "central_impact[drop,e=0.5]" --engines mujoco', needs=("mujoco",)),
    # an engine and its port (MuJoCo Warp compiles its kernels once into physval's cache folder)
    "physval parity mujoco mujoco-warp --cases central_impact resting_blocks --workers 2": Narrowed(
        '--cases "central_impact[e=1.0,m=1:1]"', needs=("mujoco", "mujoco-warp")),
    # the real-world tier
    "physval real": Narrowed(REAL_QUICK, needs=("mujoco",)),
    # docs/measure/real_elbow.md: the articulated data set
    "physval real --data elbow_toss": Narrowed(REAL_QUICK, needs=("mujoco",)),
    "physval real --data elbow_toss --engines mujoco --nominal --limit 20": Narrowed("--limit 2", needs=("mujoco",)),
    "physval real --tosses my_tosses.csv --params reports/real/params.json": Narrowed("--engines mujoco",
                                                                                     after="physval real",
                                                                                     needs=("mujoco",)),
    # docs/extend/writing_cases.md: its worked family (my_cases/pair_drop.py) and --known file
    "physval check-case my_cases/pair_drop.py": Narrowed(),
    "physval run --cases-dir my_cases --cases pair_drop --engines reference,pybullet,dart,pymunk,mujoco": Narrowed(
        needs=("pybullet", "dart", "pymunk", "mujoco")),
    "physval run --cases-dir my_cases --cases 'pair_drop[e=0.9*]' --engines reference,mujoco "
    "--save-trajectories traj/": Narrowed(needs=("mujoco",)),
    "physval known mujoco --file my_known.txt --cases-dir my_cases --write": Narrowed(needs=("mujoco",)),
    "physval run --cases-dir my_cases --cases pair_drop --engines reference,mujoco --known my_known.txt": Narrowed(
        after="physval known mujoco --file my_known.txt --cases-dir my_cases --write", needs=("mujoco",)),
    # docs/extend/adding_an_engine.md: a fault of the user's own planted ad hoc (my_faults.py)
    "physval run --adapter my_faults.py:reference_strong_gravity --engines reference,reference-strong-gravity "
    "--cases conformance": Narrowed(),
    # the plug-in example's README (after its `pip install`)
    "pip install ./examples/physval-engine-example": Narrowed(where="repo"),
    "physval run --cases central_impact --engines mujoco,mujoco-soft": Narrowed(
        after="pip install ./examples/physval-engine-example", needs=("mujoco",)),
    "physval known mujoco-soft --file physval_engine_example/xfails/mujoco-soft.txt --write": Narrowed(
        '--cases "central_impact[drop,e=0.5]"', after="pip install ./examples/physval-engine-example",
        where="example", needs=("mujoco",)),
}
# lines the README shows that start processes of other programs (the Dask cluster the
# --scheduler line runs on is started by the test itself, as the README says)
NOT_PHYSVAL = ("dask scheduler", "dask worker")


def readme_lines(path: Path) -> list[str]:
    """The command lines of a page's indented code blocks, without trailing comments: a
    line ending in a backslash goes on in the next, and an option in square brackets
    (`[--adapter module:Class]`) is the page's way to say it is optional, so it is left out."""
    text = re.sub(r"\\\n\s*", "", path.read_text())
    lines = []
    for raw in re.findall(r"^ {4,}((?:physval|pip install|dask) .*)$", text, re.M):
        line = re.sub(r"\s+#.*$", "", raw)
        line = re.sub(r" \[--[^\]]*\]", "", line).strip().rstrip("&").strip()
        lines.append(line)
    return list(dict.fromkeys(lines))


ALL_LINES = list(dict.fromkeys(line for page in (README, *DOCS, EXAMPLE / "README.md") for line in readme_lines(page)))


def test_every_readme_command_is_run_here():
    unknown = [line for line in ALL_LINES if line not in NARROWED and not line.startswith(NOT_PHYSVAL)]
    assert not unknown, f"README commands this file does not run: {unknown}"
    gone = [line for line in NARROWED if line not in ALL_LINES]
    assert not gone, f"lines no README shows any more: {gone}"


# --- the installed product -------------------------------------------------------------------

@dataclass
class Installed:
    venv: Path
    user: Path      # a folder outside the repository, with the user's files
    env: dict
    wheel: Path

    def bin(self, name: str) -> str:
        return str(self.venv / "bin" / name)


def _sh(args, **kw) -> subprocess.CompletedProcess:
    return subprocess.run(args, capture_output=True, text=True, **kw)


@pytest.fixture(scope="module")
def installed(tmp_path_factory) -> Installed:
    base = tmp_path_factory.mktemp("installed")
    wheels = base / "wheels"
    # built from a copy of the source: setuptools builds in build/ beside pyproject.toml, and two
    # test workers building in the checkout at once collide there ("File exists"); the copy also
    # leaves the checkout without a build/ that a user's later `pip install .` would reuse
    source = base / "source"
    shutil.copytree(ROOT, source, ignore=shutil.ignore_patterns(".git", ".venv", "build", "*.egg-info",
                                                                "__pycache__", "reports", ".pytest_cache"))
    built = _sh([sys.executable, "-m", "pip", "wheel", "--no-deps", "-q", "-w", str(wheels), str(source)])
    assert built.returncode == 0, built.stderr[-2000:]
    (wheel,) = wheels.glob("physval-*.whl")
    venv = base / "venv"
    _environment_beside_this_one(venv)
    inst = _sh([str(venv / "bin" / "pip"), "install", "-q", "--no-deps", "--ignore-installed", str(wheel)])
    assert inst.returncode == 0, inst.stderr[-2000:]
    user = base / "user"
    user.mkdir()
    env = {k: v for k, v in os.environ.items() if k not in ("PYTHONPATH", "PYTHONHOME")}
    env |= {"PHYSVAL_CACHE_DIR": str(base / "cache"), "MPLBACKEND": "Agg", "PATH": f"{venv / 'bin'}:{env['PATH']}"}
    _user_files(user)
    return Installed(venv, user, env, wheel)


def _environment_beside_this_one(venv: Path) -> None:
    """A fresh virtual environment that sees this test run's own site packages behind its
    own, through a .pth file listing them. `venv --system-site-packages` would expose the
    base interpreter's packages instead, and inside a virtual environment (the README's
    way, and the only way pip installs on Debian 12 or Ubuntu 24.04) those lack numpy, pandas
    and the engines. The folders are listed as plain paths, so their own .pth files (an
    editable install of this checkout among them) are not run: physval, cases, adapters and
    reference_impl can come from the wheel alone."""
    assert _sh([sys.executable, "-m", "venv", str(venv)]).returncode == 0
    import site
    import sysconfig
    ours = site.getsitepackages() + ([site.getusersitepackages()] if site.ENABLE_USER_SITE else [])
    ours += [sysconfig.get_path("purelib"), sysconfig.get_path("platlib")]
    folders = [p for p in dict.fromkeys(ours) if Path(p).is_dir()]
    where = _sh([str(venv / "bin" / "python"), "-c", "import sysconfig; print(sysconfig.get_path('purelib'))"])
    assert where.returncode == 0, where.stderr
    (Path(where.stdout.strip()) / "physval-tests-beside.pth").write_text("".join(f"{p}\n" for p in folders))


def _user_files(user: Path) -> None:
    """What the shown commands expect in the user's folder: the worked example families
    (docs/extend/first_case.md's, and writing_cases.md's with its --known file), the planted
    fault of adding_an_engine.md (my_faults.py), and a toss
    file of the packaged data's columns (three measured tosses)."""
    from tests.guide import write_example, write_known
    (code,) = re.findall(r"```python\n(# my_cases/second_bounce.py\n.*?)```", FIRST_CASE.read_text(), re.S)
    (user / "my_cases").mkdir()
    (user / "my_cases" / "second_bounce.py").write_text(code)
    write_example(user)
    write_known(user)
    from tests.test_planting import users_file
    users_file(user)
    import pandas as pd
    data = pd.read_csv(ROOT / "cases" / "data" / "cube_toss" / "cube_tosses.csv.gz")
    data[data.toss.isin([1, 3, 5])].to_csv(user / "my_tosses.csv", index=False)


def test_the_environment_imports_physval_from_the_wheel(installed):
    probe = ("import importlib, json, sys; "
             "print(json.dumps({n: importlib.import_module(n).__file__ for n in sys.argv[1:]}))")
    done = _sh([installed.bin("python"), "-c", probe, *PACKAGES], cwd=installed.user, env=installed.env)
    assert done.returncode == 0, done.stderr
    import json
    for name, file in json.loads(done.stdout).items():
        assert file.startswith(str(installed.venv)), f"{name} imported from {file}, not from the installed wheel"
    version = _sh([installed.bin("physval"), "--version"], cwd=installed.user, env=installed.env)
    assert version.returncode == 0 and re.fullmatch(r"physval \d+\.\d+\.\d+\S*\n", version.stdout), version


def _missing_engines(installed: Installed, names) -> list[str]:
    """Those of `names` the environment lacks; asked of it once, for every engine a shown
    line needs (a probe is an interpreter importing the registry: 0.3 CPU-s, each test paid one)."""
    ask = [n for n in dict.fromkeys([*(e for how in NARROWED.values() for e in how.needs), *names])
           if n not in _installed_engines]
    if ask:
        probe = "import sys; from adapters.registry import available; print(' '.join(n for n in sys.argv[1:] if not available(n)))"
        done = _sh([installed.bin("python"), "-c", probe, *ask], cwd=installed.user, env=installed.env)
        assert done.returncode == 0, done.stderr[-2000:]
        missing = set(done.stdout.split())
        _installed_engines.update({n: n not in missing for n in ask})
    return [n for n in names if not _installed_engines[n]]


_installed_engines: dict[str, bool] = {}  # engine -> whether the environment has it (_missing_engines)


def _run_line(installed: Installed, line: str, tmp: Path) -> subprocess.CompletedProcess:
    how = NARROWED[line]
    if how.after and how.after not in _done:
        _run_line(installed, how.after, tmp)
    words = shlex.split(line) + shlex.split(how.extra)
    words = [w.replace("/tmp/", f"{tmp}/") for w in words]
    if how.where == "repo":  # `pip install ./examples/...`: from the repository, into the environment
        cwd, words = ROOT, [installed.bin("pip"), *words[1:], "-q"]
    elif how.where == "example":
        cwd = tmp / "example"
        if not cwd.exists():
            shutil.copytree(EXAMPLE, cwd, ignore=shutil.ignore_patterns("build", "*.egg-info"))
    else:
        cwd = installed.user
    if words[0] == "physval":
        words[0] = installed.bin("physval")
    if (tuple(words), str(cwd)) in _ran:
        _done.add(line)
        return _ran[(tuple(words), str(cwd))]
    if line.startswith("physval run --scheduler"):
        with _dask_cluster(installed) as address:
            words[words.index("tcp://127.0.0.1:8786")] = address
            done = _sh(words, cwd=cwd, env=installed.env, timeout=600)
    else:
        done = _sh(words, cwd=cwd, env=installed.env, timeout=900)
    _done.add(line)
    _ran[(tuple(words), str(cwd))] = done
    shutil.rmtree(ROOT / "examples" / "physval-engine-example" / "build", ignore_errors=True)
    return done


_done: set[str] = set()
# What each command, as run, gave: two shown lines that narrow to the same command in the same
# folder (`physval bench`, narrowed to its overhead benchmark, and `physval bench overhead`)
# run it once, and the second line's test reads the same outcome
_ran: dict[tuple[tuple[str, ...], str], subprocess.CompletedProcess] = {}


@pytest.mark.parametrize("line", [pytest.param(line, marks=[pytest.mark.slow] if NARROWED[line].slow else [])
                                  for line in ALL_LINES if line in NARROWED])
def test_a_readme_command_works_from_the_installed_wheel(installed, line, tmp_path):
    missing = _missing_engines(installed, NARROWED[line].needs)
    if missing:
        pytest.skip(f"not installed here: {', '.join(missing)}")
    done = _run_line(installed, line, tmp_path)
    said = f"`{line}` {NARROWED[line].extra}: exit {done.returncode}\n{done.stdout[-1500:]}\n{done.stderr[-3000:]}"
    assert done.returncode == 0, said
    assert "Traceback" not in done.stderr, said
    if "--plan" in line:  # a prediction: one row per engine and a total, nothing written
        assert "predicted" in done.stdout.lower() and "wrote " not in done.stdout, said
    elif line.startswith("physval run ") and "--help" not in line:
        assert "wrote " in done.stdout, said
        if "--save-trajectories" in line:
            assert list((installed.user / "traj").glob("*.npz")), said
    if line == "physval real":
        assert (installed.user / "reports" / "real" / "params.json").is_file(), said
    if line.startswith("physval run --cases central_impact --engines mujoco,mujoco-soft"):
        assert "mujoco-soft" in done.stdout + done.stderr or (installed.user / "reports" / "results.csv").is_file()


class _dask_cluster:
    """The README's Dask cluster, started from the environment on a free port of this
    machine, and stopped after."""

    def __init__(self, installed: Installed):
        self.installed = installed

    def __enter__(self) -> str:
        with socket.socket() as s:
            s.bind(("127.0.0.1", 0))
            port = s.getsockname()[1]
        address = f"tcp://127.0.0.1:{port}"
        run = dict(cwd=self.installed.user, env=self.installed.env, stdout=subprocess.DEVNULL,
                   stderr=subprocess.DEVNULL, start_new_session=True)
        dask = [self.installed.bin("python"), "-m", "dask"]  # the environment's own interpreter
        self.procs = [subprocess.Popen([*dask, "scheduler", "--host", "127.0.0.1", "--port", str(port),
                                        "--no-dashboard"], **run)]
        self.procs.append(subprocess.Popen([*dask, "worker", address, "--nworkers", "1", "--nthreads", "1",
                                            "--no-dashboard"], **run))
        deadline = time.monotonic() + 60
        while time.monotonic() < deadline:
            with socket.socket() as s:
                if s.connect_ex(("127.0.0.1", port)) == 0:
                    break
            time.sleep(0.2)
        time.sleep(2)  # the worker registers with the scheduler
        return address

    def __exit__(self, *exc):
        for p in self.procs:
            try:
                os.killpg(p.pid, signal.SIGTERM)
            except ProcessLookupError:
                pass
        for p in self.procs:
            try:
                p.wait(10)
            except subprocess.TimeoutExpired:
                os.killpg(p.pid, signal.SIGKILL)


def test_the_engine_ci_example_gates_on_the_plug_in(installed, tmp_path):
    """The plug-in example's CI script, as its workflow runs it: install physval (here the
    wheel), install the plug-in, run the battery with --junitxml and --fail-on."""
    if _missing_engines(installed, ("mujoco",)):
        pytest.skip("MuJoCo is not installed here")
    example = tmp_path / "engine-repo"
    shutil.copytree(EXAMPLE, example, ignore=shutil.ignore_patterns("build", "*.egg-info", "physval-out"))
    env = installed.env | {"PHYSVAL": str(installed.wheel), "CASES": "conformance central_impact"}
    done = _sh(["bash", "ci/battery.sh"], cwd=example, env=env, timeout=900)
    assert done.returncode == 0, done.stdout[-2000:] + done.stderr[-3000:]
    import csv
    import xml.etree.ElementTree as ET
    rows = list(csv.DictReader(open(example / "physval-out" / "results.csv")))
    root = ET.parse(example / "physval-out" / "physval.xml").getroot()
    assert int(root.get("tests")) == len(rows) > 0 and {r["engine"] for r in rows} == {"mujoco-soft"}
