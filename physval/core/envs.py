"""One environment per engine release, made once and cached (for `physval versions`).

An environment is a virtual environment (`python -m venv --system-site-packages`, this
interpreter's base) in `cache_dir()/envs/`, into which pip installs the engine's packages
at one release (`Adapter.release_requirements`): the release, and whatever of its
dependencies the machine's site packages do not satisfy, live in the environment's own
site-packages. It is made under a lock, checked (each pinned package imports at its
release) and then marked complete (physval-env.json); a folder without the mark is a
make that was cut short, and is made again. pip leaves a release the machine's site packages
already hold where it is; so each use checks again that the release is seen (0.3 s), and an
environment whose release has gone (the machine's was upgraded) is made again.

physval itself is not installed there. A run in the environment (`Env.command`, with
`Env.environ`) is given this process's import path (physval's own folder first) in
PHYSVAL_ENV_PATH, and a .pth file of the environment adds those folders behind the
environment's own site-packages. So the run imports the same physval (checkout or
installed wheel), the same numpy, the same cases and adapters as the command that started
it, except for the engine, whose release in the environment comes first. Installing
physval into the environment instead (`pip install --no-deps .`) would freeze the code as
it was when the environment was made: after an edit, a cached environment would run old
code. The run starts with `python -P` (no current folder on the path, so a checkout the
user stands in cannot shadow it) and without PYTHONPATH (whose folders would come before
the release; they are in PHYSVAL_ENV_PATH already).
"""
from __future__ import annotations

import contextlib
import hashlib
import json
import os
import re
import shutil
import subprocess
import sys
import sysconfig
import time
from dataclasses import dataclass, field
from pathlib import Path

from physval.core.store import cache_dir

MARK = "physval-env.json"
PTH = "physval-env.pth"
PATH_VARIABLE = "PHYSVAL_ENV_PATH"
# the .pth line: each folder of PHYSVAL_ENV_PATH as a site folder (its own .pth files too:
# editable installs), behind the environment's site-packages. site runs the line with exec()
# inside a function: a comprehension there would not see the names the line imports.
PTH_LINE = (f"import os, site; any(map(site.addsitedir, filter(None, os.environ.get({PATH_VARIABLE!r}, '')"
            ".split(os.pathsep))))\n")


class EnvError(RuntimeError):
    """An environment that cannot be made: one line (pip's last line, or what is wrong)."""


@dataclass(frozen=True)
class Interpreter:
    """A Python that makes an environment: this one (`foreign` False), or another."""
    path: Path
    version: str                  # its sys.version
    foreign: bool

    @property
    def short(self) -> str:
        return ".".join(self.version.split()[0].split(".")[:2])


def this_interpreter() -> Interpreter:
    return Interpreter(Path(os.path.realpath(sys.executable)), sys.version, False)


def interpreter(spec: str | None) -> Interpreter:
    """The Python that `spec` names: None, this one; "3.12", the `python3.12` on PATH; else a
    path to an interpreter (EnvError, one line, if there is none or it does not start)."""
    if spec is None:
        return this_interpreter()
    version = re.fullmatch(r"\d+\.\d+", spec)
    found = shutil.which(f"python{spec}") if version else shutil.which(spec) or spec
    if not found or not Path(found).exists():
        where = f"no python{spec} on PATH" if version else f"no interpreter at {spec}"
        raise EnvError(f"--python {spec}: {where}; name a Python 3.11-3.13 as a version (3.12) or an interpreter's "
                       "path")
    done = _run([found, "-c", "import os, sys; print(os.path.realpath(sys.executable)); print(sys.version)"])
    if done.returncode:
        raise EnvError(f"--python {spec}: {found} does not start: {_last_line(done)}")
    path, version = done.stdout.split("\n", 1)
    real = Path(path.strip())
    same = real == Path(os.path.realpath(sys.executable)) or version.strip() == sys.version
    return Interpreter(real, version.strip(), not same)


