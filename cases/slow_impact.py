"""Slow impact: a ball moving at 0.02, 0.1 or 0.5 m/s meets the ground in zero gravity
with e = 0.5 and leaves at e v.

FIRST TO TEST: restitution at low approach speeds. Engines switch restitution off below a
threshold speed (PyBullet's restitutionVelocityThreshold, 0.2 m/s by default; Box2D's
restitution threshold, 1 m/s; DART's bouncing threshold, 0.1 m/s on e v) or resolve a
slow approach speculatively, closing the gap in one step with no bounce; the other
impact families strike at 0.44-3 m/s, above most of these, and the few slow contacts
they have (bounce_series's last bounces) are judged loosely. An adapter should switch a
threshold off; one left on shows here as a ball that does not bounce.

Closed form (note 001, "central impact"): Newton's law of restitution against the fixed
ground, v' = -e v; with no gravity and no friction nothing else acts, so the rebound is
exact whatever the step and wherever the step boundary falls relative to the touch.
The ball starts 2.5 v dt above the ground, so the touch falls inside a step (a
speculative engine sees the gap closing within its next step, a late one finds an
overlap of up to v dt). The velocity is read when the ball flies free again
(cases.observables.first_impact).
"""
from __future__ import annotations

from cases.family import CaseFamily, Catch, Check, plane_label
from cases.observables import first_impact
from cases.scene import Body, Material, Scene, ball, ground

R = 0.1      # m
M = 1.0      # kg
E = 0.5
DT = 1e-3    # s: the rebound is exact at any step (no gravity, one contact)
SPEEDS = (0.02, 0.1, 0.5)  # m/s: below DART's 0.1 on e v, PyBullet's 0.2 and Box2D's 1 m/s thresholds
T = 0.1      # s: the touch at 2.5 ms; MuJoCo's soft contact takes ~20 steps, then 5 free ones to read

GRID = tuple({"v": v, "dim": dim} for dim in (3, 2) for v in SPEEDS)


def scene(p) -> Scene:
    gap = 2.5 * p["v"] * DT
    b = Body("ball", ball(R, p["dim"]), mass=M, position=(0.0, 0.0, R + gap), velocity=(0.0, 0.0, -p["v"]),
             rotates=False)
    return Scene(bodies=(ground(), b), gravity=(0.0, 0.0, 0.0), material=Material(e=E), dimension=p["dim"])


def duration(p) -> float:
    return T


def observe(traj, p) -> dict:
    _, k = first_impact(traj, "ball", (0.0, 0.0, 0.0))
    if k is None:  # it never flew free again (stuck to the ground, or never touched): its last state
        k = len(traj.t) - 1
    v = traj.vel("ball")[k]
    return {"rebound": float(v[2]), "tangential": float(abs(v[0]) + abs(v[1]))}


def expect(p, dt) -> list[Check]:
    v = p["v"]
    tol = 1e-6 * v
    why = "one impulse, no other force: exact to solver convergence (1e-6 of the approach speed) at any step"
    return [Check("rebound", "m/s", E * v, tol, "abs", "Newton's law, v' = -e v: " + why),
            Check("tangential", "m/s", 0.0, tol, "abs", "a frictionless central impact has no tangential impulse: "
                  + why)]


def variant_id(p) -> str:
    return f"v={p['v']:g}{plane_label(p)}"


FAMILY = CaseFamily(
    name="slow_impact",
    summary="a ball meets the ground at 0.02, 0.1 and 0.5 m/s in zero gravity with e = 0.5: rebound e v, below the "
            "speeds at which engines switch restitution off by default",
    source="note 001 (CG3 II.5), central impact, Newton's law of restitution",
    grid=GRID,
    scene=scene,
    duration=duration,
    observe=observe,
    expect=expect,
    dt=DT,
    variant_id=variant_id,
    catches=(
        Catch("restitution threshold", "v=0.1"),
        Catch("restitution off", "v=0.5"),
        Catch("restitution doubled", "v=0.5"),
    ),
)
