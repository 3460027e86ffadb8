"""A row of three balls, each touching pair with its own coefficient of restitution
(note 001, "central impact"): the first family whose impacts differ in e from pair to
pair (`Scene.pairs`), so an engine is judged on each pair's coefficient.

Balls 1, 2, 3 (masses m1, m2, m3, frictionless, held from rotating, no gravity) lie on the
x axis with gaps between them; ball 1 moves at v0 towards 2 and 3, which rest. Ball 1
hits ball 2 (pair e12), then ball 2 hits ball 3 (pair e23). Each impact is a central
impact of two bodies alone (the third is a gap away, the impacts 59-179 ms apart where a
compliant contact lasts 16 steps, 16 ms), so the impact model (simultaneous or sequential) plays no part; each keeps
momentum and obeys Newton's law v2' - v1' = -e (v2 - v1):
    v1' = (m1 - e12 m2) v0 / (m1 + m2),        u = v2' = m1 (1 + e12) v0 / (m1 + m2),
    v2'' = (m2 - e23 m3) u / (m2 + m3),         v3'' = m2 (1 + e23) u / (m2 + m3),
and the row stays as it is when v1' <= v2'' <= v3'' (no third impact; `impacts` checks
this for each variant, tests/test_closed_forms_pairs.py against an event-driven run).

Every pair of the three is a pair of the table an adapter undoes its engine's combination
rule for, so every pair must meet in some variant: in the row 1-2-3 balls 1 and 3 never
touch, so each table also runs as the row 1-3-2 (ball 3 second: ball 1 strikes 3, then 3
strikes 2; the same closed forms with the roles of 2 and 3 swapped), where they do. The
pair that does not touch in a row takes a value the engines' rules can express with the
other two: the larger of the two that do (the max rule of Box2D and PhysX) or the smaller
(Drake, which sums the pairs' dissipations), with the product (PyBullet, Pymunk, DART)
and the arithmetic mean (Newton) expressing both. No value serves a max rule and Drake's
at once (three balls in a row always leave one pair apart), so each row is in the grid
in both classes, and every engine runs both rows of its class and sees every pair meet
(tests/test_closed_forms_pairs.py); a variant of the other class it reports unsupported:
its rule cannot give that table, whose third pair meets in the other row. An adapter
that ignores the pair table runs every impact at the default; one that inverts the
product rule where its engine combines by max gets other values on the pairs that meet;
one that puts each pair's e on both bodies of a product rule gets e^2.
"""
from __future__ import annotations

import math

from cases.central_impact import velocities_after
from cases.family import CaseError, CaseFamily, Catch, Check, impulse_roundoff, plane_label
from cases.scene import Body, Material, Scene, ball

R = 0.1        # ball radius, m
GAP = 0.1      # between neighbouring balls at the start, m
V0 = 2.0       # speed of ball 1, m/s (every bounce above DART's 0.1 m/s threshold)
BALLS = ("b1", "b2", "b3")

# Grid: in 3D and in 2D, each row (1-2-3 and 1-3-2) with the pair that does not touch at
# the larger of the two that do (max rule: Box2D, PhysX; the larger squared at most the
# smaller, for the product) and at the smaller (Drake, whose summed dissipations need it;
# the larger at most twice the smaller, for the mean). 1-2-3 has the hard impact first;
# 1-3-2 in 3D a heavy ball 3 in the middle, so ball 1 bounces back, and in 2D the soft
# impact first.
GRID = (
    {"e12": 0.7, "e23": 0.5, "e13": 0.7, "m": "1:1:1", "row": "1-2-3", "dim": 3},
    {"e12": 0.7, "e23": 0.4, "e13": 0.4, "m": "1:1:1", "row": "1-2-3", "dim": 3},
    {"e12": 0.6, "e23": 0.6, "e13": 0.4, "m": "1:1:4", "row": "1-3-2", "dim": 3},
    {"e12": 0.4, "e23": 0.4, "e13": 0.7, "m": "1:1:1", "row": "1-3-2", "dim": 3},
    {"e12": 0.5, "e23": 0.3, "e13": 0.5, "m": "1:2:1", "row": "1-2-3", "dim": 2},
    {"e12": 0.7, "e23": 0.4, "e13": 0.4, "m": "1:1:1", "row": "1-2-3", "dim": 2},
    {"e12": 0.7, "e23": 0.5, "e13": 0.7, "m": "1:1:1", "row": "1-3-2", "dim": 2},
    {"e12": 0.4, "e23": 0.4, "e13": 0.7, "m": "1:1:1", "row": "1-3-2", "dim": 2},
)


