"""Edge landing: a cube falling tilted lands on one edge (or one corner): a single-point
impact with a lever arm.

The impact (note 004, "The collision matrix" and "Newton Coulomb impulses for rigid
bodies"; note 001, "Inverse Mass Matrix of Contact", "Impact with Friction"). The cube
(mass m, half-extent a, inertia I = 2/3 m a^2 about every axis through its centre) falls
without spin and meets the ground at v_in. Its contact point sits at r from the centre;
an impulse p there changes the contact point's velocity by K p, with the collision matrix
    K = 1/m 1 - r* I^-1 r*        (r* the cross-product matrix of r).
With n = e_z and the approach u = -v_in n (no slip), Newton's law asks u'_n = e v_in.
- Sticking: u' = e v_in n, p = K^-1 (u' - u); kept if |p_t| <= mu p_n.
- Otherwise sliding: j = (1 + e) v_in / n^T K (n - mu t), p = j (n - mu t), with t =
  -p_t / |p_t| of the sticking impulse (there is no initial slip to oppose). In the plane
  of the motion this is Coulomb friction against the slip that results: along the line
  u'_n = e v_in the slip grows with p_t (K's Schur complement is positive) and is zero at
  the sticking impulse, so a friction impulse short of it leaves slip opposite to it.
  Frictionless (mu = 0) is the same with t unused: j = (1 + e) v_in / n^T K n.
Then v' = v + p / m, w' = I^-1 (r x p). For a cube without spin whose lowest feature is
an edge (a tilt about y) or a corner (a tilt about the face diagonal (1, 1, 0)/sqrt 2),
the pose is symmetric about the plane through the centre perpendicular to the tilt
axis, so is the impulse (an edge's two corners share it equally: one impulse at the
edge's midpoint), and the motion stays in that plane: spin about the tilt axis only.
Checked: the centre's velocity along the lever's horizontal direction and vertical, the
spin about the tilt axis, the contact point's rebound e v_in (Newton's law), and no spin
about any other axis. The ratio |p_t| / p_n of the sticking impulse does not depend on e
or v_in: 0.40 for the edge (tilt 15 deg), 0.65 for the corner (12 deg), so mu = 0.3
slides and mu = 0.8 sticks.

That is Newton's restitution law with friction on the whole impulse. With friction and
e > 0 the engines' laws differ here, because K couples the normal and the slide
direction (cases/impact_laws.py): the two-phase law (Box2D, Box3D, Rapier) applies
friction to the compression impulse only and restitution without it, which leaves the
cube sliding faster and spinning harder. Each frictional variant is in the grid once more
under that law (ids ending ",two_phase"), and an engine runs the one of the law it
declares (Capabilities.restitution_law; the other reports unsupported). Poisson's law is
Newton's here: the cube lands without slip, so both phases stick (or slide along the same
direction) and e times the compression impulse is the impulse that restores e v_in.

A hull on an edge: a regular hexagonal prism given as a convex hull (circumradius and
half-height HALF; `Hull` of its twelve corners), turned so that an edge of its bottom
hexagon lies along y, tilted 15 deg about y, lands on that edge (two corners at once,
through each engine's convex-hull collision). The same impulse with the prism's own
inertia: its principal moments (the polyhedral integral cases.scene.Hull computes: with
the corners a from the axis and the faces a from the centre, I_z = 5/12 m a^2, the regular
hexagon's polar moment, and I_x = I_y = m (5/24 a^2 + a^2/3)) turned into the world, I_w = R diag(I) R^T, in K = 1/m 1 - r* I_w^-1 r* and w' = I_w^-1 (r x p).
The tilt about y keeps y a principal axis, so the spin is about y alone and stays so in
free flight. Frictionless and sticking (mu = 0.8), as the cube's edge.

The approach: the cube starts GAP = 1 mm above the ground moving down at the speed that
brings it to V_IN = 2 m/s at the touch (that of a 0.20 m drop), so the run is 30 ms. The
time-stepping error of the outcome is about g dt / v_in (a contact found a step late, the
impact step's gravity: see expect), so the speed and the step set the bands: at 2 m/s and
dt = 2e-4 s they are 0.2 % on the velocities and spin and 0.6 % on the contact point's
rebound, so an engine with e, the inertia, g or mu off by 1 % is flagged. (The family
dropped its cube from 1 cm, 0.44 m/s, at dt = 1e-3 s: bands of 4.4 % and 13 %. A drop
that tall could no longer be trusted to end on the face that was lowest, the energy
argument of cases/tumbling_box.py, so that check left this family: tumbling_box judges
the rest face at the same two poses.)

Reading the impact: the state at the first sample from which the cube flies free again
after the first contact (cases.observables.first_impact; it does, e > 0 lifts the
contact point at e v_in), with the vertical velocity taken back to the moment of touching
along the free fall: v_z + g (t_k - t_touch). Spin and horizontal velocity are constant
in free flight (a cube's inertia is isotropic, so a free cube keeps its angular
velocity). A compliant contact acts over several steps while the cube turns; the reading
then includes that, and the deviation it makes is the engine's.

Sources: note 004 (Umea, Visual Interactive Simulation), collision matrix and the
Newton-Coulomb impulse; note 001 (CG3 II.5), inverse mass matrix of contact, impact with
friction.
"""
from __future__ import annotations

