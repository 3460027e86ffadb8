"""The conformance battery: what every adapter must do, independent of any case.

Each check is a plain function named for what it checks; it returns a `Probe` (a small
scene, how long to run it, what to measure, and the checks with their tolerances). Every
probe exists in 3D and in 2D; an engine runs the ones its declared capabilities allow
(the runner reports the rest `unsupported`). Every probe also checks the effect manifest:
the engine simulates exactly the effects the scene calls for.

The battery is the family `conformance` (tag "conformance"), so it flows through the same
core, known-deviation files (`conformance[free_fall,3D]:...`), table and report as the cases.
"""
from __future__ import annotations

from dataclasses import dataclass
from typing import Callable

import numpy as np

from cases.family import CaseFamily, Catch, Check
from cases.observables import free_flight_error, rate, window_mean
from cases.roundoff import position_roundoff, uniform_motion_roundoff
from cases.scene import Body, Material, Scene, ball, cube, ground
from cases.trajectory import Trajectory

G = 9.81
R = 0.1  # ball radius and box half-extent, m


@dataclass(frozen=True)
class Probe:
    scene: Scene
    duration: float
    measure: Callable[[Trajectory], dict]
    expect: Callable[[float], list[Check]]   # dt -> checks
    needs: frozenset = frozenset()


def _ball(dim: int, **kw) -> Body:
    return Body("body", ball(R, dim), mass=1.0, **kw)


def _box(dim: int, **kw) -> Body:
    return Body("body", cube(R, dim), mass=1.0, **kw)


# --- the checks ---------------------------------------------------------------------------

def free_fall_matches_discrete_closed_form(dim: int) -> Probe:
    """z_n of a falling body is the free flight of a consistent one-step integrator,
    z0 - g t^2/2 - c g dt t with c in [-1/2, 1/2] (cases.observables.free_flight_error:
    velocity first, c = 1/2, as in MuJoCo, DART, Bullet; position first, -1/2, as in Pymunk;
    velocity first in 4 sub-steps, 1/8, as in Box2D and Rapier; the exact parabola, 0), to
    round-off; and the continuous z0 - g t^2/2 to first order in dt."""
    z0, T = 10.0, 1.0
    scene = Scene(bodies=(_ball(dim, position=(0, 0, z0), rotates=False),), gravity=(0, 0, -G), dimension=dim)

    def measure(traj):
        z = traj.pos("body")[:, 2]
        return {"discrete_error": free_flight_error(z[:, None], [z0], [0.0], [-G], traj.t, traj.dt),
                "continuous_error": abs(z[-1] - (z0 - G * traj.t[-1] ** 2 / 2))}

    def expect(dt):
        return [Check("discrete_error", "m", 0.0, 1e-9, "abs",
                      "a consistent one-step integrator's free flight (c in [-1/2, 1/2]) is exact to round-off: "
                      "1e-9 m in float64; at the engine's float width 3 times the error of this fall stepped in "
                      "that arithmetic (cases/roundoff.py)",
                      roundoff_at=position_roundoff(max(1, round(T / dt)), dt, [z0], [0.0], [-G])),
                Check("continuous_error", "m", 0.0, G * T * dt, "abs",
                      "first-order time stepping: every consistent step is within g T dt / 2 of g t^2 / 2")]
    return Probe(scene, T, measure, expect)


def nothing_damps_a_free_body(dim: int) -> Probe:
    """No gravity, no contact: linear and angular velocity stay exactly as they started."""
    v0 = (1.0, 0.0, 0.5) if dim == 2 else (1.0, 0.5, 0.25)
    w0 = (0.0, 3.0, 0.0) if dim == 2 else (0.0, 0.0, 3.0)  # about a principal axis: constant
    scene = Scene(bodies=(_ball(dim, velocity=v0, angular_velocity=w0),), gravity=(0, 0, 0), dimension=dim)

    def measure(traj):
        return {"velocity_change": float(np.linalg.norm(traj.vel("body")[-1] - v0)),
                "spin_change": float(np.linalg.norm(traj.omega("body")[-1] - w0))}

    def expect(dt):
        why = "nothing acts on the body: any change is damping the scene did not ask for"
        return [Check("velocity_change", "m/s", 0.0, 1e-9, "abs", why),
                Check("spin_change", "rad/s", 0.0, 1e-9, "abs", why)]
    return Probe(scene, 2.0, measure, expect)


def a_slow_body_does_not_fall_asleep(dim: int) -> Probe:
    """A body drifting at 1 mm/s keeps drifting for 10 s (sleeping would stop it)."""
    scene = Scene(bodies=(_ball(dim, velocity=(1e-3, 0, 0), rotates=False),), gravity=(0, 0, 0), dimension=dim)

    def measure(traj):
        return {"distance": float(traj.pos("body")[-1, 0] - traj.pos("body")[0, 0])}

    v, T = 1e-3, 10.0

    def expect(dt):
        d = v * T
        # each sub-step adds the same h v: within a binade of x it rounds the same way, half an
        # ulp of x a sub-step; v itself is stored rounded (cases/roundoff.py)
        roundoff = uniform_motion_roundoff(max(1, round(T / dt)), dt, d, v) / d
        return [Check("distance", "m", d, 1e-6, "rel",
                      "uniform motion is integrated exactly (1e-6 in float64; half an ulp of x a sub-step at the "
                      "engine's float width); a sleeping body stops", roundoff)]
    return Probe(scene, T, measure, expect)


