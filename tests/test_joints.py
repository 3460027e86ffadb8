"""Joints and loads (issue 39): the scene vocabulary's checks and effects, the capability gate,
the pendulum family's graders against integrators of known order, and each engine that
declares joints or loads doing what the scene asks (a limit stops where it says, a force
accelerates at F / m). Tiny scenes: seconds of CPU for the whole file."""
from __future__ import annotations

import math
import re
import subprocess
import sys
import textwrap

import numpy as np
import pytest

from adapters import registry
from adapters.base import Capabilities, Settings
from cases import pendulum
from cases.scene import Body, Box, Joint, Load, Scene, SceneError, ball, ground
from cases.trajectory import Trajectory
from tests.helpers import adapter_or_skip, engines_declaring

G = 9.81


def _bob(dim: int = 3, name: str = "bob", x: float = 0.5) -> Body:
    return Body(name, ball(0.05, dim), mass=1.0, position=(x, 0.0, 1.0))


# --- the vocabulary ------------------------------------------------------------------------

@pytest.mark.parametrize("joints,loads,dim,message", [
    ((Joint("revolute", "nobody"),), (), 3, r"joints[0].body = 'nobody': no body of that name (bob)"),
    ((Joint("revolute", "bob", parent="ghost"),), (), 3, r"joints[0].parent = 'ghost': no body of that name"),
    ((Joint("revolute", "bob", parent="bob"),), (), 3, r"joints[0].parent = 'bob': a joint connects two different"),
    ((Joint("hinge", "bob"),), (), 3, r"joints[0].kind = 'hinge': must be one of revolute, prismatic, ball, fixed"),
    ((Joint("revolute", "bob", axis=(0, 0, 0)),), (), 3, r"joints[0].axis = (0, 0, 0): must have a length > 0"),
    ((Joint("prismatic", "bob", axis=(1, 0, 0), limits=(0.5, -0.5)),), (), 3,
     r"joints[0].limits = (0.5, -0.5): lower must be <= upper"),
    ((Joint("revolute", "bob", limits=(0.1, 0.5)),), (), 3, r"joints[0].limits = (0.1, 0.5): must hold the start, 0"),
    ((Joint("ball", "bob", limits=(-1, 1)),), (), 3, r"joints[0].limits = (-1, 1): only revolute and prismatic"),
    ((Joint("revolute", "bob", friction=-1.0),), (), 3, r"joints[0].friction = -1.0: must be a finite force or torque >= 0"),
    ((Joint("ball", "bob", friction=0.5),), (), 3, r"joints[0].friction = 0.5: only revolute and prismatic joints have"),
    ((Joint("revolute", "bob", anchor=(0, 0, math.nan)),), (), 3, r"joints[0].anchor = (0, 0, nan): must be finite"),
    ((Joint("revolute", "bob", limits=(-1, 1), limit_e=1.5),), (), 3,
     r"joints[0].limit_e = 1.5: a coefficient of restitution, must lie in [0, 1]"),
    ((Joint("revolute", "bob", limit_e=0.5),), (), 3, r"joints[0].limit_e = 0.5: a restitution at a limit needs limits"),
    ((Joint("ball", "bob"),), (), 2, r"joints[0].kind = 'ball': a 2D scene's joints are revolute (about y)"),
    ((Joint("revolute", "bob", axis=(0, 0, 1)),), (), 2, r"joints[0].axis = (0, 0, 1): a 2D revolute joint turns about y"),
    ((), (Load("ghost", force=(1, 0, 0)),), 3, r"loads[0].body = 'ghost': must name a dynamic body (bob)"),
    ((), (Load("bob", force=(1, 0)),), 3, r"loads[0].force = (1, 0): must have 3 components"),
    ((), (Load("bob", torque=(1, 0, 0)),), 2, r"loads[0]: a 2D scene lies in the x-z plane"),
])
def test_bad_joints_and_loads_name_the_field(joints, loads, dim, message):
    with pytest.raises(SceneError) as caught:
        Scene(bodies=(_bob(dim),), joints=joints, loads=loads, dimension=dim)
    assert message in str(caught.value) and "\n" not in str(caught.value)


def test_a_joint_needs_a_dynamic_body():
    with pytest.raises(SceneError, match=r"joints\[0\]: joins 'ground' to the world, both static"):
        Scene(bodies=(ground(), _bob()), joints=(Joint("fixed", "ground"),))


def test_effects_name_joints_limits_and_loads():
    plain = Scene(bodies=(_bob(),))
    assert not {"joint", "limit", "load"} & plain.effects
    hinged = Scene(bodies=(_bob(),), joints=(Joint("revolute", "bob", anchor=(0, 0, 1)),))
    assert "joint" in hinged.effects and "limit" not in hinged.effects
    limited = Scene(bodies=(_bob(),), joints=(Joint("revolute", "bob", limits=(-1.0, 0.0)),))
    assert {"joint", "limit"} <= limited.effects
    assert "load" in Scene(bodies=(_bob(),), loads=(Load("bob", torque=(0, 1, 0)),)).effects
    assert "load" not in Scene(bodies=(_bob(),), loads=(Load("bob"),)).effects  # a zero load asks for nothing
    assert "joint_friction" not in limited.effects
    assert "limit_restitution" not in limited.effects  # a plastic limit (limit_e = 0)
    bouncy = Scene(bodies=(_bob(),), joints=(Joint("revolute", "bob", limits=(-1.0, 0.0), limit_e=0.5),))
    assert {"limit", "limit_restitution"} <= bouncy.effects
    assert "joint_friction" in Scene(bodies=(_bob(),), joints=(Joint("prismatic", "bob", friction=1.0),)).effects