import math

import numpy as np

from cases.family import CaseFamily, Catch, Check, plane_label
from cases.impact_laws import IMPULSE_OF_LAW, law_label, law_needs, law_of, outcomes_differ, with_laws
from cases.observables import first_impact
from cases.scene import Body, Hull, Material, Scene, cube, ground, quat_about_y
from cases.tumbling_box import corners, rotation

HALF = 0.1      # half-extent of the cube, m
M = 1.0         # kg
I = 2.0 / 3.0 * M * HALF**2  # kg m^2, about every axis through the centre (cube and square alike)
G = 9.81
E = 0.5         # restitution: the contact point leaves at e v_in, so the cube flies free to be read
V_IN = 2.0      # speed at the touch, m/s (a 0.20 m drop)
GAP = 1e-3      # height of the lowest point at the start, m
TILT = {"y": 15.0, "diag": 12.0}  # deg: an edge lowest, a corner lowest
T = 0.03        # simulated time, s: the touch at 0.5 ms, then the impact and free flight
DT = 2e-4       # s: the bands are ~ g dt / v_in (expect): 0.2 % and 0.6 % here

# Grid: frictionless, sliding (mu = 0.3) and sticking (mu = 0.8) impacts on an edge (3D: two
# corners at once; 2D: one corner of the square), and a corner landing frictionless and
# sticking.
GRID = tuple({"tilt": "y", "mu": mu, "dim": dim} for dim in (3, 2) for mu in (0.0, 0.3, 0.8)) + \
       tuple({"tilt": "diag", "mu": mu, "dim": 3} for mu in (0.0, 0.8)) + \
       tuple({"tilt": "y", "mu": mu, "dim": 3, "shape": "hull"} for mu in (0.0, 0.8))
# the hull: a regular hexagonal prism about z (circumradius and half-height HALF) turned so
# that an edge of its bottom hexagon lies along y at +x; tilted about y it lands on that edge
HEX_PRISM = Hull(tuple((HALF * math.cos(math.radians(30 + 60 * k)), HALF * math.sin(math.radians(30 + 60 * k)), z)
                       for z in (-HALF, HALF) for k in range(6)))
# its principal moments in closed form (circumradius a = HALF, height 2 HALF): the regular
# hexagon's polar moment 5/12 m a^2 about z, half of it plus the slab's m (2 HALF)^2 / 12 about
# x and y (the engines get the hull's polyhedral moments, cases/scene.py Hull.inertia)
HEX_INERTIA = (M * HALF**2 * 13 / 24, M * HALF**2 * 13 / 24, M * HALF**2 * 5 / 12)


