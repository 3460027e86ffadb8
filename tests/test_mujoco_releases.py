"""On demand (`pytest -m slow tests/test_mujoco_releases.py`): the conformance battery on the
oldest and the newest MuJoCo release the adapter supports (`MuJoCoAdapter.supported`), each
installed with pip into a virtual environment of its own. The environment sees this
interpreter's site-packages (`venv --system-site-packages`), so only MuJoCo is installed, and
its MuJoCo shadows any installed here (the newest in range is taken with --upgrade: an older one
installed here does not satisfy it); the battery runs from this repository's folder.

PHYSVAL_MUJOCO_RELEASES="3.4.0 3.12.0" names other releases. A release pip cannot install
(no registry in reach, no wheel for this Python) is skipped with pip's last line.
"""
from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

import pytest
from packaging.requirements import Requirement
from packaging.specifiers import SpecifierSet

from adapters.registry import EngineError, get

pytestmark = pytest.mark.slow
ROOT = Path(__file__).resolve().parent.parent


def _releases() -> list[str]:
    """pip requirements of the releases to test: the oldest supported and the newest on the
    registry inside the range, unless PHYSVAL_MUJOCO_RELEASES names them."""
    named = os.environ.get("PHYSVAL_MUJOCO_RELEASES", "").split()
    if named:
        return [f"mujoco=={r}" for r in named]
    try:
        supported = get("mujoco").supported
    except EngineError:  # the adapter imports only with MuJoCo installed
        return []
    (oldest,) = [s.version for s in SpecifierSet(supported) if s.operator == ">="]
    return [f"mujoco=={oldest}", f"mujoco{supported}"]


def _run(args, **kw) -> subprocess.CompletedProcess:
    return subprocess.run(args, capture_output=True, text=True, **kw)


@pytest.mark.parametrize("requirement", _releases())
def test_the_conformance_battery_passes_on_the_release(requirement, tmp_path):
    venv = tmp_path / "venv"
    _run([sys.executable, "-m", "venv", "--system-site-packages", str(venv)], check=True)
    python = str(venv / "bin" / "python")
    pip = _run([python, "-m", "pip", "install", "--quiet", "--upgrade", "--disable-pip-version-check", requirement])
    if pip.returncode:
        pytest.skip(f"pip cannot install {requirement}: {(pip.stderr.strip().splitlines() or ['?'])[-1]}")
    installed = _run([python, "-c", "import mujoco; print(mujoco.__version__)"], cwd=ROOT, check=True).stdout.strip()
    assert Requirement(requirement).specifier.contains(installed, prereleases=True)  # the venv's own MuJoCo
    battery = _run([python, "-m", "pytest", "-n", "0", "-q", "-p", "no:cacheprovider", "tests/test_cases.py",
                    "-k", "test_conformance", "--engine", "mujoco"], cwd=ROOT)
    summary = (battery.stdout.strip().splitlines() or [""])[-1]
    assert battery.returncode == 0 and " passed" in summary, f"MuJoCo {installed}:\n{battery.stdout[-3000:]}"