def test_jointed_bodies_do_not_collide():
    a, b = _bob(name="a", x=0.0), _bob(name="b", x=0.1)  # touching spheres
    free = Scene(bodies=(ground(), a, b))
    joined = Scene(bodies=(ground(), a, b), joints=(Joint("fixed", "b", parent="a", anchor=(0.05, 0, 1)),))
    assert {(x.name, y.name) for x, y in free.contact_pairs()} - {(x.name, y.name) for x, y in joined.contact_pairs()} \
        == {("a", "b")}


def test_an_engine_without_joints_says_so():
    bare = Capabilities(dimensions=frozenset({3}), shapes=frozenset({"sphere"}), native_restitution=True,
                        static_kinetic=False, contact_forces=False, iterations=False)
    hinged = Scene(bodies=(_bob(),), joints=(Joint("revolute", "bob", limits=(-1.0, 0.0)),))
    assert bare.cannot_run(hinged) == "revolute joint asked for: the adapter builds no joints"
    some = Capabilities(**{**bare.__dict__, "joints": frozenset({"revolute"}), "coordinates": "maximal"})
    assert some.cannot_run(hinged) == "joint limits asked for: the adapter builds no joint limits"
    assert some.cannot_run(Scene(bodies=(_bob(),), loads=(Load("bob", force=(1, 0, 0)),))).startswith(
        "a constant external force or torque asked for")
    with pytest.raises(ValueError, match="coordinates = None: an engine with joints says which it uses"):
        Capabilities(**{**bare.__dict__, "joints": frozenset({"revolute"})})


def test_contact_forces_from_momenta_are_not_read_in_a_scene_with_joints():
    """Box2D's and Box3D's contact forces are worked out from the bodies' momenta: in a scene
    with joints these hold the joints' impulses too, so a case that reads contact forces
    there is unsupported, with that reason; without joints, or with forces read apart, it runs."""
    hinged = Scene(bodies=(ground(), _bob()), joints=(Joint("revolute", "bob"),))
    free = Scene(bodies=(ground(), _bob()))
    forces = frozenset({"contact_forces"})
    base = dict(dimensions=frozenset({3}), shapes=frozenset({"sphere", "plane"}), native_restitution=True,
                static_kinetic=False, contact_forces=True, iterations=False, joints=frozenset({"revolute"}),
                coordinates="maximal")
    from_momenta = Capabilities(**base, contact_forces_beside_joints=False)
    assert "joints' impulses change too" in from_momenta.cannot_run(hinged, forces)
    assert from_momenta.cannot_run(free, forces) is None and from_momenta.cannot_run(hinged) is None
    assert Capabilities(**base).cannot_run(hinged, forces) is None
    for engine in ("box2d", "box3d"):
        try:
            assert not registry.get(engine).capabilities.contact_forces_beside_joints, engine
        except registry.EngineError:
            continue  # not installed


def test_a_bad_joint_in_a_users_case_is_one_line_and_exit_2(tmp_path):
    (tmp_path / "cases").mkdir()
    (tmp_path / "cases" / "mine.py").write_text(textwrap.dedent("""
        from cases.family import CaseFamily, Check
        from cases.scene import Body, Joint, Scene, Sphere
        FAMILY = CaseFamily(
            name="my_hinge", summary="", source="", grid=({"a": 1},),
            scene=lambda p: Scene(bodies=(Body("bob", Sphere(0.1), mass=1.0),),
                                  joints=(Joint("revolute", "bob", axis=(0, 0, 0)),)),
            duration=lambda p: 1.0, observe=lambda t, p: {"x": 0.0},
            expect=lambda p, dt: [Check("x", "m", 0.0, 0.1, "abs", "why")])
    """))
    out = subprocess.run([sys.executable, "-m", "physval", "run", "--cases-dir", str(tmp_path / "cases"),
                          "--out", str(tmp_path / "out"), "--engines", "mujoco"], capture_output=True, text=True)
    assert out.returncode == 2, out.stderr
    assert "my_hinge[a=1]: joints[0].axis = (0, 0, 0): must have a length > 0" in out.stderr
    assert len(out.stderr.strip().splitlines()) == 1 and "Traceback" not in out.stderr
    assert not (tmp_path / "out" / "results.csv").exists()


# --- the pendulum's graders against integrators of known order -------------------------------