@dataclass(frozen=True)
class Env:
    path: Path
    requirements: tuple[str, ...]
    created: bool                 # made by this call; False: taken from the cache
    seconds: float                # how long making it took (when it was made)
    installed: dict = field(default_factory=dict)  # distribution -> version, in its own site-packages
    python: Interpreter = field(default_factory=this_interpreter)

    @property
    def executable(self) -> Path:
        return self.path / ("Scripts/python.exe" if os.name == "nt" else "bin/python")

    def command(self, *args: str) -> list[str]:
        """A command line run by the environment's interpreter."""
        return [str(self.executable), "-P", *args]

    def environ(self) -> dict[str, str]:
        """The process environment of a run: this one's, without PYTHONPATH and PYTHONHOME,
        with this process's import path in PHYSVAL_ENV_PATH (only physval's own folder on
        another Python)."""
        env = {k: v for k, v in os.environ.items() if k not in ("PYTHONPATH", "PYTHONHOME")}
        env[PATH_VARIABLE] = os.pathsep.join(import_path()[:1] if self.python.foreign else import_path())
        return env


def import_path() -> list[str]:
    """physval's own folder, then every folder of this process's sys.path."""
    root = str(Path(__file__).resolve().parents[2])
    path = [root] + [str(Path(p).resolve()) for p in sys.path if p and Path(p).exists()]
    return list(dict.fromkeys(path))


def folder(requirements, python: Interpreter | None = None) -> Path:
    """Where the environment of `requirements` lives: readable, and unique to them and to
    the interpreter that makes it (an environment is bound to it)."""
    python = python or this_interpreter()
    slug = "-".join(r.replace("==", "-") for r in requirements)
    key = json.dumps([list(requirements), python.version, str(python.path)])
    return cache_dir() / "envs" / f"{slug}-py{python.short.replace('.', '')}-" \
                                  f"{hashlib.sha256(key.encode()).hexdigest()[:8]}"


def own_requirements() -> list[str]:
    """physval's own requirements (its distribution's, without extras), which an environment
    on another Python installs beside the release."""
    from importlib import metadata
    try:
        wanted = metadata.requires("physval") or []
    except metadata.PackageNotFoundError:
        raise EnvError("physval is not installed (pip install -e .): its requirements, which an environment on "
                       "another Python needs, are read from its installed metadata") from None
    return [r.split(";")[0].strip() for r in wanted if "extra ==" not in r]


def _site_packages(path: Path, python: Interpreter | None = None) -> Path:
    """The environment's own site-packages (lib/pythonX.Y/site-packages of its Python)."""
    site = Path(sysconfig.get_path("purelib", "venv", vars={"base": str(path), "platbase": str(path)}))
    if python is not None and python.foreign and os.name != "nt":
        site = path / "lib" / f"python{python.short}" / "site-packages"
    return site


def _run(args, **kw) -> subprocess.CompletedProcess:
    return subprocess.run([str(a) for a in args], capture_output=True, text=True, **kw)


# What pip (urllib3) says when the index cannot be reached at all, and the part of it worth
# a user's eyes: "[Errno 111] Connection refused", "Temporary failure in name resolution".
UNREACHABLE = re.compile(r"(?:Failed to establish a new connection|NameResolutionError|ConnectTimeoutError|"
                         r"ProxyError|Network is unreachable)[^:]*:\s*([^'\")]+)")


def unreachable(output: str) -> str:
    """Why pip could not reach its index, from its output ("" if it could)."""
    found = UNREACHABLE.search(output)
    return found[1].strip() if found else ""


def _last_line(done: subprocess.CompletedProcess) -> str:
    lines = [x for x in (done.stderr + done.stdout).splitlines() if x.strip()]
    return lines[-1].strip() if lines else f"exit code {done.returncode}"


@contextlib.contextmanager
def _locked(path: Path):
    """Hold an exclusive lock on `path` (two commands making the same environment wait for
    each other; where fcntl is missing, no lock)."""
    path.parent.mkdir(parents=True, exist_ok=True)
    with open(path, "a") as fh:
        try:
            import fcntl
        except ImportError:
            yield
            return
        fcntl.flock(fh, fcntl.LOCK_EX)
        try:
            yield
        finally:
            fcntl.flock(fh, fcntl.LOCK_UN)


def _cached(path: Path, requirements: tuple[str, ...], python: Interpreter) -> Env | None:
    try:
        mark = json.loads((path / MARK).read_text())
    except (OSError, ValueError):
        return None
    env = Env(path, requirements, False, float(mark.get("seconds", 0.0)), mark.get("installed", {}), python)
    return env if tuple(mark.get("requirements", ())) == requirements and env.executable.exists() else None


