"""What an engine declares about impacts is what its runs show: every installed engine
configuration of the registry.

- The impact model (Capabilities.impact_model) through bodies already touching: a 0.1 kg
  ball resting on a 1 kg one, touching without overlap, both landing at 2 m/s with gravity
  off (the measurement adapters/box3d_engine.py IMPACT_MODEL_MEASURED rests on). The
  simultaneous model's closed form has both leave at e V, the sequential one's launches the
  top ball faster (cases/column_impact.py). An engine that declares one of them shows it; one
  that declares none (Box2D, Rapier) shows neither, so an upgrade that makes it follow one
  says so here. Compliant engines (contacts as springs) have no closed form. (A row struck
  by a ball touching it is no such measurement: whether exactly touching bodies are in
  contact is a rounding coin flip, cases/column_impact.py; the family presses its pairs
  1 um into each other and records each engine's deviations there.)
- The restitution law (Capabilities.restitution_law) at a frictional contact: a ball
  sliding into a free rod off its centre line (eccentric_impact, e = 0.5, mu = 0.1, where
  Newton's and the two-phase law differ by 1,400 tolerances), judged by each law's closed
  form with no known deviation: the declared law's miss is the smallest, by a factor of ten
  (a compliant engine's: the smallest).

Tens of steps per engine at dt = 1e-3: seconds for the whole file."""
from __future__ import annotations

import copy
import math
from dataclasses import replace

import pytest

from adapters import registry
from adapters.base import Settings, Unsupported
from cases.column_impact import sequential_velocities, simultaneous_velocities
from cases.impact_laws import IMPULSE_OF_LAW, law_of
from cases.scene import Body, Material, Scene, ball, ground
from physval.core import Context, Job, execute
from physval.core.context import Resolver
from tests.helpers import adapter_or_skip

V = 2.0                              # m/s, both balls before the landing
MASSES = [0.1, 1.0, math.inf]        # top, bottom, ground
# m/s: three impacts of a few m/s in float32 round to 1e-5; DART and PyBullet leave the
# bodies 2e-5 to 5e-5 m/s off the closed form (measured: their contacts' push-out).
MATCH = 1e-4
# m/s: the models differ here by 1.1 m/s (e = 0.5) and 3.3 m/s (e = 1); an engine "follows
# neither" only if it misses each by more than this (Rapier's nearest miss measured: 0.075
# m/s in 3D at e = 0.5)
NEITHER = 1e-2


def _landing(adapter, e: float) -> tuple[float, float]:
    """Downward velocities of the top and the bottom ball once the impacts are over."""
    dim = max(adapter.capabilities.dimensions)
    bottom = Body("bottom", ball(0.1, dim), mass=1.0, position=(0, 0, 0.1), velocity=(0, 0, -V))
    top = Body("top", ball(0.1, dim), mass=0.1, position=(0, 0, 0.3), velocity=(0, 0, -V))
    scene = Scene(bodies=(ground(), bottom, top), gravity=(0, 0, 0), material=Material(e=e), dimension=dim)
    try:
        sim = adapter.build(scene, Settings(dt=1e-3))
    except Unsupported as exc:
        pytest.skip(f"{adapter.name}: {exc}")
    try:
        for _ in range(30):
            sim.step()
        s = sim.states()
    finally:
        sim.close()
    return -float(s["top"][9]), -float(s["bottom"][9])


@pytest.mark.parametrize("e", (1.0, 0.5))
@pytest.mark.parametrize("engine", registry.engine_names())
def test_touching_balls_land_by_the_declared_impact_model(engine, e):
    adapter = adapter_or_skip(engine)
    model = adapter.capabilities.impact_model
    if model == "compliant":
        pytest.skip(f"{engine}: compliant contacts have no closed form here")
    got = _landing(adapter, e)
    closed = {"sequential": sequential_velocities(MASSES, [V, V, 0.0], e)[0][:2],
              "simultaneous": simultaneous_velocities(MASSES, [V, V, 0.0], e)[:2]}
    miss = {m: max(abs(g - c) for g, c in zip(got, v)) for m, v in closed.items()}
    said = f"{engine} (declares {model}) at e = {e}: top, bottom {got} m/s down; closed forms {closed}; misses {miss}"
    if model is None:
        assert min(miss.values()) > NEITHER, f"{said}: it follows a model now, declare it"
    else:
        assert miss[model] <= MATCH, said


LAW_VARIANT = "e=0.5,mu=0.1,slip=1"


def _law_misses(engine: str, adapter) -> dict[str, float]:
    """The largest miss in tolerances of the law-dependent eccentric impact under each law
    of its grid, judged by that law's closed form with the engine declaring that law and
    no known deviation; the law left out where the engine cannot run the variant."""
    resolver = Resolver(Context())
    family = resolver.family("eccentric_impact")
    label = "" if 3 in adapter.capabilities.dimensions else ",2D"
    ids = {v.id: v for v in family.all_variants}
    out = {}
    for law in IMPULSE_OF_LAW:
        variant = ids.get(LAW_VARIANT + ("" if law == "newton" else f",{law}") + label)
        if variant is None:
            continue
        assert law_of(variant.params) == law
        claimed = copy.copy(adapter)
        claimed.capabilities = replace(adapter.capabilities, restitution_law=law)
        rows = execute(Job(family.name, variant, engine), Resolver(Context()).provide(engine, claimed, [])).rows
        if {r["status"] for r in rows} & {"unsupported", "error", "unstable"}:
            continue
        out[law] = max((r["abs_error"] if r["tolerance_kind"] == "abs" else r["rel_error"]) / r["tolerance"]
                       for r in rows)
    return out


@pytest.mark.parametrize("engine", registry.engine_names())
def test_the_declared_restitution_law_is_the_one_the_runs_show(engine):
    adapter = adapter_or_skip(engine)
    misses = _law_misses(engine, adapter)
    declared = adapter.capabilities.restitution_law
    if declared not in misses or len(misses) < 2:
        pytest.skip(f"{engine} runs the law-dependent impact under fewer than two laws: {sorted(misses)}")
    others = {law: m for law, m in misses.items() if law != declared}
    # an impulse solver follows its law to a few tolerances against 1,400 for the other; a
    # compliant contact (a spring over many steps) follows none exactly: the nearest is declared
    factor = 1.0 if adapter.capabilities.impact_model == "compliant" else 10.0
    assert all(misses[declared] * factor < m for m in others.values()), \
        f"{engine} declares {declared}: misses in tolerances {misses}"
