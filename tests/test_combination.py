"""adapters.combination: per-body values whose engine-rule combination reproduces every
pair of a scene, or Unsupported when none exist."""
from __future__ import annotations

import math

import pytest

from adapters.base import Unsupported
from adapters.combination import RULES, per_body_values
from cases.scene import Body, Material, Scene, Sphere, ground


def _three(e_ground: float, e_balls: float) -> Scene:
    """Two stacked balls on the ground: every pair may touch."""
    return Scene(bodies=(ground(), Body("bottom", Sphere(0.1), mass=1.0, position=(0, 0, 0.1)),
                         Body("top", Sphere(0.05), mass=0.1, position=(0, 0, 0.25))),
                 material=Material(e=e_ground), pairs=(("bottom", "top", Material(e=e_balls)),))


def _check(scene, v, rule):
    for a, b in scene.contact_pairs():
        assert math.isclose(RULES[rule](v[a.name], v[b.name]), scene.material_of(a.name, b.name).e, rel_tol=1e-12)


@pytest.mark.parametrize("rule", ["product", "min", "max"])
def test_one_value_for_every_pair(rule):
    scene = _three(0.5, 0.5)
    _check(scene, per_body_values(scene, lambda m: m.e, rule, "restitution"), rule)


def test_the_product_rule_solves_the_pairs_in_logs():
    """ground-ball 0.5 and ball-ball 1: ground 0.5, balls 1 (the first two candidates miss it)."""
    scene = _three(0.5, 1.0)
    v = per_body_values(scene, lambda m: m.e, "product", "restitution")
    _check(scene, v, "product")
    assert v["bottom"] == pytest.approx(1.0) and v["ground"] == pytest.approx(0.5)


def test_pairs_no_per_body_values_reproduce_are_unsupported():
    """product: ground-bottom 0 forces the ground or the bottom ball to 0, but ground-top
    and bottom-top are 0.5: no per-body values exist."""
    scene = Scene(bodies=_three(0.5, 0.5).bodies, material=Material(e=0.5),
                  pairs=(("ground", "bottom", Material(e=0.0)),))
    with pytest.raises(Unsupported, match="product rule"):
        per_body_values(scene, lambda m: m.e, "product", "restitution")


# --- the pair families' tables, pair by pair ------------------------------------------------

def _family_scenes():
    from cases import pair_friction, pair_restitution
    out = []
    for fam, value_of in ((pair_friction, lambda m: m.mu_s), (pair_restitution, lambda m: m.e)):
        for p in fam.GRID:
            out.append(pytest.param(fam.scene(p), value_of, id=f"{fam.FAMILY.name}[{fam.variant_id(p)}]"))
    return out


@pytest.mark.parametrize("rule", sorted(RULES))
@pytest.mark.parametrize("scene,value_of", _family_scenes())
def test_values_found_reproduce_every_pair_or_none_are_given(scene, value_of, rule):
    """Whatever the rule, per_body_values either refuses or gives values whose combination
    is each pair's own value, checked here pair by pair (a silent wrong mapping is the bug
    the pair families exist to catch)."""
    try:
        v = per_body_values(scene, value_of, rule, "value")
    except Unsupported:
        return
    for a, b in scene.contact_pairs():
        assert RULES[rule](v[a.name], v[b.name]) == pytest.approx(value_of(scene.material_of(a.name, b.name)),
                                                                  rel=1e-12, abs=1e-15)


@pytest.mark.parametrize("p", [pytest.param(p, id=p["layout"] + str(p["dim"])) for p in
                               __import__("cases.pair_friction", fromlist=["GRID"]).GRID])
def test_the_friction_rules_engines_use_express_the_pair_friction_tables(p):
    """The pair that does not touch sits at the min of the two that do (min rule: DART) or
    at their max (max rule: PhysX), and the friction ratio is below 2: the product, the
    harmonic mean (Drake), the arithmetic and the geometric mean (Newton, Box2D) express
    every table, min or max each one, with the ground non-neutral for product and
    harmonic (the family's docstring says so)."""
    from cases import pair_friction as pf
    ok = set()
    for rule in RULES:
        try:
            v = per_body_values(pf.scene(p), lambda m: m.mu_s, rule, "friction")
        except Unsupported:
            continue
        ok.add(rule)
        if rule in ("product", "harmonic"):
            assert v["ground"] != pytest.approx(1.0)
    assert {"product", "harmonic", "mean", "geometric"} <= ok and len({"min", "max"} & ok) == 1


