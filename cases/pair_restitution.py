"""A row of three balls, each touching pair with its own coefficient of restitution
(note 001, "central impact"): the first family whose impacts differ in e from pair to
pair (`Scene.pairs`), so an engine is judged on each pair's coefficient.

Balls 1, 2, 3 (masses m1, m2, m3, frictionless, held from rotating, no gravity) lie on the
x axis with gaps between them; ball 1 moves at v0 towards 2 and 3, which rest. Ball 1
hits ball 2 (pair e12), then ball 2 hits ball 3 (pair e23). Each impact is a central
impact of two bodies alone (the third is a gap away, the impacts 59-192 ms apart where a
compliant contact lasts 16 steps, 16 ms), so the impact model (simultaneous or sequential) plays no part; each keeps
momentum and obeys Newton's law v2' - v1' = -e (v2 - v1):
    v1' = (m1 - e12 m2) v0 / (m1 + m2),        u = v2' = m1 (1 + e12) v0 / (m1 + m2),
    v2'' = (m2 - e23 m3) u / (m2 + m3),         v3'' = m2 (1 + e23) u / (m2 + m3),
and the row stays as it is when v1' <= v2'' <= v3'' (no third impact; `impacts` checks
this for each variant, tests/test_closed_forms_pairs.py against an event-driven run).

Balls 1 and 3 never touch; their pair (the scene's default material) takes e13, which is
a parameter of the grid: min(e12, e23) lets the product and min rules express the pair
table (and Drake's sums of dissipations), max(e12, e23) the max rule (Box2D), with the
middle ball's value non-neutral either way, so the variants test how an adapter undoes
its engine's combination rule. An adapter that ignores the pair table runs every impact
at e13; one that puts each pair's e on both bodies of a product rule gets e^2.
"""
from __future__ import annotations

import math

from cases.central_impact import velocities_after
from cases.family import CaseError, CaseFamily, Check, impulse_roundoff, plane_label
from cases.scene import Body, Material, Scene, ball

R = 0.1        # ball radius, m
GAP = 0.1      # between neighbouring balls at the start, m
V0 = 2.0       # speed of ball 1, m/s (every bounce above DART's 0.1 m/s threshold)
BALLS = ("b1", "b2", "b3")

# Grid: the hard impact first and the soft one second, and the reverse with a heavier
# middle ball (so ball 1 bounces back and the row does not meet again); 2D variants,
# one with the end pair at max(e12, e23) for the max rule of Box2D.
GRID = (
    {"e12": 0.7, "e23": 0.3, "e13": 0.3, "m": "1:1:1", "dim": 3},
    {"e12": 0.3, "e23": 0.8, "e13": 0.3, "m": "1:4:1", "dim": 3},
    {"e12": 0.7, "e23": 0.3, "e13": 0.3, "m": "1:1:1", "dim": 2},
    {"e12": 0.5, "e23": 0.3, "e13": 0.5, "m": "1:2:1", "dim": 2},
)


def masses(p) -> tuple[float, float, float]:
    m1, m2, m3 = (float(m) for m in p["m"].split(":"))
    return m1, m2, m3


# --- closed forms ---------------------------------------------------------------------

def impacts(m1, m2, m3, e12, e23, v0):
    """Velocities of the three balls after the impacts 1-2 then 2-3 (note 001, central
    impact, twice), and whether the row then stays apart (no third impact)."""
    v1, u = velocities_after(m1, m2, v0, 0.0, e12)
    v2, v3 = velocities_after(m2, m3, u, 0.0, e23)
    return (v1, v2, v3), v1 <= v2 <= v3


def final_velocities(p) -> tuple[float, float, float]:
    v, separate = impacts(*masses(p), p["e12"], p["e23"], V0)
    if not separate:
        raise CaseError(f"pair_restitution {variant_id(p)}: balls 1 and 2 meet again after the second impact; "
                        "the closed form covers two impacts only")
    return v


def impact_times(p) -> tuple[float, float]:
    """When ball 1 meets ball 2, and ball 2 meets ball 3 (s)."""
    m1, m2, _ = masses(p)
    _, u = velocities_after(m1, m2, V0, 0.0, p["e12"])
    t1 = GAP / V0
    return t1, t1 + GAP / u


# --- scene ----------------------------------------------------------------------------

def scene(p) -> Scene:
    dim = p.get("dim", 3)
    bodies = tuple(Body(name, ball(R, dim), mass=m, position=(i * (2 * R + GAP), 0.0, 0.0),
                        velocity=(V0 if i == 0 else 0.0, 0.0, 0.0), rotates=False)
                   for i, (name, m) in enumerate(zip(BALLS, masses(p))))
    return Scene(bodies=bodies, gravity=(0.0, 0.0, 0.0),
                 material=Material(e=p["e13"]),  # b1-b3: never touch
                 pairs=(("b1", "b2", Material(e=p["e12"])), ("b2", "b3", Material(e=p["e23"]))),
                 dimension=dim)


def duration(p) -> float:
    # past the second impact, with time for a soft contact (tens of ms) to let go
    return impact_times(p)[1] + 0.15


# --- observables ----------------------------------------------------------------------

def observe(traj, p) -> dict:
    v = [float(traj.vel(name)[-1, 0]) for name in BALLS]
    out = {f"v{i + 1}_after": vi for i, vi in enumerate(v)}
    out["momentum_after"] = sum(m * vi for m, vi in zip(masses(p), v))
    return out


# --- expectations ---------------------------------------------------------------------

def expect(p, dt) -> list[Check]:
    m1, m2, m3 = masses(p)
    # Each frictionless impact without external force is one impulse, exact to the
    # solver's convergence (1e-6 of its closing speed, as in central_impact); the first
    # impact's error enters the second, scaled by at most (1 + e23) m2 / (m2 + m3) < 2.
    tol = 3e-6 * V0
    why = ("two single impulses, no external force: each exact to solver convergence (1e-6 of its closing speed), "
           "the first's error carried into the second")
    checks = [Check(f"v{i + 1}_after", "m/s", v, tol, "abs", why) for i, v in enumerate(final_velocities(p))]
    # energy never rises, so ball i moves at most V0 sqrt(m1 / m_i): each pair's m |v| sums
    # to at most V0 sum(sqrt(m1 m_i)), rounded in the two impacts
    bound = V0 * sum(math.sqrt(m1 * m) for m in masses(p))
    checks.append(Check("momentum_after", "kg m/s", m1 * V0, 1e-9 * m1 * V0, "abs",
                        "equal and opposite impulses conserve momentum to round-off (of the engine's float width)",
                        impulse_roundoff(bound, impacts=2)))
    return checks


def variant_id(p) -> str:
    return f"e12={p['e12']},e23={p['e23']},e13={p['e13']},m={p['m']}{plane_label(p)}"


FAMILY = CaseFamily(
    name="pair_restitution",
    summary="a row of three balls, e12 != e23: two central impacts in turn, each with its own pair's e",
    source="note 001 (CG3 II.5), central impact with a coefficient of restitution, per pair of bodies",
    grid=GRID,
    scene=scene,
    duration=duration,
    observe=observe,
    expect=expect,
    dt=1e-3,
    variant_id=variant_id,
)