def _swing(p, dt: float, symplectic: bool) -> Trajectory:
    """The pendulum of variant `p` stepped in its angle: symplectic Euler (velocity, then
    position with the new velocity) or explicit Euler (position with the old velocity)."""
    I_p = pendulum.pivot_inertia(p["dim"])
    mgL = pendulum.MASS * G * pendulum.LENGTH
    n = round(pendulum.duration(p) / dt)
    th, w = math.radians(p["amplitude"]), 0.0
    rows = np.zeros((n + 1, 13))
    for k in range(n + 1):
        s, c = math.sin(th), math.cos(th)
        L = pendulum.LENGTH
        rows[k, 0:3] = (L * s, 0.0, pendulum.PIVOT[2] - L * c)
        rows[k, 3:7] = (math.cos(-th / 2), 0.0, math.sin(-th / 2), 0.0)  # turned with the arm (unused by E)
        rows[k, 7:10] = (L * c * w, 0.0, L * s * w)
        rows[k, 10:13] = (0.0, -w, 0.0)  # theta grows turning about -y
        a = -mgL * s / I_p
        if symplectic:
            w += a * dt
            th += w * dt
        else:
            th, w = th + w * dt, w + a * dt
    return Trajectory(dt=dt, t=np.arange(n + 1) * dt, states={"bob": rows})


@pytest.mark.parametrize("params", [p for p in pendulum.GRID if p["joint"] == "revolute"], ids=pendulum.variant_id)
def test_pendulum_checks_pass_symplectic_euler_and_catch_explicit_euler(params):
    dt = pendulum.FAMILY.dt_for(params)
    checks = {c.metric: c for c in pendulum.expect(params, dt)}

    def misses(traj):
        got = pendulum.observe(traj, params)
        return {m for m, c in checks.items() if abs(got[m] - c.expected) > c.tolerance}

    assert misses(_swing(params, dt, symplectic=True)) == set()
    assert misses(_swing(params, dt, symplectic=False)) == {"period", "energy_drift"}


def test_pendulum_period_is_the_elliptic_integral():
    w0 = pendulum.small_frequency()
    assert pendulum.period(1e-6, w0) == pytest.approx(2 * math.pi / w0, rel=1e-12)
    # Landau & Lifshitz: T = T_0 (1 + theta_0^2 / 16 + 11 theta_0^4 / 3072 + ...)
    th = math.radians(20.0)
    assert pendulum.period(th, w0) == pytest.approx(2 * math.pi / w0 * (1 + th**2 / 16 + 11 * th**4 / 3072), rel=1e-6)


# --- the engines that declare joints and loads ---------------------------------------------

@pytest.mark.parametrize("engine", engines_declaring(lambda c: c.joint_limits and "revolute" in c.joints))
def test_a_revolute_limit_stops_the_swing_where_the_scene_says(engine):
    """Let go at 60 deg, the bob swings back towards the vertical, a turn about +y (positive:
    cases.scene.Joint); the limit's upper bound 0.3 rad stops it at 60 deg - 0.3 rad. The
    unlimited swing passes through the vertical, and a limit turned the wrong way would stop
    it at 60 deg - 1 rad. This checks the mapping (which way, where), not the limit's
    stiffness: the stop must lie nearer the limit than halfway to the reversed limit's stop
    (a soft limit gives: Box2D's soft rows 0.085 rad, Box3D's 0.100 rad, measured), and a
    limit may not stop the swing early by more than 0.05 rad (MuJoCo's soft row acts as it
    nears the bound)."""
    adapter = adapter_or_skip(engine)
    dim = 3 if 3 in adapter.capabilities.dimensions else 2
    th0 = math.radians(60.0)
    bob = Body("bob", ball(0.05, dim), mass=1.0, position=(0.5 * math.sin(th0), 0.0, 1.0 - 0.5 * math.cos(th0)))
    least = {}
    for limits in (None, (-1.0, 0.3)):
        hinge = Joint("revolute", "bob", anchor=(0.0, 0.0, 1.0), axis=(0.0, 1.0, 0.0), limits=limits)
        sim = adapter.build(Scene(bodies=(bob,), joints=(hinge,), dimension=dim), Settings(dt=1e-3))
        theta = []
        for _ in range(500):
            sim.step()
            x = sim.states()["bob"]
            theta.append(math.atan2(x[0], 1.0 - x[2]))
        sim.close()
        least[limits] = min(theta)
    stop, reversed_stop = th0 - 0.3, th0 - 1.0
    assert (stop + reversed_stop) / 2 < least[(-1.0, 0.3)] < stop + 0.05
    assert least[None] < 0.0


@pytest.mark.parametrize("engine", engines_declaring(lambda c: c.loads))
def test_a_load_accelerates_at_force_over_mass(engine):
    """A free ball, no gravity, pushed by F = 2 N along x and turned by 0.01 N m about y:
    after 100 steps of 1 ms, v = F t / m = 0.2 m/s and w = tau t / I = 0.1 rad/s (I = 0.01 kg
    m^2). Exact in every consistent integrator; 1e-4 relative allows float32."""
    adapter = adapter_or_skip(engine)
    dim = 3 if 3 in adapter.capabilities.dimensions else 2
    body = Body("ball", ball(0.1, dim), mass=1.0, inertia=(0.01, 0.01, 0.01), position=(0, 0, 1))
    scene = Scene(bodies=(body,), gravity=(0, 0, 0), dimension=dim,
                  loads=(Load("ball", force=(2.0, 0.0, 0.0), torque=(0.0, 0.01, 0.0)),))
    sim = adapter.build(scene, Settings(dt=1e-3))
    assert "load" in sim.effects
    for _ in range(100):
        sim.step()
    state = sim.states()["ball"]
    sim.close()
    assert state[7] == pytest.approx(0.2, rel=1e-4)
    assert state[11] == pytest.approx(0.1, rel=1e-4)


