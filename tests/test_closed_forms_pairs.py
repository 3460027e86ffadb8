"""The closed forms of the per-pair material families against independent routes: the
stopping distances from the work of friction and from stepping Coulomb's law, the row of
balls from an event-driven run that resolves any approaching pair by the impulse of
note 002 (J = (1 + e) m_eff v_rel) until none approaches; and the scenes state each
pair's own material."""
from __future__ import annotations

import math

import numpy as np
import pytest

from cases import pair_friction as pfr
from cases import pair_restitution as pre
from cases.family import CaseError
from cases.trajectory import Trajectory

G = 9.81


# --- pair_friction ----------------------------------------------------------------------------

@pytest.mark.parametrize("p", pfr.GRID, ids=pfr.variant_id)
def test_each_pair_has_its_own_material_and_the_layout_touches_two_pairs(p):
    """Side: the blocks rest on the ground apart and move apart; stack: b rests on a, a on
    the ground, and b ends on a's top face (its centre within a's half-size)."""
    scene = pfr.scene(p)
    assert scene.material_of("ground", "a").mu_s == p["mu_a"]
    assert scene.material_of("b", "ground").mu_s == p["mu_b"]
    assert scene.material_of("a", "b").mu_s == p["mu_ab"]
    a, b = scene.body("a"), scene.body("b")
    if p["layout"] == "side":
        assert a.position[0] - b.position[0] >= 2 * pfr.HALF and a.velocity[0] > 0 > b.velocity[0]
        assert a.position[2] == b.position[2] == pfr.HALF
    else:
        assert b.position[2] - a.position[2] == pytest.approx(2 * pfr.HALF, abs=1e-15) and a.position[2] == pfr.HALF
        assert a.velocity == b.velocity and p["mu_ab"] < p["mu_a"]  # b slides forward on a
        checks = {c.metric: c for c in pfr.expect(p, 1e-3)}
        ahead = checks["stop_distance_b"].expected - checks["stop_distance_a"].expected
        assert 0.0 < ahead < 0.6 * pfr.HALF


def test_each_layout_has_a_max_rule_and_a_min_rule_variant():
    """Each layout runs on a min-rule engine (DART) and on a max-rule one (PhysX): the
    untouched pair at the min of the touching ones in one variant, at their max in another
    (tests/test_combination.py: the other rules express every table)."""
    from adapters.base import Unsupported
    from adapters.combination import per_body_values

    def expressible(p, rule):
        try:
            per_body_values(pfr.scene(p), lambda m: m.mu_s, rule, "friction")
            return True
        except Unsupported:
            return False
    for rule in ("min", "max"):
        assert {p["layout"] for p in pfr.GRID if expressible(p, rule)} == {"side", "stack"}, rule


@pytest.mark.parametrize("p", pfr.GRID, ids=pfr.variant_id)
def test_stop_distances_are_the_work_of_each_pairs_friction(p):
    """Work-energy, block by block: side, mu_i m g d_i = m v0^2 / 2; stack, a carries b's
    weight and b's drag, (2 mu_a - mu_ab) m g d_a = m v0^2 / 2, and b, mu_ab m g d_b = m v0^2 / 2."""
    checks = {c.metric: c for c in pfr.expect(p, 1e-3)}
    v0 = pfr.V0[p["layout"]]
    force = {"a": p["mu_a"], "b": p["mu_b"]} if p["layout"] == "side" else \
        {"a": 2 * p["mu_a"] - p["mu_ab"], "b": p["mu_ab"]}
    for name in pfr.BLOCKS:
        assert force[name] * G * checks[f"stop_distance_{name}"].expected == pytest.approx(v0**2 / 2, rel=1e-12)


def _ground(v: float, brake: float) -> float:
    """A block's velocity after the ground's friction impulse (at most `brake`, never past rest)."""
    return max(v - brake, 0.0) if v > 0 else min(v + brake, 0.0)


def _stepped(p, dt: float, steps: int, velocity_first: bool):
    """Both blocks stepped with Coulomb friction as impulses (unit masses), each step's
    contacts resolved together: the ground's impulse on each block it touches is mu N dt
    against its motion, or what holds it at rest if that is less; a-b (stack) slides with
    mu_ab g dt if b is then still faster than a, else the two move as one. Returns x of a
    and b along their launch directions, one per step."""
    v0 = pfr.V0[p["layout"]]
    x = {"a": [0.0], "b": [0.0]}
    v = {"a": v0, "b": v0}
    for _ in range(steps):
        if p["layout"] == "side":
            new = {n: _ground(v[n], p[f"mu_{n}"] * G * dt) for n in pfr.BLOCKS}
        else:
            j = p["mu_ab"] * G * dt                                    # b slides on a
            new = {"a": _ground(v["a"] + j, 2.0 * p["mu_a"] * G * dt), "b": v["b"] - j}
            if new["b"] <= new["a"]:                                   # no: they move as one
                together = _ground((v["a"] + v["b"]) / 2.0, p["mu_a"] * G * dt)
                new = {"a": together, "b": together}
        for name in pfr.BLOCKS:
            x[name].append(x[name][-1] + (new[name] if velocity_first else v[name]) * dt)
        v = new
    return {n: np.array(x[n]) for n in pfr.BLOCKS}


