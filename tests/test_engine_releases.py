"""On demand (`pytest -m slow tests/test_engine_releases.py`): the conformance battery on the
oldest and the newest release of each engine's package that its adapter supports
(`Adapter.supported`, the range the lower bounds of pyproject.toml repeat), each installed
with pip into a virtual environment of its own. The environment sees this interpreter's
site-packages (`venv --system-site-packages`), so only the engine is installed, and its
release shadows the one installed here (the newest in range is taken with --upgrade: an
older one installed here does not satisfy it); the battery runs from this repository's folder.

PHYSVAL_RELEASES="mujoco==3.4.0 mujoco==3.12.0" names other requirements (of the engines'
packages). A release pip cannot install (no registry in reach, no wheel for this Python)
is skipped with pip's last line.
"""
from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

import pytest
from packaging.requirements import Requirement
from packaging.specifiers import SpecifierSet

from adapters.registry import EngineError, engine_names, get

pytestmark = pytest.mark.slow
ROOT = Path(__file__).resolve().parent.parent


def _releases() -> list[tuple[str, str]]:
    """(engine, pip requirements) of the releases to test: for each engine whose adapter
    declares a range (one engine per package), the oldest supported and the newest on the
    registry inside the range, unless PHYSVAL_RELEASES names requirements."""
    adapters = {}
    for name in engine_names():
        try:
            a = get(name)
        except EngineError:  # an adapter imports only with its engine installed
            continue
        if a.supported and a.package not in {x.package for x in adapters.values()}:
            adapters[name] = a
    named = os.environ.get("PHYSVAL_RELEASES", "").split()
    if named:
        by_package = {a.package: n for n, a in adapters.items()}
        return [(by_package[Requirement(r).name], r) for r in named if Requirement(r).name in by_package]
    out = []
    for name, a in adapters.items():
        (oldest,) = [s.version for s in SpecifierSet(a.supported) if s.operator == ">="]
        # the oldest as `physval versions` installs it (MuJoCo Warp with the MuJoCo of its release)
        out += [(name, " ".join(a.release_requirements(oldest))), (name, f"{a.package}{a.supported}")]
    return out


def _run(args, **kw) -> subprocess.CompletedProcess:
    return subprocess.run(args, capture_output=True, text=True, **kw)


@pytest.mark.parametrize("engine, requirement", _releases())
def test_the_conformance_battery_passes_on_the_release(engine, requirement, tmp_path):
    venv = tmp_path / "venv"
    _run([sys.executable, "-m", "venv", "--system-site-packages", str(venv)], check=True)
    python = str(venv / "bin" / "python")
    pip = _run([python, "-m", "pip", "install", "--quiet", "--upgrade", "--disable-pip-version-check",
                *requirement.split()])
    if pip.returncode:
        pytest.skip(f"pip cannot install {requirement}: {(pip.stderr.strip().splitlines() or ['?'])[-1]}")
    engine_requirement = Requirement(requirement.split()[0])  # its partners are pinned beside it
    package = engine_requirement.name
    installed = _run([python, "-c", f"from importlib.metadata import version; print(version({package!r}))"],
                     cwd=ROOT, check=True).stdout.strip()
    assert engine_requirement.specifier.contains(installed, prereleases=True)  # the venv's own release
    battery = _run([python, "-m", "pytest", "-n", "0", "-q", "-p", "no:cacheprovider", "tests/test_cases.py",
                    "-k", "test_conformance", "--engine", engine], cwd=ROOT)
    summary = (battery.stdout.strip().splitlines() or [""])[-1]
    assert battery.returncode == 0 and " passed" in summary, f"{package} {installed}:\n{battery.stdout[-3000:]}"