@pytest.mark.parametrize("motion", ["slow mode", "fast mode"])
def test_double_pendulum_modes_are_the_linear_normal_modes_at_2_deg(motion):
    """The expected period (the full equations integrated, read at their zero crossings) is
    the linear mode's 2 pi / w to the O(theta^2) shift at 2 deg: 1e-4 for the slow mode (a
    single pendulum's theta^2/16 is 7.6e-5), 2e-3 for the fast one, whose opposed arms meet
    the coupling cos(theta_1 - theta_2) and the theta'^2 terms at their difference (measured
    1.1e-3); and the two modes differ: the start shapes are the modes'."""
    from cases import double_pendulum as dp
    w, shapes = dp.normal_modes(3)
    k = 0 if motion == "slow mode" else 1
    T, _ = dp._swing(motion, 3, 1e-3)
    assert T == pytest.approx(2 * math.pi / w[k], rel=1e-4 if k == 0 else 2e-3)
    assert w[0] < w[1] and shapes[0, 0] * shapes[1, 0] > 0 > shapes[0, 1] * shapes[1, 1]  # in phase, then opposed


def test_rigid_motions_and_scalings_do_not_apply_to_jointed_scenes():
    """They move the bodies, not yet the joints' anchors and axes or the loads: a moved
    scene would hang its bodies on the old anchors, so the relation says it does not apply."""
    from cases import relations
    hinged = pendulum.scene(pendulum.GRID[0])
    moved = [r for r in relations.RELATIONS if isinstance(r, (relations.Motion, relations.Scale))]
    assert moved and all(r.applies(hinged) == "the scene has joints or loads, which this relation does not "
                                              "transform yet" for r in moved)
    assert all(r.applies(Scene(bodies=(_bob(),))) is None for r in moved)


def test_pinch_grasp_holds_exactly_at_2_mu_F_equal_to_m_g():
    from cases import pinch_grasp as pg
    assert pg.holds({"ratio": 1.0, "dim": 3}) and not pg.holds({"ratio": 0.999, "dim": 3})
    mu = pg.friction({"ratio": 0.8, "dim": 3})
    assert 2 * mu * pg.F == pytest.approx(0.8 * pg.MASS * G)
    assert pg.sliding_acceleration(mu) == pytest.approx(0.2 * G)
    # a slipping block stays between the pads for the whole run: at the grid's lowest ratio
    # (0.8) it falls (1 - 0.8) g T^2 / 2, less than the pads reach below it
    lowest = min(p["ratio"] for p in pg.GRID)
    assert (1 - lowest) * G * pg.T**2 / 2 < pg.PAD_HALF[2] - pg.HALF


def test_the_pinch_grasps_ball_touches_each_pad_at_one_point_and_keeps_the_blocks_ids():
    """The ball beside the block: the block's ids stay as they were (its bands are keyed by
    them), the ball's carry ',ball'; the ball (radius HALF) touches each pad's inner face at
    one point on the x axis through its centre, where the two frictions' moments cancel
    (the module docstring), and it holds at the block's threshold 2 mu F = m g."""
    from cases import pinch_grasp as pg
    ids = [pg.variant_id(p) for p in pg.GRID]
    assert ids == ["2muF/mg=0.8", "2muF/mg=0.98", "2muF/mg=1.02", "2muF/mg=1.25", "2muF/mg=0.8,2D",
                   "2muF/mg=1.25,2D", "2muF/mg=0.8,ball", "2muF/mg=0.98,ball", "2muF/mg=1.02,ball",
                   "2muF/mg=1.25,ball"]
    for p in pg.GRID:
        if pg.shape_of(p) != "ball":
            continue
        scene = pg.scene(p)
        held, left, right = scene.bodies
        assert held.shape.kind == "sphere" and held.mass == pg.MASS
        for pad, side in ((left, -1.0), (right, 1.0)):
            inner_face = pad.position[0] - side * pad.shape.half_extents[0]
            assert inner_face == pytest.approx(side * held.shape.radius)  # touching, at one point
            assert pad.position[1:] == held.position[1:]  # that point on the ball's x axis
        assert pg.holds(p) == (p["ratio"] >= 1.0)
        names = {c.metric for c in pg.expect(p, 1e-3)}
        assert "spin_rate" in names and ("holding_friction" in names) == (not pg.holds(p))
    # the spin an uneven split by the acceleration's tolerance (m tol_a) drives over T:
    # angular acceleration R m tol_a / (2/5 m R^2)
    tol_a = 1e-6 / 1e-3
    assert pg.spin_tolerance(1e-3) == pytest.approx(pg.HALF * pg.MASS * tol_a / (0.4 * pg.MASS * pg.HALF**2) * pg.T)