@pytest.mark.parametrize("velocity_first", [True, False])
@pytest.mark.parametrize("p", pfr.GRID, ids=pfr.variant_id)
def test_stepped_coulomb_friction_reads_within_half_the_tolerances(p, velocity_first):
    """Both Euler orders, the bodies stepped together with Coulomb impulses (not the
    family's per-block decelerations), read by the family's observer: every check holds
    with half its band or less to spare (a correct Euler engine does not fill it)."""
    dt = 1e-3
    steps = int(round(pfr.duration(p) / dt))
    t = np.arange(steps + 1) * dt
    xs = _stepped(p, dt, steps, velocity_first)
    states = {}
    for name in pfr.BLOCKS:
        x = xs[name]
        v = np.concatenate([[pfr.V0[p["layout"]]], np.diff(x) / dt])  # the speed a step moved at: stopped is 0
        s = np.zeros((steps + 1, 13))
        s[:, 0], s[:, 7], s[:, 3] = x, v, 1.0
        states[name] = s
    values = pfr.observe(Trajectory(dt=dt, t=t, states=states), p)
    for c in pfr.expect(p, dt):
        used = abs(values[c.metric] - c.expected) / c.tolerance
        limit = 0.51 if c.metric.startswith("stop_distance") else 1.0
        assert used <= limit, f"{c.metric}: {used:.3f} of the band"


@pytest.mark.parametrize("p", pfr.GRID, ids=pfr.variant_id)
def test_a_five_per_cent_error_in_any_pairs_mu_fails_a_stop_distance(p):
    """Stepped either way (velocity or position first), one pair's mu 5 % high or low moves
    some block's stop out of its band: the band does not let a wrong mu through."""
    dt = 1e-3
    steps = int(round(pfr.duration(p) / dt))
    checks = {c.metric: c for c in pfr.expect(p, dt)}
    for pair in ("mu_a", "mu_b", "mu_ab"):
        if p["layout"] == "side" and pair == "mu_ab" or p["layout"] == "stack" and pair == "mu_b":
            continue  # the pair that does not touch
        for factor in (0.95, 1.05):
            for velocity_first in (True, False):
                xs = _stepped({**p, pair: factor * p[pair]}, dt, steps, velocity_first)
                assert any(abs(xs[n][-1] - checks[f"stop_distance_{n}"].expected)
                           > checks[f"stop_distance_{n}"].tolerance for n in pfr.BLOCKS), (pair, factor)


# --- pair_restitution -------------------------------------------------------------------------

def _event_driven(masses, pairs_e, x0, v0, radius):
    """Three balls on a line, impacts resolved one at a time when a neighbouring pair
    closes its gap: J = (1 + e) m1 m2 / (m1 + m2) (v_i - v_j) (note 002, two particles);
    returns the final velocities and the pairs that met, in order."""
    x, v = np.array(x0, float), np.array(v0, float)
    m = np.array(masses, float)
    order = []
    for _ in range(100):
        times = []
        for i in range(len(x) - 1):
            closing = v[i] - v[i + 1]
            gap = x[i + 1] - x[i] - 2 * radius
            if closing > 1e-15:
                times.append((max(gap, 0.0) / closing, i))
        if not times:
            return v, order
        dt, i = min(times)
        x += v * dt
        e = pairs_e[(i, i + 1)]
        J = (1.0 + e) * m[i] * m[i + 1] / (m[i] + m[i + 1]) * (v[i] - v[i + 1])
        v[i] -= J / m[i]
        v[i + 1] += J / m[i + 1]
        order.append((i + 1, i + 2))
    raise AssertionError("impacts did not end")


def _along_x(p):
    """The scene's balls sorted by their place on the x axis."""
    scene = pre.scene(p)
    return scene, sorted((scene.body(n) for n in pre.BALLS), key=lambda b: b.position[0])


@pytest.mark.parametrize("p", pre.GRID, ids=pre.variant_id)
def test_the_row_meets_twice_and_ends_at_the_closed_form(p):
    """An event-driven run of the scene's balls as they lie along x, each neighbouring pair
    with the e the scene gives it: two impacts, the first two balls then the last two, and
    the closed form's velocities."""
    scene, bodies = _along_x(p)
    e = {(i, i + 1): scene.material_of(bodies[i].name, bodies[i + 1].name).e for i in range(2)}
    v, order = _event_driven([b.mass for b in bodies], e, [b.position[0] for b in bodies],
                             [b.velocity[0] for b in bodies], pre.R)
    assert order == [(1, 2), (2, 3)]            # two impacts, first-second then second-third, and no third
    by_name = dict(zip((b.name for b in bodies), v))
    assert np.allclose([by_name[n] for n in pre.BALLS], pre.final_velocities(p), rtol=0, atol=1e-12)


