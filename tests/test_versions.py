"""Every engine's adapter declares the releases it supports (`Adapter.supported`, a PEP 440
specifier whose lower bound is a release the conformance battery ran on), pyproject.toml
installs no older one, and `adapters.registry.version_problem` says in one line when the
installed release lies outside the range."""
from __future__ import annotations

import tomllib
from importlib import metadata
from pathlib import Path

import pytest
from packaging.requirements import Requirement
from packaging.specifiers import SpecifierSet
from packaging.version import Version

from adapters import registry
from tests.fakes import FakeAdapter

ROOT = Path(__file__).resolve().parent.parent


def _adapter(name):
    """The adapter of extra `name`: the engine of that name, else its first configuration
    (newton-xpbd for newton)."""
    if name not in registry.ENGINES:
        name = next((n for n in registry.ENGINES if n.startswith(f"{name}-")), name)
    try:
        return registry.get(name)
    except registry.EngineError as exc:
        pytest.skip(str(exc))


def _lower_bound(spec: str) -> Version:
    (lower,) = [Version(s.version) for s in SpecifierSet(spec) if s.operator == ">="]
    return lower


@pytest.mark.parametrize("name", sorted(registry.EXTRAS))
def test_every_engine_declares_a_range_and_pyproject_installs_no_older_release(name):
    adapter = _adapter(name)
    assert adapter.supported, f"adapter {name} declares no supported range"
    extras = tomllib.loads((ROOT / "pyproject.toml").read_text())["project"]["optional-dependencies"]
    requirements = [Requirement(r) for group in (registry.EXTRAS[name], "all", "more") for r in extras.get(group, ())]
    bounds = {_lower_bound(str(r.specifier)) for r in requirements if r.name == adapter.package}
    assert bounds == {_lower_bound(adapter.supported)}


def test_the_reference_is_part_of_physval_and_declares_no_range():
    assert registry.get("reference").supported is None
    assert registry.version_problem("reference") is None


@pytest.mark.parametrize("release, inside", [("3.1.0", False), ("3.2.5", False), ("3.2.6", True), ("4.0.0", True),
                                             ("4.1.0rc1", True), ("5.0.0", False)])
def test_a_release_outside_the_range_is_named_in_one_line(release, inside):
    adapter = FakeAdapter(name="mujoco")
    adapter.package, adapter.supported = "mujoco", ">=3.2.6,<5"
    problem = registry.range_problem(adapter, release)
    if inside:
        assert problem is None
    else:
        assert problem == f"mujoco {release} is outside the supported range >=3.2.6,<5 of adapter mujoco"


def test_a_version_that_is_not_pep_440_is_said_so():
    adapter = FakeAdapter()
    adapter.package, adapter.supported = "thing", ">=1"
    assert "not a PEP 440 version" in registry.range_problem(adapter, "nightly build")


class OldNumpyOnly(FakeAdapter):
    """An adapter of numpy releases before 1.0 (none installed here)."""
    package = "numpy"
    supported = "<1"

    def __init__(self):
        super().__init__(name="old-numpy-only")


def test_version_problem_reads_the_installed_release_of_the_adapters_package():
    adhoc = ("tests.test_versions:OldNumpyOnly",)
    assert registry.version_problem("old-numpy-only", adhoc) == (
        f"numpy {metadata.version('numpy')} is outside the supported range <1 of adapter old-numpy-only")


def test_the_mujoco_adapter_leaves_out_only_what_the_release_lacks_and_records_it(monkeypatch):
    """A release whose schema lacks the sleep flag and pair adhesion (as 3.2.6-3.3.7 do) gets
    MJCF without them, the knob left_out names them, and the scene still compiles."""
    mj = pytest.importorskip("adapters.mujoco_engine", exc_type=ImportError)
    from adapters.base import Settings
    from cases import resting_blocks
    schema = mj.mjcf_schema()
    assert {"timestep", "cone", "impratio"} <= schema["option"] and "autoreset" in schema["option/flag"]
    older = {**schema, "option/flag": schema["option/flag"] - {"sleep"},
             "contact/pair": schema["contact/pair"] - {"adhesion"}}
    monkeypatch.setattr(mj, "mjcf_schema", lambda: older)
    scene = resting_blocks.scene({"n": 2, "dim": 3})
    xml, knobs = mj.scene_mjcf(scene, Settings(dt=1e-3), mj.ITERATIONS, mj.CONTACT_STEPS)
    assert "sleep=" not in xml and "adhesion=" not in xml and 'autoreset="disable"' in xml
    assert {"option/flag/sleep", "contact/pair/adhesion"} <= set(knobs["left_out"])
    assert "sleep" not in knobs["flag"] and all("adhesion" not in p for p in knobs["pair"].values())
    mj.MuJoCoAdapter._compile(xml)


# --- through the command line: before any work ------------------------------------------------

OUT_OF_RANGE = '''
from adapters.mujoco_engine import MuJoCoAdapter


class Future(MuJoCoAdapter):
    name = "mujoco-future"
    supported = ">=999"   # a release of MuJoCo nobody has
'''


def test_an_engine_outside_its_range_is_named_before_any_work(tmp_path, capsys):
    """Named by its name: one line with the range, exit 2, nothing written. Picked by a glob:
    left out with one line, and the run goes on without it."""
    from adapters.registry import available
    from physval.cli import main
    if not available("mujoco"):
        pytest.skip("MuJoCo is not installed")
    (tmp_path / "future.py").write_text(OUT_OF_RANGE)
    adapter = ["--adapter", f"{tmp_path / 'future.py'}:Future"]
    one = ["run", "--cases", "central_impact[drop,e=0.5]", "--quiet", "--readings", "none", *adapter]
    assert main([*one, "--engines", "mujoco-future", "--out", str(tmp_path / "a")]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "outside the supported range >=999 of adapter mujoco-future" in err[0], err
    assert not (tmp_path / "a" / "results.csv").exists()
    assert main([*one, "--engines", "mujoco*", "--out", str(tmp_path / "b")]) == 0
    assert "mujoco-future left out" in capsys.readouterr().err
    import csv
    engines = {r["engine"] for r in csv.DictReader(open(tmp_path / "b" / "results.csv"))}
    assert "mujoco-future" not in engines and "mujoco" in engines