@pytest.mark.parametrize("engine, ratio", [("reference", 0.8), ("reference-spook", 0.98)])
def test_the_references_grasp_held_from_turning_slides_at_the_closed_form(engine, ratio):
    """The reference's two pinch-grasp misses (adapters/xfails/reference*.txt) are the block
    turning about the pads' normal, which the indeterminate split of each pad's load over
    its coplanar points drives: the same scene with the block held from turning
    (rotates=False) slides at g - 2 mu F / m within the family's 1e-3 m/s^2 (measured:
    1.962000 and 0.196089), so the friction rows are right."""
    from dataclasses import replace

    from cases import pinch_grasp as pg
    p = {"ratio": ratio, "dim": 3}
    scene = pg.scene(p)
    scene = replace(scene, bodies=(replace(scene.bodies[0], rotates=False),) + scene.bodies[1:])
    sim = registry.get(engine).build(scene, Settings(dt=1e-3))
    vz = []
    for _ in range(round(pg.T / 1e-3)):
        sim.step()
        vz.append(sim.states()["block"][9])
    sim.close()
    t = np.arange(1, len(vz) + 1) * 1e-3
    after = t >= pg.SETTLE
    a = -np.polyfit(t[after], np.array(vz)[after], 1)[0]
    assert a == pytest.approx(pg.sliding_acceleration(pg.friction(p)), abs=1e-3)


@pytest.mark.parametrize("engine", ["reference", "reference-pgs", "reference-lemke", "reference-spook"])
def test_every_reference_formulation_meets_the_ball_grasps_closed_forms(engine):
    """Where the block's grasp is indeterminate (its misses on reference, -spook and -lemke
    are the split's), the ball's is not: each formulation with joints slides it at
    g - 2 mu F / m 20 % and 2 % below the threshold and holds it 2 % above, without spin,
    every check within its tolerance (measured: 1.962000 and 0.196200 m/s^2, spin below
    2e-8 rad/s)."""
    from cases import pinch_grasp as pg
    from physval.core import Context, Job, execute
    from physval.core.context import Resolver
    family = pg.FAMILY
    for v in family.variants:
        if pg.shape_of(v.params) == "ball" and v.params["ratio"] in (0.8, 0.98, 1.02):
            rows = execute(Job(family.name, v, engine), Resolver(Context())).rows
            assert rows and all(r["status"] == "pass" for r in rows), \
                [(v.id, r["metric"], r["measured"], r["status"]) for r in rows if r["status"] != "pass"]


@pytest.mark.parametrize("engine", engines_declaring(lambda c: "revolute" in c.joints))
def test_a_jointed_scenes_bulk_read_is_its_states(engine):
    """The harness records through write_state and decode_states: on a swinging hinge they
    give every engine's states() (a MuJoCo tree and a DART or PyBullet jointed body read
    their states another way than their free bodies do)."""
    adapter = adapter_or_skip(engine)
    dim = 3 if 3 in adapter.capabilities.dimensions else 2
    p = {"joint": "revolute", "amplitude": 150.0, "dim": dim}
    sim = adapter.build(pendulum.scene(p), Settings(dt=1e-3))
    for _ in range(50):
        sim.step()
    raw = np.empty((1, sim.state_size()))
    sim.write_state(raw[0])
    decoded = sim.decode_states(raw)[0]
    states = sim.states()
    sim.close()
    for i, name in enumerate(sim.body_order()):
        np.testing.assert_allclose(decoded[i], states[name], rtol=0, atol=1e-12)


# --- closed loops: the four-bar linkage ----------------------------------------------------

def test_freudenstein_closes_the_loop_along_the_whole_turn():
    """theta_4(theta_2) from Freudenstein's equation puts the rocker's end B at the coupler's
    length from the crank's end A for every crank angle, and the start's rocker on the branch."""
    from cases import four_bar as fb
    th2 = np.linspace(0.0, 2 * math.pi, 721)
    th4 = fb.output_angle(th2, fb._branch())
    a = np.stack([fb.A * np.cos(th2), fb.A * np.sin(th2)], 1)
    b = np.stack([fb.D + fb.C * np.cos(th4), fb.C * np.sin(th4)], 1)
    np.testing.assert_allclose(np.linalg.norm(b - a, axis=1), fb.B, rtol=0, atol=1e-12)
    o2, _, b0, o4 = fb.start_points()
    assert math.atan2(b0[1] - o4[1], b0[0] - o4[0]) == pytest.approx(float(fb.output_angle(fb.THETA_2, fb._branch())),
                                                                     abs=1e-12)


def test_four_bar_tolerances_follow_the_step():
    """The loop's one-step gap is the centripetal term, dt^2; the energy's the modified
    energy's, dt; both from the closed-form motion (the crank turns down to where V is back at
    its start value, past a full half turn)."""
    from cases import four_bar as fb
    assert fb.loop_gap(5e-4, 3) == pytest.approx(fb.loop_gap(1e-3, 3) / 4, rel=1e-12)
    checks = {c.metric: c for c in fb.expect({"dim": 3}, 1e-3)}
    assert checks["output_angle_error"].tolerance == pytest.approx(
        2 * fb.loop_gap(1e-3, 3) * fb.rocker_sensitivity(3), rel=1e-12)
    theta_2 = fb._motion(3)["theta"][0]
    assert theta_2.max() == pytest.approx(fb.THETA_2, abs=1e-3) and theta_2.min() < fb.THETA_2 - math.pi