# --- geometry -------------------------------------------------------------------------------

def axis(p) -> np.ndarray:
    """The tilt axis, world frame."""
    return np.array([0.0, 1.0, 0.0]) if p["tilt"] == "y" else np.array([1.0, 1.0, 0.0]) / math.sqrt(2.0)


def orientation(p) -> tuple[float, float, float, float]:
    """TILT degrees about the tilt axis, as a (w, x, y, z) quaternion."""
    angle = math.radians(TILT[p["tilt"]])
    if p["tilt"] == "y":
        return quat_about_y(angle)
    u = axis(p) * math.sin(angle / 2)
    return (math.cos(angle / 2), float(u[0]), float(u[1]), float(u[2]))


def is_hull(p) -> bool:
    return p.get("shape") == "hull"


def vertices(p) -> np.ndarray:
    """The body-frame corners: the cube's (the square's), or the hexagonal prism's."""
    return np.asarray(HEX_PRISM.vertices) if is_hull(p) else corners(HALF, p["dim"])


def inertia(p) -> np.ndarray:
    """The inertia tensor in the world frame at the touch: I for the cube (isotropic), and
    R diag(I_x, I_y, I_z) R^T for the prism (its polyhedral moments; a tilt about y keeps y
    principal, so the spin stays about y)."""
    if not is_hull(p):
        return I * np.eye(3)
    R = rotation(orientation(p))
    return R @ np.diag(HEX_INERTIA) @ R.T


def lever(p) -> np.ndarray:
    """r: from the centre to the contact point at touching, world frame: the mean of the
    lowest vertices (an edge's midpoint, or the one corner)."""
    world = vertices(p) @ rotation(orientation(p)).T
    z = world[:, 2]
    return world[np.isclose(z, z.min(), atol=1e-12)].mean(axis=0)


def release_height(p) -> float:
    """Centre height at the start: GAP above the touching height -r_z."""
    return GAP - lever(p)[2]


def start_speed() -> float:
    """The downward speed at the start that becomes V_IN after falling GAP."""
    return math.sqrt(V_IN**2 - 2.0 * G * GAP)


def touch_time() -> float:
    """When the lowest point reaches the ground: the speed grows from start_speed to V_IN."""
    return (V_IN - start_speed()) / G


def slide_direction(p) -> np.ndarray:
    """Unit horizontal direction from the centre towards the contact point; with e_z it
    spans the plane of the motion. Friction pushes the centre the other way (v_slide < 0)."""
    r = lever(p)
    s = np.array([r[0], r[1], 0.0])
    return s / np.linalg.norm(s)


# --- closed forms ---------------------------------------------------------------------------

def cross_matrix(r) -> np.ndarray:
    """r* with r* x = r x x."""
    return np.array([[0.0, -r[2], r[1]], [r[2], 0.0, -r[0]], [-r[1], r[0], 0.0]])


def collision_matrix(r, inertia_w: np.ndarray | None = None) -> np.ndarray:
    """K = 1/m 1 - r* I^-1 r* of the body against the fixed ground (note 004); I the
    world-frame inertia tensor (default: the cube's, I 1)."""
    r_star = cross_matrix(r)
    I_inv = np.eye(3) / I if inertia_w is None else np.linalg.inv(inertia_w)
    return np.eye(3) / M - r_star @ I_inv @ r_star


def impact_impulse(r, mu: float, e: float, v_in: float, law: str = "newton",
                   inertia_w: np.ndarray | None = None) -> np.ndarray:
    """The impulse p on the body by restitution law `law` (cases/impact_laws.py; Newton's,
    note 004: sticking if it lies in the cone, else sliding against the slip it leaves,
    module docstring)."""
    n = np.array([0.0, 0.0, 1.0])
    return IMPULSE_OF_LAW[law](collision_matrix(r, inertia_w), -v_in * n, n, e, mu, mu)


