"""The planted-fault hook (adapters/planting.py) as a user meets it: a fault of one's own,
planted in an engine under a new name through `--adapter`, is judged by the engine's own
tolerances and recorded bands; the wrapper alone changes nothing, bands included; and a
fault that needs an engine-internal change its adapter does not make is refused in one
line. Every job runs in this process on one variant (seconds)."""
from __future__ import annotations

import re
from pathlib import Path

import pytest

from adapters import registry
from adapters.planting import Fault, NotPlantable, Planted
from physval import faults
from physval.core import Context, Job, execute
from physval.core.context import Resolver

ROOT = Path(__file__).resolve().parent.parent
PAGE = ROOT / "docs" / "extend" / "adding_an_engine.md"


def users_file(folder: Path) -> Path:
    """The page's my_faults.py, written where the user keeps it."""
    (code,) = re.findall(r"```python\n(# my_faults.py\n.*?)```", PAGE.read_text(), re.S)
    path = folder / "my_faults.py"
    path.write_text(code)
    return path


def verdicts(ctx: Context, engine: str, family: str, variant: str) -> list[dict]:
    resolver = Resolver(ctx)
    (v,) = [v for v in resolver.family(family).all_variants if v.id == variant]
    return execute(Job(family, v, engine), resolver).rows


FREE_FALL = ("conformance", "free_fall_matches_discrete_closed_form,2D")


def test_the_pages_fault_of_ones_own_fails_the_free_fall_the_engine_passes(tmp_path):
    spec = f"{users_file(tmp_path)}:reference_strong_gravity"
    ctx = Context(adapters=(spec,))
    planted = verdicts(ctx, "reference-strong-gravity", *FREE_FALL)
    plain = verdicts(ctx, "reference", *FREE_FALL)
    assert {r["status"] for r in plain} == {"pass"}, plain
    failed = [r for r in planted if r["status"] == "fail"]
    assert failed, planted
    assert all("planted fault: strong gravity" in r["engine_version"] for r in planted)


class _Nothing(Fault):
    name = "nothing"


def mujoco_named_anew():
    return Planted(registry.get("mujoco"), _Nothing(), name="mujoco-nothing-planted")


def test_an_engine_planted_under_a_new_name_is_judged_by_the_engines_bands():
    """MuJoCo's central impact is a known deviation (e mapped onto a spring-damper): the
    wrapper alone, named anew, measures the same numbers and reads the same bands."""
    if not registry.available("mujoco"):
        pytest.skip("mujoco is not installed")
    ctx = Context(adapters=(f"{__name__}:mujoco_named_anew",))
    case = ("central_impact", "e=0.5,m=1:3")
    planted = verdicts(ctx, "mujoco-nothing-planted", *case)
    plain = verdicts(ctx, "mujoco", *case)
    assert "deviation" in {r["status"] for r in plain}
    assert [(r["metric"], r["status"], r["measured"], r["band"]) for r in planted] == \
           [(r["metric"], r["status"], r["measured"], r["band"]) for r in plain]


def test_a_change_the_adapter_does_not_make_is_refused_in_one_line():
    """The reference's PGS formulation makes no engine-internal change: a square friction
    cone cannot be planted there, and the message names the change and what it makes."""
    with pytest.raises(NotPlantable) as caught:
        Planted(registry.get("reference-pgs"), faults.by_name("friction cone"))
    said = str(caught.value)
    assert "\n" not in said and "'square friction cone'" in said and "reference-pgs" in said
    # a fault that changes only the scene goes into any engine
    assert Planted(registry.get("reference-pgs"), faults.by_name("gravity")).name == "reference-pgs"


def test_every_change_an_adapter_declares_is_one_planting_knows():
    from adapters.planting import CHANGES
    for name in registry.engine_names():
        try:
            adapter = registry.get(name)
        except registry.EngineError:
            continue
        assert set(adapter.plantable) <= set(CHANGES), (name, adapter.plantable)
