"""Column impact: an impact through bodies already in contact, where the simultaneous and
the sequential impact model give different closed forms.

Two setups, frictionless balls, no gravity:
- `landing`: a column of two pressed balls (bottom m_1 = 1 kg, top m_2) moving down at V
  lands on the ground (the instant a dropped column lands: a tennis ball on a basketball);
- `strike`: a ball (1 kg) moving at V strikes a row of two pressed balls of 1 kg.
Pressed means the touching pairs start OVERLAP into each other, so that every engine's
collision detection sees their contact in the step of the impact. Exactly touching is a
rounding coin flip: measured, PyBullet and DART take a row placed at distance 0.0 into the
impact's solve, but not a moving pair whose distance is zero only to rounding; Pymunk sees
no contact between discs that do not overlap. Such a contact joins a step later and the
impact passes one pair per step: Pymunk then gives the sequential outcome below to 1e-4
(a struck row of three at e = 1 ends at 0, 0, V), PyBullet and DART a mixture. Gravity is off:
the closed forms hold exactly, and a falling column's internal contact would carry no
force for the engines to see.

Simultaneous model (note 000, "Resolving systems of collisions": the matrix form
J M^-1 J^T gamma = -(1 + c_r) J v- as an LCP, gamma >= 0, each contact's restitution on
its own approach velocity; note 001, "Multiple Contacts"): contacts approaching
at v_n- < 0 must leave at v_n+ >= -e v_n-, the pressed ones (v_n- = 0) at v_n+ >= 0, with
complementary impulses. Every contact ends active (its impulse is positive, see
`simultaneous_velocities`), so the pressed bodies leave as one rigid body and the impact
is the central impact (note 001) of the mover on that body:
- landing: both balls leave the ground together at e V (for any masses);
- strike: the striker leaves at (m_s - e M) V / (m_s + M), the row as one at
  (1 + e) m_s V / (m_s + M), M the row's mass.
tests/test_closed_forms_models.py solves the LCP directly (every active set) and compares.

Sequential model (note 001, "Assumption in CG: collisions are dispersion-free": multiple
contact collisions as a sequence of single contact impacts; note 002, sequential
resolution): the limit of vanishing gaps, every collision a two-body central impact with
restitution e on its own approach velocity, the ground an infinite mass. In both setups at
most one pair approaches at any time (an impact leaves its own pair parting and can only
set the next pair approaching), so the sequence is unique (`sequential_velocities`):
- landing: the bottom ball bounces off the ground at e V and meets the top ball, still
  falling at V; with m_2 / m_1 = 0.1 the top ball leaves at 2.64 V (e = 1; 1.05 V at
  e = 0.5), the bottom one at 0.64 V (0.30 V): the top ball is launched faster than e V;
- strike: a Newton's cradle of three; e = 1 hands the whole velocity on (0, 0, V),
  e = 0.5 gives (0.203, 0.234, 0.5625) V.
tests/test_closed_forms_models.py checks it against an event-driven simulation with
small gaps, real collision times and no sweeps.

Which model a variant checks is a parameter: its `needs` holds "impact_model:<model>"
and an engine that declares another (adapters.base, Capabilities.impact_model) reports it
unsupported with the reason, so each engine is judged against the model it declares. The
`any` variants hold every engine, compliant ones included (contacts as springs: the
outcome depends on the stiffnesses, no closed form), to what every model obeys:
momentum is conserved where nothing external acts (strike), no energy is created
(e <= 1), and at the end no pair (nor the bottom ball and the ground) still approaches.
"""
from __future__ import annotations

import math


from cases.family import IMPACT_ROUNDINGS, CaseFamily, Catch, Check, impulse_roundoff, plane_label
from cases.scene import Body, Material, Scene, ball, ground

R = 0.1          # ball radius, m
V = 2.0          # speed of the moving bodies before the impact, m/s
GAP = 0.01       # m between the mover and what it strikes: 5 steps of travel at dt = 1e-3
OVERLAP = 1e-6   # m: how far the pressed pairs start inside each other (the scene's allowed overlap)
STRIKER = 1.0    # kg, and each ball of the struck row
ROW = 2          # balls in the struck row
BOTTOM = 1.0     # kg, the column's bottom ball
TOP = 0.1        # kg, its top ball: m_2 / m_1 = 0.1, where the models differ most
MODELS = ("simultaneous", "sequential", "any")

# Grid: a light ball on a heavy one landing (m_2/m_1 = 0.1: the models differ most) and a
# ball striking a pressed row of two, each elastic and at e = 0.5, each checked against the
# simultaneous and the sequential closed form and the model-free bounds; 3D and 2D (discs,
# so Pymunk takes part).
GRID = tuple({"setup": setup, "e": e, "model": model, "dim": dim}
             for dim in (3, 2) for setup in ("landing", "strike") for e in (1.0, 0.5) for model in MODELS)


# --- closed forms ---------------------------------------------------------------------------