def impact_speed() -> float:
    return V_IN


def after_impact(p, depth: float = 0.0) -> dict[str, float]:
    """The closed-form state right after the first impact: the centre's velocity along the
    slide direction and vertical, the spin about the tilt axis, the contact point's normal
    velocity, and the spin about the other axes. `depth`: the impulse taken that far above
    the corner (an engine that finds the contact a step late, the corner below the ground,
    may put the contact point anywhere between the corner and the ground's surface)."""
    r = lever(p) + np.array([0.0, 0.0, depth])
    v_in = impact_speed()
    P = impact_impulse(r, p["mu"], E, v_in, law_of(p), inertia(p))
    v = np.array([0.0, 0.0, -v_in]) + P / M
    w = np.linalg.solve(inertia(p), np.cross(r, P))
    return {"v_slide_after": float(v @ slide_direction(p)), "vz_after": float(v[2]),
            "spin_after": float(w @ axis(p)), "contact_rebound": float((v + np.cross(w, r))[2]),
            "off_axis_spin": float(np.linalg.norm(w - (w @ axis(p)) * axis(p)))}


def sticks(p) -> bool:
    """Whether the impact sticks: Newton's sticking impulse inside the friction cone."""
    P = impact_impulse(lever(p), math.inf, E, impact_speed(), inertia_w=inertia(p))
    return bool(np.linalg.norm(P[:2]) <= p["mu"] * P[2])


def law_differs(p, law: str) -> bool:
    """The closed form under `law` is not Newton's (beyond round-off of the impact speed)."""
    newton = {k: v for k, v in p.items() if k != "law"}
    return outcomes_differ(after_impact(dict(newton, law=law)), after_impact(newton), V_IN)


def law_matters(p) -> bool:
    """The restitution laws give this variant different outcomes."""
    return any(law_differs(p, law) for law in IMPULSE_OF_LAW if law != "newton")


# --- scene ----------------------------------------------------------------------------------

def scene(p) -> Scene:
    box = Body("box", HEX_PRISM if is_hull(p) else cube(HALF, p["dim"]), mass=M, position=(0.0, 0.0, release_height(p)),
               orientation=orientation(p), velocity=(0.0, 0.0, -start_speed()))
    return Scene(bodies=(ground(), box), gravity=(0.0, 0.0, -G), material=Material(e=E, mu_s=p["mu"]),
                 dimension=p["dim"])


def duration(p) -> float:
    # the touch at 0.5 ms; a rigid impact is over in a step, MuJoCo's soft contact takes
    # ~20 steps, and the cube must fly free 5 steps to be read: 30 ms leaves room for all
    return T


# --- observables ----------------------------------------------------------------------------

def observe(traj, p) -> dict:
    _, k = first_impact(traj, "box", (0.0, 0.0, -G))
    t_touch = touch_time()
    if k is None:  # it never flew free after its first impact (or never landed): it left the
        v, w = traj.vel("box")[-1], traj.omega("box")[-1]  # ground with what it ends with
    else:
        v = traj.vel("box")[k] + np.array([0.0, 0.0, G * (traj.t[k] - t_touch)])  # back to the touch, free fall
        w = traj.omega("box")[k]
    u = axis(p)
    out = {"v_slide_after": float(v @ slide_direction(p)), "vz_after": float(v[2]), "spin_after": float(w @ u),
           "contact_rebound": float((v + np.cross(w, lever(p)))[2])}
    if p["dim"] == 3:
        out["off_axis_spin"] = float(np.linalg.norm(w - (w @ u) * u))
    return out


# --- expectations ---------------------------------------------------------------------------