@pytest.mark.parametrize("p", pre.GRID, ids=pre.variant_id)
def test_the_row_loses_the_deformation_work_of_each_impact(p):
    """Energy: the loss is the sum of note 001's W = m* v_rel^2 (1 - e^2) / 2 per impact."""
    scene, (first, mid, last) = _along_x(p)
    e1, e2 = scene.material_of(first.name, mid.name).e, scene.material_of(mid.name, last.name).e
    v = dict(zip(pre.BALLS, pre.final_velocities(p)))
    u = pre.velocities_after(first.mass, mid.mass, pre.V0, 0.0, e1)[1]
    lost = 0.5 * first.mass * pre.V0**2 - 0.5 * sum(b.mass * v[b.name]**2 for b in (first, mid, last))
    work = (first.mass * mid.mass / (first.mass + mid.mass) * pre.V0**2 * (1 - e1**2) / 2
            + mid.mass * last.mass / (mid.mass + last.mass) * u**2 * (1 - e2**2) / 2)
    assert lost == pytest.approx(work, rel=1e-12)


@pytest.mark.parametrize("p", pre.GRID, ids=pre.variant_id)
def test_the_impacts_are_far_apart_in_time(p):
    """A compliant contact lasts tens of ms (16 steps here); the impacts must not overlap."""
    t1, t2 = pre.impact_times(p)
    assert t2 - t1 > 0.04 and pre.duration(p) - t2 >= 0.15 - 1e-12


def test_a_row_that_meets_a_third_time_is_refused():
    """Equal masses, soft first impact, hard second: ball 2 bounces back into ball 1."""
    p = {"e12": 0.3, "e23": 0.8, "e13": 0.8, "m": "1:1:1", "dim": 3}
    assert not pre.impacts(1.0, 1.0, 1.0, 0.3, 0.8, pre.V0)[1]
    with pytest.raises(CaseError, match="meets again"):
        pre.expect(p, 1e-3)


@pytest.mark.parametrize("p", pre.GRID, ids=pre.variant_id)
def test_each_impact_has_its_pairs_e(p):
    scene = pre.scene(p)
    assert (scene.material_of("b1", "b2").e, scene.material_of("b3", "b2").e) == (p["e12"], p["e23"])
    assert scene.material_of("b1", "b3").e == p["e13"]


def test_every_pair_meets_in_some_row_of_each_dimension():
    """Row 1-2-3 brings 1-2 and 2-3 together, row 1-3-2 1-3 and 3-2: in 3D and in 2D every
    pair of the table meets in some variant."""
    for dim in (3, 2):
        met = set()
        for p in (q for q in pre.GRID if q["dim"] == dim):
            _, bodies = _along_x(p)
            met |= {frozenset((bodies[0].name, bodies[1].name)), frozenset((bodies[1].name, bodies[2].name))}
        assert met == {frozenset(pair) for pair in (("b1", "b2"), ("b2", "b3"), ("b1", "b3"))}, dim


@pytest.mark.parametrize("p", pre.GRID, ids=pre.variant_id)
def test_the_product_and_the_mean_express_every_table_and_max_or_drake_each(p):
    """The pair that does not meet sits at the larger of the two that do (its square at
    most the smaller) or at the smaller (the larger at most twice it): the product and the
    mean express every table, the max rule the first class, Drake's summed dissipations
    the second."""
    from adapters.base import Unsupported
    from adapters.combination import per_body_values
    for rule in ("product", "mean"):
        per_body_values(pre.scene(p), lambda m: m.e, rule, "restitution")  # raises Unsupported if not
    try:
        per_body_values(pre.scene(p), lambda m: m.e, "max", "restitution")
        by_max = True
    except Unsupported:
        by_max = False
    touching = sorted(pre.pair_e(p, *pair) for pair in zip(pre.row(p), pre.row(p)[1:]))
    apart = ({"e12", "e13", "e23"} - {"e" + "".join(sorted((a[1], b[1]))) for a, b in
                                      zip(pre.row(p), pre.row(p)[1:])}).pop()
    assert by_max == (p[apart] == touching[1])
    assert p[apart] in touching


def test_each_dimension_has_both_rows_in_both_classes():
    for dim in (3, 2):
        kinds = set()
        for p in (q for q in pre.GRID if q["dim"] == dim):
            touching = [pre.pair_e(p, *pair) for pair in zip(pre.row(p), pre.row(p)[1:])]
            apart = [v for k, v in p.items() if k.startswith("e") and k[1:] not in
                     {"".join(sorted((a[1], b[1]))) for a, b in zip(pre.row(p), pre.row(p)[1:])}][0]
            kinds.add((p["row"], "max" if apart == max(touching) else "min"))
        assert kinds == {(r, c) for r in ("1-2-3", "1-3-2") for c in ("max", "min")}, dim