def central_impact(m_a: float, m_b: float, v_a: float, v_b: float, e: float) -> tuple[float, float]:
    """Velocities after a central impact of a (behind, faster) on b (note 001): momentum
    conserved and v_b' - v_a' = e (v_a - v_b); m_b = inf is a fixed wall."""
    if math.isinf(m_b):
        return v_b - e * (v_a - v_b), v_b
    p = m_a * v_a + m_b * v_b
    return (p - m_b * e * (v_a - v_b)) / (m_a + m_b), (p + m_a * e * (v_a - v_b)) / (m_a + m_b)


def setup_bodies(p) -> tuple[list[float], list[float]]:
    """Masses and velocities along the line of impact, rear to front. Landing: the line
    points down, so the top ball, the bottom ball (both at +V) and the ground (infinite
    mass, at rest); strike: the striker (at +V), then the row."""
    if p["setup"] == "landing":
        return [TOP, BOTTOM, math.inf], [V, V, 0.0]
    return [STRIKER] + [STRIKER] * ROW, [V] + [0.0] * ROW


def simultaneous_velocities(masses, velocities, e: float) -> list[float]:
    """The simultaneous model's outcome (the LCP of note 000) when one contact approaches
    and every other is pressed (v_n- = 0). Every contact ends active, so the pressed bodies
    on either side of the approaching contact leave as one rigid body each, and the impact
    is the central impact of the rear group on the front one. Active: a group's bodies
    all change velocity the same way, so the impulse a pressed contact carries is the
    momentum change of the bodies behind it (or ahead of it), whose sign makes it push."""
    k = next(i for i in range(len(velocities) - 1) if velocities[i] > velocities[i + 1])
    rear, front = masses[:k + 1], masses[k + 1:]
    if len(set(velocities[:k + 1])) > 1 or len(set(velocities[k + 1:])) > 1:
        raise ValueError("a pressed group must move as one before the impact")
    v_rear, v_front = central_impact(sum(rear), sum(front), velocities[0], velocities[-1], e)
    return [v_rear] * len(rear) + [v_front] * len(front)


def sequential_velocities(masses, velocities, e: float) -> tuple[list[float], int]:
    """The sequential model's outcome and its number of pair impacts: while a pair of
    neighbours approaches (the rear one faster), take its central impact with restitution
    e. Raises if two pairs approach at once: the order would then matter and the outcome
    would not be unique."""
    v = list(velocities)
    for count in range(10_000):
        closing = [i for i in range(len(v) - 1) if v[i] - v[i + 1] > 1e-15 * V]
        if not closing:
            return v, count
        if len(closing) > 1:
            raise ValueError(f"pairs {closing} approach at once: the sequence of impacts is not unique")
        i = closing[0]
        v[i], v[i + 1] = central_impact(masses[i], masses[i + 1], v[i], v[i + 1], e)
    raise RuntimeError("the impacts did not end within 10000 pair impacts")


def model_velocities(p) -> tuple[list[float], int]:
    """The variant's model: velocities along the line, rear to front, and how many pair
    impulses a velocity passes through (one per contact when simultaneous)."""
    masses, velocities = setup_bodies(p)
    if p["model"] == "simultaneous":
        return simultaneous_velocities(masses, velocities, p["e"]), len(masses) - 1
    return sequential_velocities(masses, velocities, p["e"])


def outcome(p) -> dict[str, float]:
    """Each ball's velocity after the impact along the scene's axis (landing: z, up
    positive; strike: x), by the variant's model."""
    v, _ = model_velocities(p)
    if p["setup"] == "landing":  # the line points down: top, bottom, ground
        return {"v_top": -v[0], "v_bottom": -v[1]}
    return {"v_striker": v[0], **{f"v_row{i}": v[1 + i] for i in range(ROW)}}


def kinetic_energy(p) -> float:
    masses, velocities = setup_bodies(p)
    return sum(0.5 * m * v * v for m, v in zip(masses, velocities) if math.isfinite(m))


# --- scene ----------------------------------------------------------------------------------

def names(p) -> list[str]:
    return ["bottom", "top"] if p["setup"] == "landing" else ["striker"] + [f"row{i}" for i in range(ROW)]


def scene(p) -> Scene:
    dim = p["dim"]
    material = Material(e=p["e"])
    if p["setup"] == "landing":
        z = R + GAP
        bodies = (ground(),
                  Body("bottom", ball(R, dim), mass=BOTTOM, position=(0, 0, z), velocity=(0, 0, -V), rotates=False),
                  Body("top", ball(R, dim), mass=TOP, position=(0, 0, z + 2 * R - OVERLAP),
                       velocity=(0, 0, -V), rotates=False))
    else:
        row = tuple(Body(f"row{i}", ball(R, dim), mass=STRIKER, position=((2 * R - OVERLAP) * i, 0, 0),
                         rotates=False) for i in range(ROW))
        bodies = (Body("striker", ball(R, dim), mass=STRIKER, position=(-2 * R - GAP, 0, 0), velocity=(V, 0, 0),
                       rotates=False),) + row
    # the pressed overlap, with room for rounding of the positions
    return Scene(bodies=bodies, gravity=(0.0, 0.0, 0.0), material=material, dimension=dim,
                 allowed_overlap=2 * OVERLAP)