def test_mujoco_closes_the_loop_with_a_connect():
    """The coupler's second joint, which the tree cannot hold, is an equality connect at its
    anchor, in the coupler's frame, to the rocker; with MuJoCo's defaults their solref."""
    adapter_or_skip("mujoco")
    from adapters.mujoco_engine import CONTACT_STEPS, DEFAULT_SOLREF, scene_mjcf
    from cases import four_bar as fb
    scene = fb.scene({"dim": 3})
    xml, knobs = scene_mjcf(scene, Settings(dt=1e-3), 50, CONTACT_STEPS)
    assert xml.count("<connect ") == 1 and list(knobs["loop"]) == ["joints[3]"]
    loop = knobs["loop"]["joints[3]"]
    assert (loop["body1"], loop["body2"], loop["solref"]) == ("coupler", "rocker", [2e-3, 1.0])
    np.testing.assert_allclose(loop["anchor"], [fb.B / 2, 0.0, 0.0], atol=1e-12)  # the coupler's end, on its x axis
    _, defaults = scene_mjcf(scene, Settings(dt=1e-3), 50, CONTACT_STEPS, defaults=frozenset({"solref", "solimp"}))
    assert defaults["loop"]["joints[3]"]["solref"] == list(DEFAULT_SOLREF)


@pytest.mark.parametrize("closing,message", [
    (Joint("prismatic", "b", "a", anchor=(0.5, 0, 1), axis=(1, 0, 0)), "(prismatic) closes a loop"),
    (Joint("revolute", "b", "a", anchor=(0.5, 0, 1), axis=(1, 0, 0)), "closes a loop that is not planar"),
])
def test_mujoco_says_which_loops_it_cannot_close(closing, message):
    adapter = adapter_or_skip("mujoco")
    from adapters.base import Unsupported
    a, b = _bob(name="a", x=0.3), _bob(name="b", x=0.7)
    scene = Scene(bodies=(a, b), gravity=(0, 0, -G), joints=(
        Joint("revolute", "a", None, anchor=(0.0, 0, 1)), Joint("revolute", "b", None, anchor=(1.0, 0, 1)), closing))
    with pytest.raises(Unsupported, match=re.escape(message)):
        adapter.build(scene, Settings(dt=1e-3))


# --- joint friction: the slider on a rail -------------------------------------------------

def test_rail_slide_closed_form_and_its_discrete_stop():
    """x_s = v_0^2 / (2 mu g) at t_s = v_0 / (mu g); semi-implicit Euler with the friction's
    exact decrement stops within the family's tolerance, v_0 dt, of it."""
    from cases import rail_slide as rs
    p = rs.GRID[0]
    mu, v0, dt = p["mu"], p["v0"], rs.FAMILY.dt_for(p)
    assert rs.stop_time(mu, v0) == pytest.approx(v0 / (mu * G)) and rs.stop_distance(mu, v0) == pytest.approx(
        v0 * rs.stop_time(mu, v0) / 2)
    x, v = 0.0, v0
    for _ in range(round(rs.T / dt)):
        v = max(v - mu * G * dt, 0.0)
        x += v * dt
    check = {c.metric: c for c in rs.expect(p, dt)}["stop_distance"]
    assert abs(x - check.expected) <= check.tolerance and abs(x - check.expected) > check.tolerance / 4


@pytest.mark.parametrize("engine", engines_declaring(lambda c: c.joint_friction))
def test_an_engine_that_declares_joint_friction_stops_the_slider(engine):
    """With the friction the launched slider stops where rail_slide says (and reports the
    effect); with none it keeps its speed: the engine simulates the friction it declares."""
    from dataclasses import replace

    from cases import rail_slide as rs
    adapter = adapter_or_skip(engine)
    p = {**rs.GRID[0], "dim": 3 if 3 in adapter.capabilities.dimensions else 2}
    dt, steps = 1e-3, round(rs.T / 1e-3)
    for friction in (True, False):
        scene = rs.scene(p)
        if not friction:
            scene = replace(scene, joints=(replace(scene.joints[0], friction=0.0),))
        sim = adapter.build(scene, Settings(dt=dt))
        for _ in range(steps):
            sim.step()
        x, v = sim.states()["slider"][0] - rs.START[0], sim.states()["slider"][7]
        assert ("joint_friction" in sim.effects) == friction
        sim.close()
        if friction:
            assert abs(x - rs.stop_distance(p["mu"], p["v0"])) <= p["v0"] * dt and abs(v) < rs.REST
        else:
            assert v == pytest.approx(p["v0"], rel=1e-5)


# --- an impact with a pivot: the hinged rod on its stop ------------------------------------

# A finding this check shows (strict: a pass says it is gone); its cause is recorded with the
# family's deviations (adapters/xfails/newton-featherstone.txt, hinged_rod_stop)
STOP_FINDINGS = {
    "newton-featherstone": "Newton 1.8.0's SolverFeatherstone with penalty contact: the plastic rod turns 37.1 deg "
                           "against the stop at 30 deg (MuJoCo, XPBD, Kamino: within the 0.05 rad this test allows)",
}


@pytest.mark.parametrize("engine", [pytest.param(e, marks=pytest.mark.xfail(strict=True, reason=STOP_FINDINGS[e]))
                                    if e in STOP_FINDINGS else e
                                    for e in engines_declaring(lambda c: "revolute" in c.joints)])