def masses(p) -> tuple[float, float, float]:
    """(m1, m2, m3) of the balls b1, b2, b3."""
    m1, m2, m3 = (float(m) for m in p["m"].split(":"))
    return m1, m2, m3


def row(p) -> tuple[str, str, str]:
    """The balls along +x: b1 first, then the one it strikes, then the last."""
    return tuple(f"b{i}" for i in p.get("row", "1-2-3").split("-"))


def pair_e(p, a: str, b: str) -> float:
    return p["e" + "".join(sorted((a[1], b[1])))]


# --- closed forms ---------------------------------------------------------------------

def impacts(m1, m2, m3, e12, e23, v0):
    """Velocities of three balls in a row after the impacts first-second, then
    second-third (note 001, central impact, twice), and whether the row then stays apart
    (no third impact)."""
    v1, u = velocities_after(m1, m2, v0, 0.0, e12)
    v2, v3 = velocities_after(m2, m3, u, 0.0, e23)
    return (v1, v2, v3), v1 <= v2 <= v3


def final_velocities(p) -> tuple[float, float, float]:
    """(v1, v2, v3) of the balls b1, b2, b3 after both impacts."""
    first, mid, last = row(p)
    m = dict(zip(BALLS, masses(p)))
    v, separate = impacts(m[first], m[mid], m[last], pair_e(p, first, mid), pair_e(p, mid, last), V0)
    if not separate:
        raise CaseError(f"pair_restitution {variant_id(p)}: the row meets again after the second impact; "
                        "the closed form covers two impacts only")
    by_name = dict(zip((first, mid, last), v))
    return tuple(by_name[n] for n in BALLS)


def impact_times(p) -> tuple[float, float]:
    """When ball 1 meets the second ball of the row, and that one the third (s)."""
    first, mid, _ = row(p)
    m = dict(zip(BALLS, masses(p)))
    _, u = velocities_after(m[first], m[mid], V0, 0.0, pair_e(p, first, mid))
    t1 = GAP / V0
    return t1, t1 + GAP / u


# --- scene ----------------------------------------------------------------------------

def scene(p) -> Scene:
    dim = p.get("dim", 3)
    place = {name: i for i, name in enumerate(row(p))}
    bodies = tuple(Body(name, ball(R, dim), mass=m, position=(place[name] * (2 * R + GAP), 0.0, 0.0),
                        velocity=(V0 if name == "b1" else 0.0, 0.0, 0.0), rotates=False)
                   for name, m in zip(BALLS, masses(p)))
    return Scene(bodies=bodies, gravity=(0.0, 0.0, 0.0),
                 material=Material(e=p["e13"]),
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
    order = f",row={p['row']}" if p.get("row", "1-2-3") != "1-2-3" else ""
    return f"e12={p['e12']},e23={p['e23']},e13={p['e13']},m={p['m']}{order}{plane_label(p)}"


FAMILY = CaseFamily(
    name="pair_restitution",
    summary="a row of three balls, each pair its own e: two central impacts in turn, each with its own pair's e, "
            "every pair meeting in some row",
    source="note 001 (CG3 II.5), central impact with a coefficient of restitution, per pair of bodies",
    grid=GRID,
    scene=scene,
    duration=duration,
    observe=observe,
    expect=expect,
    dt=1e-3,
    variant_id=variant_id,
    catches=(
        Catch("combine rule", "e12=0.7,e23=0.5,e13=0.7,m=1:1:1"),
        Catch("combine rule", "e12=0.6,e23=0.6,e13=0.4,m=1:1:4,row=1-3-2"),
        Catch("pair materials", "e12=0.7,e23=0.5,e13=0.7,m=1:1:1"),
        Catch("pair materials", "e12=0.6,e23=0.6,e13=0.4,m=1:1:4,row=1-3-2"),
        Catch("restitution off", "e12=0.7,e23=0.5,e13=0.7,m=1:1:1"),
        Catch("restitution doubled", "e12=0.7,e23=0.5,e13=0.7,m=1:1:1"),
    ),
)