def duration(p) -> float:
    # the mover crosses the gap at V; the rest lets a compliant contact (16 steps in MuJoCo)
    # part and the sequence of impacts end
    return GAP / V + 0.05


def needs(p) -> frozenset[str]:
    return frozenset() if p["model"] == "any" else frozenset({f"impact_model:{p['model']}"})


# --- observables ----------------------------------------------------------------------------

def observe(traj, p) -> dict:
    axis = 2 if p["setup"] == "landing" else 0
    v = {name: float(traj.vel(name)[-1, axis]) for name in names(p)}
    sc = scene(p)
    mass = {b.name: b.mass for b in sc.dynamic_bodies}
    out = {f"v_{name}": value for name, value in v.items()}
    energy = sum(0.5 * mass[n] * float(traj.vel(n)[-1] @ traj.vel(n)[-1]) for n in names(p))
    out["energy_gain"] = max(energy - kinetic_energy(p), 0.0)
    if p["setup"] == "landing":  # pairs along the line pointing down: top-bottom, bottom-ground
        closing = [v["bottom"] - v["top"], -v["bottom"]]
    else:
        out["momentum"] = sum(mass[n] * v[n] for n in names(p))
        order = names(p)
        closing = [v[a] - v[b] for a, b in zip(order, order[1:])]
    out["closing_speed"] = max(max(closing), 0.0)
    return out


# --- expectations ---------------------------------------------------------------------------

def expect(p, dt) -> list[Check]:
    # a pressed overlap pushed out through the velocity within a step separates the pair
    # at up to OVERLAP / dt; each pair impulse is exact to solver convergence (1e-6 of V)
    push_out = OVERLAP / dt
    checks = []
    if p["model"] != "any":
        _, n = model_velocities(p)
        tol = 1e-6 * V * n + push_out
        why = (f"{n} pair impulses, each exact to solver convergence (1e-6 of V), and the "
               f"{OVERLAP * 1e6:g} um pressed overlap pushed out within a step ({push_out:.0e} m/s)")
        checks += [Check(metric, "m/s", value, tol, "abs", why) for metric, value in outcome(p).items()]
    e0 = kinetic_energy(p)
    checks += [
        Check("energy_gain", "J", 0.0, 1e-6 * e0 + 0.5 * sum(b.mass for b in scene(p).dynamic_bodies) * push_out**2,
              "abs", "impacts with e <= 1 create no energy: solver convergence (1e-6 of E), plus the energy of "
                     "the pressed overlap pushed out within a step"),
        Check("closing_speed", "m/s", 0.0, 1e-6 * V, "abs",
              "after the impact no pair still approaches: solver convergence (1e-6 of V)"),
    ]
    if p["setup"] == "strike":
        p0 = STRIKER * V
        # as many pair impacts as the sequential model takes (at least the row's contacts),
        # each between two 1 kg balls: m |v| summed <= (1 + e) p0 <= 2 p0
        impacts = max(sequential_velocities(*setup_bodies(p), p["e"])[1], ROW)
        checks.append(Check("momentum", "kg m/s", p0, 1e-9 * p0, "abs",
                            "nothing external acts: equal and opposite impulses conserve momentum to round-off "
                            f"(1e-9 in float64; {IMPACT_ROUNDINGS} roundings of m |v| a sub-step for each of "
                            f"{impacts} pair impacts at the engine's float width)",
                            impulse_roundoff(2.0 * p0, impacts)))
    return checks


def variant_id(p) -> str:
    masses = f",m=1:{TOP:g}" if p["setup"] == "landing" else f",row={ROW}"
    return f"{p['setup']}{masses},e={p['e']},{p['model']}{plane_label(p)}"


FAMILY = CaseFamily(
    name="column_impact",
    summary="a pressed column of two balls landing, a ball striking a pressed row of two: each engine against the "
            "closed form of the impact model it declares (simultaneous or sequential), every engine against "
            "momentum, energy and no pair still approaching",
    source="note 000 (Resolving systems of collisions: matrix form, LCP); note 001 (CG3 II.5), central impact, "
           "multiple contact collisions as a sequence of single impacts; note 002, sequential resolution",
    grid=GRID,
    scene=scene,
    duration=duration,
    observe=observe,
    expect=expect,
    dt=1e-3,
    needs=needs,
    variant_id=variant_id,
    catches=(
        Catch("restitution off", "landing,m=1:0.1,e=0.5,simultaneous"),
        Catch("restitution doubled", "strike,row=2,e=0.5,simultaneous"),
    ),
)