def test_a_hinged_body_is_stopped_by_a_static_body(engine):
    """The hinged rod of cases/hinged_rod_stop.py, plastic (e = 0), at dt = 1e-3: its face
    meets the fixed ball at theta_c = 30 deg, and it may not turn past that by more than
    0.05 rad (2 cm at the lever d = 0.4 m: a soft contact's depth, MuJoCo's ~1 cm). Unstopped
    it swings through 90 deg. PyBullet failed this with the body welded (JOINT_FIXED) to a
    massless link on the hinge: its contacts with static bodies got no impulse."""
    from adapters.base import Unsupported
    from cases import hinged_rod_stop as rod
    adapter = adapter_or_skip(engine)
    dim = 3 if 3 in adapter.capabilities.dimensions else 2
    try:
        sim = adapter.build(rod.scene({"e": 0.0, "dim": dim}), Settings(dt=1e-3))
    except Unsupported as exc:
        pytest.skip(str(exc))
    turn = []
    for _ in range(300):  # the contact at 0.19 s
        sim.step()
        x = sim.states()["rod"]
        turn.append(math.atan2(rod.PIVOT[2] - x[2], x[0] - rod.PIVOT[0]))
    sim.close()
    assert rod.THETA_C - 0.01 < max(turn) < rod.THETA_C + 0.05, f"the rod turned to {math.degrees(max(turn)):.1f} deg"


def _collision_matrix(r_a: np.ndarray, r_b: np.ndarray, m: float, I_inv: np.ndarray) -> np.ndarray:
    """Note 001's K_ab = 1/M + r_a*^T I^-1 r_b*: the velocity change at r_a per impulse at r_b."""
    def star(r):
        return np.array([[0.0, -r[2], r[1]], [r[2], 0.0, -r[0]], [-r[1], r[0], 0.0]])
    return np.eye(3) / m + star(r_a).T @ I_inv @ star(r_b)


@pytest.mark.parametrize("dim", [3, 2])
def test_the_stops_collision_matrix_with_the_hinge_is_d2_over_I_p(dim):
    """The contact's K with the hinge's rows eliminated (the Schur complement n^T (K_cc - K_cj
    K_jj^-1 K_jc) n, from note 001's blocks of the free rod at the contact) is d^2 / I_p, so
    the impulse that reverses v_n by (1 + e) gives omega+ = -e omega-, with the pivot still."""
    from cases import hinged_rod_stop as rod
    th = rod.THETA_C
    u, n = np.array([math.cos(th), 0.0, -math.sin(th)]), np.array([-math.sin(th), 0.0, -math.cos(th)])
    r_c = (rod.LEVER - rod.L / 2) * u + rod.W * n     # the contact from the rod's centre
    r_j = -rod.L / 2 * u                              # the pivot from the rod's centre
    R = np.array([[math.cos(th), 0.0, math.sin(th)], [0.0, 1.0, 0.0], [-math.sin(th), 0.0, math.cos(th)]])
    I_inv = R @ np.diag(1.0 / np.array(rod._rod_shape(dim).inertia(rod.MASS))) @ R.T
    K = {(a, b): _collision_matrix(ra, rb, rod.MASS, I_inv) for a, ra in (("c", r_c), ("j", r_j))
         for b, rb in (("c", r_c), ("j", r_j))}
    k = n @ (K["c", "c"] - K["c", "j"] @ np.linalg.solve(K["j", "j"], K["j", "c"])) @ n
    assert k == pytest.approx(rod.LEVER ** 2 / rod.pivot_inertia(dim), rel=1e-12)
    # the impulse for e = 0.5 at omega- = 1 (v_n = d omega- towards the stop, along -n)
    e, w = 0.5, 1.0
    p_c = -(1 + e) * rod.LEVER * w / k * n            # the stop pushes the rod along -n
    p_j = -np.linalg.solve(K["j", "j"], K["j", "c"] @ p_c)
    omega = np.array([0.0, w, 0.0]) + I_inv @ (np.cross(r_c, p_c) + np.cross(r_j, p_j))
    assert omega[1] == pytest.approx(-e * w, rel=1e-12)
    v_centre = np.cross(np.array([0.0, w, 0.0]), -r_j) + (p_c + p_j) / rod.MASS
    assert v_centre + np.cross(omega, r_j) == pytest.approx(np.zeros(3), abs=1e-12)  # the pivot stays


def _stepped_rod(e: float, tau: float, order: str, dt: float) -> float:
    """The family's reading of a 1-DOF rod stepped by symplectic Euler in its angle, the impact
    resolved in the step where the face reaches theta_c (tau: where in its step the release
    puts the contact), the step's gravity acting before, inside or after the impulse."""
    from cases import hinged_rod_stop as rod
    I_p = rod.pivot_inertia(3)
    # start on the exact fall's speed, the contact reached tau after the first step's start
    theta, omega = rod.THETA_C - tau * rod.impact_speed(3), rod.impact_speed(3)
    w = [omega]
    for _ in range(200):
        alpha = rod.MASS * G * rod.L / 2 * math.cos(theta) / I_p
        if theta + (omega + alpha * dt) * dt >= rod.THETA_C and omega > 0:
            omega = {"before": -e * (omega + alpha * dt), "after": -e * omega + alpha * dt,
                     "inside": -e * omega}[order]
        else:
            omega += alpha * dt
        theta += omega * dt
        w.append(omega)
    w = np.array(w)
    turn = int(np.argmax(w < 0))
    return float(-np.min(w[turn:]) / np.max(w[:turn]))