def expect(p, dt) -> list[Check]:
    v_in = impact_speed()
    # The state after the impact is linear in the approach speed the engine resolves. A
    # contact found at the first step boundary after the touch (up to dt late) sees up to
    # g dt more speed, and the impact step's gravity adds another g dt before (or is taken
    # up with) the impulse: the speed is v_in to within 2 g dt. The state is read at the
    # end of the impact step, up to 2 dt after the touch, and taken back along free fall:
    # up to 2 g dt on the vertical velocities for the gravity the impact step absorbed.
    # Found a step late, the corner is up to v_in dt below the ground, and the engine may
    # take the impulse anywhere between it and the surface: the closed form with the lever
    # raised by v_in dt bounds what that does (0.1-0.3 % here; the reference puts the
    # point on the surface, measured 0.21 % on the spin at dt = 2e-4).
    rel = 2.0 * G * dt / v_in
    floor = 1e-6 * v_in  # zero by symmetry: solver convergence (1e-6 of the impact speed)
    why = (f"outcome linear in the approach speed, known to 2 g dt = {rel:.2g} of v_in (a contact found up to a "
           f"step late, the impact step's gravity), plus the contact point up to v_in dt = {v_in * dt * 1e3:.2g} mm "
           "above the corner")
    late = "; plus 2 g dt for reading it up to 2 steps after the touch"
    cf, raised = after_impact(p), after_impact(p, v_in * dt)

    def band(metric: str) -> float:
        return rel * abs(cf[metric]) + abs(raised[metric] - cf[metric])

    checks = [
        Check("v_slide_after", "m/s", cf["v_slide_after"], band("v_slide_after") + floor, "abs", why),
        Check("vz_after", "m/s", cf["vz_after"], band("vz_after") + 2 * G * dt, "abs", why + late),
        Check("spin_after", "rad/s", cf["spin_after"], band("spin_after") + floor / HALF, "abs", why),
        Check("contact_rebound", "m/s", cf["contact_rebound"], band("contact_rebound") + 2 * G * dt, "abs",
              "Newton's law at the contact point, e v_in: " + why + late),
    ]
    if p["dim"] == 3:
        checks.append(Check("off_axis_spin", "rad/s", cf["off_axis_spin"], G * dt / HALF, "abs",
                            "a corner moving g dt relative to the centre: one step of gravity a contact has not yet "
                            "cancelled; an edge struck at one corner gives ~1 rad/s"))
    return checks


def variant_id(p) -> str:
    return f"tilt={p['tilt']},mu={p['mu']}{law_label(p)}{plane_label(p)}" + (",hexagonal prism hull" if is_hull(p) else "")


def needs(p) -> frozenset[str]:
    """The restitution law, where it changes the outcome (adapters.base Capabilities.restitution_law)."""
    return law_needs(p, law_matters(p))


# Each variant whose outcome depends on the restitution law also under each other law that
# changes it (cases/impact_laws.py: the two-phase law; Poisson's is Newton's for a body
# landing without slip or spin, which sticks or slides the same way in both phases).
GRID = with_laws(GRID, law_differs)


FAMILY = CaseFamily(
    name="edge_landing",
    summary="a cube (and a hexagonal prism hull) falling tilted at 2 m/s lands on an edge or a corner: velocities "
            "and spin after the single-point impact (collision matrix, Newton-Coulomb impulse)",
    source="note 004 (collision matrix K, Newton-Coulomb impulse); note 001 (CG3 II.5), inverse mass matrix of "
           "contact, impact with friction",
    grid=GRID,
    scene=scene,
    duration=duration,
    observe=observe,
    expect=expect,
    dt=DT,
    needs=needs,
    variant_id=variant_id,
    catches=(
        Catch("restitution off", "tilt=y,mu=0.0"),
        Catch("restitution doubled", "tilt=y,mu=0.0"),
        Catch("inertia", "tilt=y,mu=0.0"),
        Catch("friction off", "tilt=y,mu=0.3"),
        Catch("friction doubled", "tilt=y,mu=0.3"),
        Catch("restitution law", "tilt=y,mu=0.3"),
        Catch("restitution law", "tilt=y,mu=0.8"),
    ),
)