def no_gravity_when_the_scene_has_none(dim: int) -> Probe:
    """Zero gravity with a ground present: a body at rest above it stays exactly where it is."""
    scene = Scene(bodies=(ground(), _ball(dim, position=(0, 0, 1.0), rotates=False)), gravity=(0, 0, 0), dimension=dim)

    def measure(traj):
        return {"displacement": float(np.max(np.linalg.norm(traj.pos("body") - traj.pos("body")[0], axis=1)))}

    def expect(dt):
        return [Check("displacement", "m", 0.0, 1e-12, "abs", "nothing acts: the body must not move at all")]
    return Probe(scene, 1.0, measure, expect)


def no_friction_when_mu_is_zero(dim: int) -> Probe:
    """A box sliding on the ground with mu = 0 keeps its speed."""
    scene = Scene(bodies=(ground(), _box(dim, position=(0, 0, R), velocity=(1.0, 0, 0))),
                  gravity=(0, 0, -G), material=Material(e=0.0, mu_s=0.0), dimension=dim)

    def measure(traj):
        return {"speed_after": float(traj.vel("body")[-1, 0])}

    def expect(dt):
        return [Check("speed_after", "m/s", 1.0, 1e-6, "rel",
                      "no friction and no damping: nothing removes horizontal momentum")]
    return Probe(scene, 1.0, measure, expect)


def locked_rotation_stays_locked(dim: int) -> Probe:
    """A ball that may not rotate, sliding with friction: it does not spin, and friction
    decelerates it as a particle, mu g."""
    mu, v0, T = 0.5, 2.0, 0.2
    scene = Scene(bodies=(ground(), _ball(dim, position=(0, 0, R), velocity=(v0, 0, 0), rotates=False)),
                  gravity=(0, 0, -G), material=Material(e=0.0, mu_s=mu), dimension=dim)

    def measure(traj):
        return {"spin": float(np.max(np.abs(traj.omega("body")))),
                "deceleration": -rate(traj, traj.vel("body")[:, 0], T / 2)}

    def expect(dt):
        return [Check("spin", "rad/s", 0.0, 1e-9, "abs", "rotation is locked: not even round-off may turn it"),
                Check("deceleration", "m/s^2", mu * G, 1e-2, "rel",
                      "Coulomb friction on a particle; 1 % leaves room for a soft contact's normal force ripple")]
    return Probe(scene, T, measure, expect)


def _resting_weight(body: Body, dim: int) -> Probe:
    """`body` at rest on the ground: the contact normal forces sum to m g."""
    scene = Scene(bodies=(ground(), body), gravity=(0, 0, -G), material=Material(e=0.0, mu_s=0.5), dimension=dim)

    def measure(traj):
        return {"normal_force": window_mean(traj, traj.force("ground", "body"), 0.5)}

    def expect(dt):
        return [Check("normal_force", "N", body.mass * G, 1e-3, "rel",
                      "momentum balance of a body at rest (mean over 0.5 s)")]
    return Probe(scene, 1.0, measure, expect, needs=frozenset({"contact_forces"}))


def resting_contact_carries_the_weight(dim: int) -> Probe:
    """A box at rest on the ground: the contact normal forces sum to m g."""
    return _resting_weight(_box(dim, position=(0, 0, R)), dim)


def a_resting_ball_carries_its_weight(dim: int) -> Probe:
    """A ball at rest on the ground: its one contact's normal force is m g (the box's check
    on a sphere, so an engine with round shapes only reads its forces here too)."""
    return _resting_weight(_ball(dim, position=(0, 0, R)), dim)


CHECKS = (free_fall_matches_discrete_closed_form, nothing_damps_a_free_body, a_slow_body_does_not_fall_asleep,
          no_gravity_when_the_scene_has_none, no_friction_when_mu_is_zero, locked_rotation_stays_locked,
          resting_contact_carries_the_weight, a_resting_ball_carries_its_weight)
_BY_NAME = {f.__name__: f for f in CHECKS}


# --- the battery as a family --------------------------------------------------------------

def _probe(p) -> Probe:
    return _BY_NAME[p["check"]](p["dim"])


def _observe(traj, p) -> dict:
    probe = _probe(p)
    out = probe.measure(traj)
    asked = probe.scene.effects
    out["unasked_effects"] = float(len(traj.effects - asked))
    out["missing_effects"] = float(len(asked - traj.effects))
    return out


def _expect(p, dt) -> list[Check]:
    probe = _probe(p)
    asked = ",".join(sorted(probe.scene.effects)) or "none"
    return probe.expect(dt) + [
        Check("unasked_effects", "count", 0.0, 0.0, "abs", f"simulate only the effects the scene calls for ({asked})"),
        Check("missing_effects", "count", 0.0, 0.0, "abs", f"simulate every effect the scene calls for ({asked})"),
    ]


FAMILY = CaseFamily(
    name="conformance",
    summary="what every adapter must do: Euler free fall, no damping, no sleeping, no unasked gravity or friction, locked rotation, resting force = weight, the effect manifest",
    source="the adapter contract (adapters/base.py) and the integrators' discrete closed forms",
    grid=tuple({"check": f.__name__, "dim": d} for f in CHECKS for d in (3, 2)),
    scene=lambda p: _probe(p).scene,
    duration=lambda p: _probe(p).duration,
    observe=_observe,
    expect=_expect,
    dt=1e-3,
    variant_id=lambda p: f"{p['check']},{p['dim']}D",
    needs=lambda p: _probe(p).needs,
    tags=frozenset({"conformance"}),
    catches=(
        Catch("gravity", "free_fall_matches_discrete_closed_form,2D"),
        Catch("time step", "free_fall_matches_discrete_closed_form,2D"),
        Catch("damping", "nothing_damps_a_free_body,2D"),
        Catch("friction off", "locked_rotation_stays_locked,2D"),
        Catch("friction doubled", "locked_rotation_stays_locked,2D"),
        Catch("force read-out", "resting_contact_carries_the_weight,2D"),
    ),
)