@pytest.mark.parametrize("order", ["before", "inside", "after"])
def test_the_rod_stops_rebound_bound_holds_a_stepped_impact_and_catches_a_wrong_e(order):
    """An ideal stepper meets the family's bound at every contact phase and each order of
    gravity and impulse; one whose restitution is 2 % off does not."""
    from cases import hinged_rod_stop as rod
    dt, e = rod.DT, 0.5
    tol = rod.rebound_bound(e, 3, dt)
    for tau in np.linspace(0.0, 1.0, 11)[:-1]:
        assert abs(_stepped_rod(e, tau * dt, order, dt) - e) <= tol
    assert abs(_stepped_rod(1.02 * e, 0.5 * dt, order, dt) - e) > tol


# --- a joint-limit impact with restitution -------------------------------------------------

@pytest.mark.parametrize("engine", engines_declaring(lambda c: c.joint_limits and "revolute" in c.joints))
def test_a_limits_restitution_is_built_or_said_unsupported(engine):
    """limit_impact[e=0.5]: an engine that declares a restitution at a limit builds it (and
    says so in its simulated effects), one that does not reports the variant unsupported
    naming it, never a plastic limit in its place."""
    from adapters.base import Unsupported
    from cases import limit_impact
    adapter = adapter_or_skip(engine)
    dim = 3 if 3 in adapter.capabilities.dimensions else 2
    scene = limit_impact.scene({"e": 0.5, "dim": dim})
    if not adapter.capabilities.limit_restitution:
        assert "restitution at a joint limit" in adapter.capabilities.cannot_run(scene)
        with pytest.raises(Unsupported, match="restitution at a joint limit"):
            adapter.build(scene, Settings(dt=1e-3))
        return
    sim = adapter.build(scene, Settings(dt=1e-3))
    assert "limit_restitution" in sim.effects
    sim.close()
    plastic = adapter.build(limit_impact.scene({"e": 0.0, "dim": dim}), Settings(dt=1e-3))
    assert "limit_restitution" not in plastic.effects
    plastic.close()


def test_a_plastic_limit_that_never_stops_the_rod_fails_limit_impact():
    """limit_impact[e=0]: a plastic limit's rebound ratio (0) is also what a rod that swings
    through a missing limit reads, so that check alone cannot see the limit; the impact
    speed does: run on without the limit the rod is 0.49 rad/s faster at the end (gravity
    for the 0.02 s after theta_c), 48 tolerances off. The reference, with and without it."""
    from dataclasses import replace
    from cases import hinged_rod_stop as rod
    from cases import limit_impact
    p = {"e": 0.0, "dim": 3}
    checks = {c.metric: c for c in limit_impact.FAMILY.expect(p, rod.DT)}
    n = round(rod.duration(p) / rod.DT)
    readings = {}
    for limited in (True, False):
        scene = limit_impact.scene(p)
        if not limited:
            scene = replace(scene, joints=tuple(replace(j, limits=None) for j in scene.joints))
        with registry.get("reference").build(scene, Settings(dt=rod.DT)) as sim:
            states = [sim.states()["rod"]]
            for _ in range(n):
                sim.step()
                states.append(sim.states()["rod"])
        traj = Trajectory(dt=rod.DT, t=np.arange(n + 1) * rod.DT, states={"rod": np.array(states)})
        readings[limited] = limit_impact.FAMILY.observe(traj, p)
    def misses(limited, metric):
        return abs(readings[limited][metric] - checks[metric].expected) > checks[metric].tolerance
    assert not misses(True, "rebound_ratio") and not misses(True, "impact_speed"), readings[True]
    assert misses(False, "impact_speed"), readings[False]


def test_dart_applies_a_load_before_every_step_and_repeats_it():
    """DART clears a body's external force after each World::step: the adapter adds the
    scene's load again before every step, so a pad pressed with F = 10 N (no gravity, no
    contact) keeps accelerating at F / m over 200 steps (not for one step only), and two
    builds in one process give the same state to the bit (the load is not what varies)."""
    pytest.importorskip("dartpy")
    pad = Body("pad", Box((0.02, 0.05, 0.3)), mass=0.5, position=(0.0, 0.0, 1.0))
    scene = Scene(bodies=(pad,), gravity=(0, 0, 0), joints=(Joint("prismatic", "pad", None, anchor=(0.0, 0.0, 1.0),
                                                                 axis=(1.0, 0.0, 0.0)),),
                  loads=(Load("pad", force=(10.0, 0.0, 0.0)),))
    ends = []
    for _ in range(2):
        sim = registry.get("dart").build(scene, Settings(dt=1e-3))
        for _ in range(200):
            sim.step()
        ends.append(sim.states()["pad"].copy())
        sim.close()
    assert ends[0][7] == pytest.approx(10.0 / 0.5 * 0.2, rel=1e-9)
    assert np.array_equal(ends[0], ends[1])