def ensure(requirements, say=lambda text: None, python: Interpreter | None = None) -> Env:
    """The environment holding `requirements` (pip requirement strings, each `name==release`)
    for `python` (default: this interpreter): from the cache, or made now (EnvError if pip
    cannot install them)."""
    requirements = tuple(requirements)
    python = python or this_interpreter()
    path = folder(requirements, python)
    with _locked(path.with_name(path.name + ".lock")):
        env = _cached(path, requirements, python)
        if env is not None:
            try:  # an environment that took the release from the machine's site packages loses it
                _check(env, _site_packages(path, python))  # when the machine's release changes
                return env
            except EnvError as exc:
                say(f"{exc}: made again")
        say(f"making the environment of {' '.join(requirements)} in {path}")
        started = time.monotonic()
        shutil.rmtree(path, ignore_errors=True)  # a make cut short
        try:
            installed = _make(path, requirements, python)
        except BaseException:
            shutil.rmtree(path, ignore_errors=True)
            raise
        seconds = time.monotonic() - started
        mark = {"requirements": list(requirements), "installed": installed, "seconds": round(seconds, 2),
                "python": python.version.split()[0], "interpreter": str(python.path),
                "made": time.strftime("%Y-%m-%d %H:%M:%S")}
        (path / MARK).write_text(json.dumps(mark, indent=1))
        return Env(path, requirements, True, seconds, installed, python)


def _make(path: Path, requirements: tuple[str, ...], python: Interpreter) -> dict[str, str]:
    # this Python shares its site packages; another one installs physval's requirements too
    made = _run([python.path, "-m", "venv", *([] if python.foreign else ["--system-site-packages"]), path])
    if made.returncode:
        raise EnvError(f"cannot make a virtual environment in {path}: {_last_line(made)}")
    env = Env(path, requirements, True, 0.0, {}, python)
    extra = own_requirements() if python.foreign else []
    pip = _run([env.executable, "-m", "pip", "install", "--disable-pip-version-check", "--no-input", "--quiet",
                *requirements, *extra])
    if pip.returncode:
        offline = unreachable(pip.stderr + pip.stdout)
        if offline:  # pip's last line would blame the release ("No matching distribution found")
            raise EnvError(f"pip cannot reach the package index to install {' '.join(requirements)} ({offline}): "
                           "check the network connection or pip's index settings (`pip config list`), then run "
                           "the same command again")
        raise EnvError(f"pip cannot install {' '.join(requirements)}: {_last_line(pip)}")
    site = _site_packages(path, python)
    (site / PTH).write_text(PTH_LINE)
    return _check(env, site)


CHECK = """import json, sys
from importlib import metadata
import physval
print(json.dumps({"physval": physval.__file__, "pinned": {n: metadata.version(n) for n in sys.argv[2:]},
                  "own": {d.metadata["Name"]: d.version for d in metadata.distributions(path=[sys.argv[1]])
                          if d.metadata["Name"] not in ("pip", "setuptools")}}))"""


def _check(env: Env, site: Path) -> dict[str, str]:
    """A run in the environment (with this process's import path behind it) imports this
    physval and sees each pinned package at its release; return what the environment's own
    site-packages hold."""
    from packaging.requirements import Requirement
    pins = [Requirement(r) for r in env.requirements]
    done = _run(env.command("-c", CHECK, site, *[p.name for p in pins]), env=env.environ())
    if done.returncode:
        raise EnvError(f"the environment in {env.path} does not start: {_last_line(done)}")
    seen = json.loads(done.stdout)
    ours = Path(__file__).resolve().parents[1] / "__init__.py"
    if Path(seen["physval"]).resolve() != ours:
        raise EnvError(f"the environment in {env.path} imports physval from {seen['physval']}, not {ours}")
    for p in pins:
        if not p.specifier.contains(seen["pinned"][p.name], prereleases=True):
            raise EnvError(f"the environment in {env.path} sees {p.name} {seen['pinned'][p.name]}, not {p}")
    return dict(sorted(seen["own"].items()))