def test_the_max_rule_takes_each_body_at_its_least_pair():
    """Balls 0.5 | 0.3 | (ends 0.5): under max, b1 = 0.5 and b2 = b3 = 0.3. The candidate
    with each body at its first pair's value (b2 = 0.5) misses it; Box2D reported the
    variant unsupported before."""
    from cases import pair_restitution as pr
    p = next(p for p in pr.GRID if (p["e12"], p["e23"], p["e13"]) == (0.5, 0.3, 0.5))
    v = per_body_values(pr.scene(p), lambda m: m.e, "max", "restitution")
    assert v == {"b1": 0.5, "b2": 0.3, "b3": 0.3}
    with pytest.raises(Unsupported, match="min rule"):
        per_body_values(pr.scene(p), lambda m: m.e, "min", "restitution")


def test_the_min_rule_takes_each_body_at_its_largest_pair():
    from cases import pair_restitution as pr
    p = {"e12": 0.7, "e23": 0.3, "e13": 0.3, "m": "1:1:1", "dim": 3}   # 0.7 | 0.3 | ends 0.3
    v = per_body_values(pr.scene(p), lambda m: m.e, "min", "restitution")
    assert v == {"b1": 0.7, "b2": 0.7, "b3": 0.3}
    with pytest.raises(Unsupported, match="max rule"):
        per_body_values(pr.scene(p), lambda m: m.e, "max", "restitution")


def test_the_harmonic_rule_is_solved_in_reciprocals():
    """Drake's 2 a b / (a + b): 1/v_a + 1/v_b = 2/c. Ground-a 0.2, ground-b 0.5, a-b 0.2:
    ground 0.5, a 0.2 * 0.5 / (2 * 0.5 - 0.2) = 0.125, b 0.5. One value for every body
    (the only candidate before) cannot give two pairs different values."""
    from cases import pair_friction as pf
    p = {"layout": "side", "mu_a": 0.2, "mu_b": 0.5, "mu_ab": 0.2, "dim": 2}
    v = per_body_values(pf.scene(p), lambda m: m.mu_s, "harmonic", "friction")
    assert v["ground"] == pytest.approx(0.5) and v["b"] == pytest.approx(0.5)
    assert v["a"] == pytest.approx(0.125)


def test_the_harmonic_rule_refuses_a_table_that_needs_a_negative_reciprocal():
    """Ground-a and ground-b 1.0, a-b 0.05: the three pairs fix the reciprocals, and the
    ground's is (2/1 + 2/1 - 2/0.05) / 2 = -18 < 0: no finite positive friction gives it."""
    from cases import pair_friction as pf
    scene = pf.scene({"layout": "side", "mu_a": 1.0, "mu_b": 1.0, "mu_ab": 1.0, "dim": 3})
    scene = Scene(bodies=scene.bodies, gravity=scene.gravity, material=Material(mu_s=0.05), pairs=scene.pairs)
    with pytest.raises(Unsupported, match="harmonic rule"):
        per_body_values(scene, lambda m: m.mu_s, "harmonic", "friction")


def test_the_harmonic_rule_is_drakes():
    """RULES["harmonic"] against pydrake's own CalcContactFrictionFromSurfaceProperties."""
    plant = pytest.importorskip("pydrake.multibody.plant")
    for a, b in ((0.2, 0.5), (0.8, 0.05), (1.0, 1.0)):
        mu = plant.CalcContactFrictionFromSurfaceProperties(plant.CoulombFriction(a, a), plant.CoulombFriction(b, b))
        assert RULES["harmonic"](a, b) == pytest.approx(mu.dynamic_friction(), rel=1e-14)


def test_the_mean_rules_are_solved_linearly():
    """Newton's arithmetic mean (XPBD, semi-implicit, Featherstone) and VBD's geometric mean
    of friction: ground-ball 0.5 and ball-ball 1 give the ground 0 and the balls 1 under the
    mean, the ground 0.25 and the balls 1 under the geometric mean."""
    scene = _three(0.5, 1.0)
    v = per_body_values(scene, lambda m: m.e, "mean", "restitution")
    _check(scene, v, "mean")
    assert v["ground"] == pytest.approx(0.0, abs=1e-12) and v["top"] == pytest.approx(1.0)
    v = per_body_values(scene, lambda m: m.e, "geometric", "restitution")
    _check(scene, v, "geometric")
    assert v["ground"] == pytest.approx(0.25) and v["top"] == pytest.approx(1.0)
