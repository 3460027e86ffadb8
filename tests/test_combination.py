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
