"""The narrow phase against exact geometry: for a catalogue of convex pairs at known poses,
the contact normal, depth and points each engine's collision detection reports (note 003,
"Collision Detection": GJK on the Minkowski difference, the narrow phase).

Each variant places a dynamic body ("top") overlapping a static one ("base") by a known
depth, at rest, gravity off, frictionless, and takes one step: the points the engine
reports after it (Simulation.contact_points, as its detection found them at the start of
the step) are set against the geometry, which is exact for every pair:

    pair               base / top                         n (base to top)   depth   exact contact region
    sphere-capsule     capsule r 0.1 h 0.3 / ball r 0.2   +x                0.05    a point on the capsule's side
    crossed-capsules   two capsules r 0.1 h 0.5, crossed  +z                0.05    a point where the axes cross
    box-cylinder-end   cube 1 m / cylinder on its end     +z                0.01    a disc of r 0.2 on the face
    box-cylinder-side  cube 1 m / cylinder on its side    +z                0.01    a segment of 0.6 m on the face
    hull-face          two cubes as hulls, face on face   +z                0.02    a 0.7 x 0.8 m rectangle
    hull-edge          a cube hull on an edge             +z                0.02    a segment of 0.9 m to the face's edge
    hull-vertex        a cube hull on a corner            +z                0.02    a point

The edge is 0.1 m along itself off centre so that its ends do not lie in the base's side
faces: a generic pose, not a tie between coplanar faces. The reference's GJK is checked on
this catalogue itself, against the exact geometry and against python-fcl
(tests/reference/test_ref_core_gjk.py), and `physval bench narrow` times it.

The overlap of a pair is the slab between the base's surface and the top's, `depth` thick
along n, over the region's footprint in the contact plane (a point, segment, rectangle or
disc). An engine may put its points on either surface or between them (MuJoCo: midway;
PyBullet: on each body; PhysX: on the pair's second shape), so a point anywhere in that slab
over the footprint is exact.

Metrics (each point's normal oriented from the base into the top):
- `normal_error`: the largest angle between a reported normal and the exact n, rad;
- `depth`: the deepest reported overlap (-gap) against the exact depth, m;
- `point_offset`: the largest distance of a reported point from the exact region (in the
  contact plane off its footprint, plus along n outside the slab), m;
- `uncovered` (line and patch contacts only): the largest distance in the contact plane
  from a corner of the footprint (a segment's two ends, a rectangle's four corners, a
  disc's centre) to the support polygon of the reported points (their convex hull). A
  line or face contact carried on fewer points than its corners rocks about them (MuJoCo's
  alternating single cylinder contact, issue 36); a disc is carried by any polygon of rim
  points around its centre, so its check is that the centre lies inside it.
An engine that reports no point at all measures infinity on every metric.

The wrong answer planted below grows every dynamic body by 2 mm (a contact offset or
collision margin left on): the depth reads 2 mm deeper.
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from cases.family import CaseFamily, Catch, Check
from cases.scene import Body, Box, Capsule, Cylinder, Hull, Material, Scene, Sphere

DT = 1e-3
H = 0.5  # half-extent of the cubes, m
CUBE = tuple((x, y, z) for x in (-H, H) for y in (-H, H) for z in (-H, H))
S2 = math.sqrt(0.5)
ALONG_X = (S2, 0.0, S2, 0.0)    # body z onto world x
ALONG_Y = (S2, -S2, 0.0, 0.0)   # body z onto world y


def about(axis, angle: float) -> tuple[float, float, float, float]:
    """Quaternion (w, x, y, z) of a rotation by `angle` about `axis`."""
    a = np.asarray(axis, float) / np.linalg.norm(axis)
    return (math.cos(angle / 2), *(float(c) for c in math.sin(angle / 2) * a))


EDGE_DOWN = about((1, 0, 0), math.pi / 4)                     # an edge along x straight down
VERTEX_DOWN = about((1.0, -1.0, 0.0), math.atan(math.sqrt(2)))  # a body diagonal along z: a corner down


@dataclass(frozen=True)
class Pair:
    """A catalogue entry: the two bodies, the exact normal n (base to top), depth, the
    surface level of the base along n (the slab is [surface - depth, surface]), and the
    footprint of the contact region in the contact plane: `corners` (one point, a
    segment's ends, or a rectangle's corners in order) or a disc (`corners` its centre,
    `radius` > 0). `patch`: a line or face contact, whose corners the points must span."""
    base: Body
    top: Body
    n: tuple[float, float, float]
    depth: float
    surface: float
    corners: tuple[tuple[float, float, float], ...]
    radius: float = 0.0
    patch: bool = False


def _catalogue() -> dict[str, Pair]:
    static, top = (lambda shape, **kw: Body("base", shape, static=True, **kw)), \
        (lambda shape, **kw: Body("top", shape, mass=1.0, **kw))
    edge, corner = H * math.sqrt(2.0), H * math.sqrt(3.0)
    return {
        "sphere-capsule": Pair(static(Capsule(0.1, 0.3)), top(Sphere(0.2), position=(0.25, 0.0, 0.1)),
                               (1.0, 0.0, 0.0), 0.05, 0.1, ((0.1, 0.0, 0.1),)),
        "crossed-capsules": Pair(static(Capsule(0.1, 0.5), orientation=ALONG_X),
                                 top(Capsule(0.1, 0.5), position=(0.0, 0.0, 0.15), orientation=ALONG_Y),
                                 (0.0, 0.0, 1.0), 0.05, 0.1, ((0.0, 0.0, 0.1),)),
        "box-cylinder-end": Pair(static(Box((H, H, H))), top(Cylinder(0.2, 0.3), position=(0.1, 0.0, H + 0.3 - 0.01)),
                                 (0.0, 0.0, 1.0), 0.01, H, ((0.1, 0.0, H),), radius=0.2, patch=True),
        "box-cylinder-side": Pair(static(Box((H, H, H))),
                                  top(Cylinder(0.2, 0.3), position=(0.0, 0.1, H + 0.2 - 0.01), orientation=ALONG_X),
                                  (0.0, 0.0, 1.0), 0.01, H, ((-0.3, 0.1, H), (0.3, 0.1, H)), patch=True),
        "hull-face": Pair(static(Hull(CUBE)), top(Hull(CUBE), position=(0.3, 0.2, 2 * H - 0.02)),
                          (0.0, 0.0, 1.0), 0.02, H, ((-0.2, -0.3, H), (H, -0.3, H), (H, H, H), (-0.2, H, H)), patch=True),
        "hull-edge": Pair(static(Hull(CUBE)), top(Hull(CUBE), position=(0.1, 0.1, H + edge - 0.02), orientation=EDGE_DOWN),
                          (0.0, 0.0, 1.0), 0.02, H, ((-0.4, 0.1, H), (H, 0.1, H)), patch=True),
        "hull-vertex": Pair(static(Hull(CUBE)), top(Hull(CUBE), position=(0.1, 0.1, H + corner - 0.02),
                                                    orientation=VERTEX_DOWN),
                            (0.0, 0.0, 1.0), 0.02, H, ((0.1, 0.1, H),)),
    }


CATALOGUE = _catalogue()


# --- the geometry of the footprint, in the contact plane ------------------------------------

def plane_basis(n) -> np.ndarray:
    """(2, 3): two unit vectors spanning the plane normal to n."""
    n = np.asarray(n, float)
    u = np.cross(n, (0.0, 0.0, 1.0) if abs(n[2]) < 0.9 else (1.0, 0.0, 0.0))
    u /= np.linalg.norm(u)
    return np.array([u, np.cross(n, u)])


def _to_segment(q: np.ndarray, a: np.ndarray, b: np.ndarray) -> float:
    ab = b - a
    s = 0.0 if not ab.any() else float(np.clip(np.dot(q - a, ab) / np.dot(ab, ab), 0.0, 1.0))
    return float(np.linalg.norm(q - (a + s * ab)))


def to_convex(q: np.ndarray, corners: np.ndarray) -> float:
    """Distance in the plane from q (2,) to the convex polygon of `corners` (k, 2) in
    counterclockwise order (k = 1: a point, k = 2: a segment); 0 inside."""
    k = len(corners)
    if k == 1:
        return float(np.linalg.norm(q - corners[0]))
    edges = [(corners[i], corners[(i + 1) % k]) for i in range(k if k > 2 else 1)]
    if k > 2 and all((b[0] - a[0]) * (q[1] - a[1]) - (b[1] - a[1]) * (q[0] - a[0]) >= 0.0 for a, b in edges):
        return 0.0
    return min(_to_segment(q, a, b) for a, b in edges)


def hull_2d(points: np.ndarray, tiny: float = 1e-12) -> np.ndarray:
    """The convex hull of 2D points, counterclockwise (Andrew's monotone chain): one point,
    a segment's two ends, or a polygon's corners."""
    pts = sorted({(float(x), float(y)) for x, y in np.round(points / tiny) * tiny})
    if len(pts) <= 2:
        return np.array(pts)

    def half(seq):
        out = []
        for p in seq:
            while len(out) >= 2 and ((out[-1][0] - out[-2][0]) * (p[1] - out[-2][1])
                                     - (out[-1][1] - out[-2][1]) * (p[0] - out[-2][0])) <= 0.0:
                out.pop()
            out.append(p)
        return out[:-1]
    return np.array(half(pts) + half(pts[::-1]))


def _footprint(pair: Pair, basis: np.ndarray) -> np.ndarray:
    return hull_2d(np.asarray(pair.corners) @ basis.T)


def offset(pair: Pair, x) -> float:
    """Distance of point x from the exact contact region: off the footprint in the contact
    plane, plus outside the slab [surface - depth, surface] along n."""
    x = np.asarray(x, float)
    basis = plane_basis(pair.n)
    lateral = max(0.0, to_convex(basis @ x, _footprint(pair, basis)) - pair.radius)
    level = float(np.dot(pair.n, x))
    return lateral + max(0.0, level - pair.surface, pair.surface - pair.depth - level)


def uncovered(pair: Pair, xs) -> float:
    """The largest distance in the contact plane from a corner of the footprint (a disc: its
    centre) to the convex hull of the points `xs`."""
    basis = plane_basis(pair.n)
    support = hull_2d(np.asarray(xs, float) @ basis.T)
    return max(to_convex(basis @ np.asarray(c, float), support) for c in pair.corners)


# --- the family -----------------------------------------------------------------------------

def scene(p) -> Scene:
    pair = CATALOGUE[p["pair"]]
    return Scene(bodies=(pair.base, pair.top), gravity=(0.0, 0.0, 0.0), material=Material(e=0.0, mu_s=0.0),
                 allowed_overlap=pair.depth + 1e-6)


def observe(traj, p) -> dict:
    pair = CATALOGUE[p["pair"]]
    points = [c for c in traj.last_points() if {c.a, c.b} == {"base", "top"}]
    out = {"normal_error": math.inf, "depth": math.inf, "point_offset": math.inf}
    if pair.patch:
        out["uncovered"] = math.inf
    if not points:
        return out
    n = np.array([c.n if c.a == "top" else -np.asarray(c.n) for c in points], float)  # base into top
    n /= np.linalg.norm(n, axis=1)[:, None]
    out["normal_error"] = float(np.arccos(np.clip(n @ np.asarray(pair.n), -1.0, 1.0)).max())
    out["depth"] = max(-float(c.gap) for c in points)
    out["point_offset"] = max(offset(pair, c.x) for c in points)
    if pair.patch:
        out["uncovered"] = uncovered(pair, [c.x for c in points])
    return out


# A contact normal off by an angle a turns a fraction sin(a) of the normal force sideways, as
# a friction coefficient of tan(a) would on a frictionless pair; 1e-3 rad is a coefficient of
# 0.001, a twentieth of the 0.02 by which the friction families resolve mu (incline_threshold
# sets its inclines 1 deg either side of atan(mu_s): (1 + mu^2) x 0.0175 = 0.022 at mu = 0.5).
# Exact geometry gives it to rounding.
NORMAL = 1e-3  # rad
# Depths and points: the resting families allow 1 mm of resting overlap (a solver's
# stabilising depth: cases/resting_blocks.py, cases/lying_cylinder.py); a tenth of it
# (0.1 mm) keeps the narrow phase's share of such a check small. An exact narrow phase (GJK
# and EPA to 1e-10 m, analytic capsule and sphere routines) meets it by six orders.
PLACE = 1e-4  # m


def expect(p, dt) -> list[Check]:
    pair = CATALOGUE[p["pair"]]
    checks = [
        Check("normal_error", "rad", 0.0, NORMAL, "abs",
              f"a normal {NORMAL:g} rad off turns that share of the normal force sideways: a spurious friction "
              "coefficient of 0.001, a twentieth of the 0.02 the friction families resolve"),
        Check("depth", "m", pair.depth, PLACE, "abs",
              f"the overlap the pose sets ({pair.depth:g} m); {PLACE * 1e3:g} mm is a tenth of the 1 mm resting overlap "
              "the resting families allow"),
        Check("point_offset", "m", 0.0, PLACE, "abs",
              f"every point in the overlap (the slab between the surfaces over the exact footprint); {PLACE * 1e3:g} mm "
              "moves the normal force's lever arm by 1e-3 of the 0.1 m bodies"),
    ]
    if pair.patch:
        what = "its centre" if pair.radius else "its corners"
        checks.append(Check("uncovered", "m", 0.0, PLACE, "abs",
                            f"a line or face contact's points span {what}, else the body rocks about them; "
                            f"{PLACE * 1e3:g} mm as for the points"))
    return checks


FAMILY = CaseFamily(
    name="narrow_phase",
    summary="each engine's contact normal, depth and points for a catalogue of convex pairs at known poses "
            "(sphere-capsule, crossed capsules, box-cylinder, hull-hull face/edge/vertex) against exact geometry",
    source="note 003 (Collision Detection: narrow phase, GJK on the Minkowski difference); note 001 (CG3 II.5), "
           "contact types vertex-face, edge-edge; exact geometry of each pose",
    grid=tuple({"pair": name} for name in CATALOGUE),
    scene=scene,
    duration=lambda p: DT,
    observe=observe,
    expect=expect,
    dt=DT,
    variant_id=lambda p: p["pair"],
    needs=frozenset({"contact_geometry"}),  # the points' pair, place, normal and gap; no forces
    catches=(
        Catch("contact offset", "sphere-capsule"),
        Catch("contact offset", "box-cylinder-side"),
    ),
)
