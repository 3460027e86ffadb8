"""The broad phase at scale: a thousand bodies or more, a planned set of touching pairs, and
every engine must find exactly those in one step, none missed and none phantom (note 003,
"Collision Detection": the broad phase by bounding volumes culls the n^2 / 2 pairs to the
few that may touch; the narrow phase then measures those).

The scene is a lattice of equal balls at rest, gravity off, frictionless and plastic
(e = 0). Along x the balls come in dimers: the two balls of a dimer overlap by DEPTH (their
centres 2 r - DEPTH apart); every other neighbour, along x between dimers and along y and z,
is GAP apart surface to surface. So the pairs in contact are exactly the dimers (half the
bodies), and every other pair is at least GAP apart: the diagonal neighbours further.

    variant          bodies               pairs in contact   pairs apart
    bodies=64,3D     4 x 4 x 4 balls      32                 1,984
    bodies=64,2D     8 x 8 discs          32                 1,984
    bodies=1000,3D   10 x 10 x 10 balls   500                499,000      (--full)
    bodies=1024,2D   32 x 32 discs        512                523,264      (--full)

The thousand-body lattices are the scale the broad phase exists for, and cost seconds per
engine before a step is taken: the scene's own checks and every adapter walk the n^2 / 2
pairs in Python (CPU time measured for the 1000-ball lattice: 2.4-3.0 s to make and check
the scene, 3.2-3.5 s more to build it in PyBullet or the reference; the step itself 3 ms in
PyBullet, 0.9 s in the reference; 24-63 s a job of wall time on a loaded 2-core machine).
So they run with --full; the 64-body ones pose the same plan in every default run (0.1-5 s
a job). MuJoCo, whose adapter makes every pair of the scene an explicit <pair> (its geoms
collide with nothing else), is given the pairs: there the family checks its pair
collision, not its sweep-and-prune (the 1000-ball job took 266 s of wall time, loaded, for
a step of 66 ms).

GAP is larger than every engine's declared contact margin or speculative distance, so an
engine that reports a separated pair reports a phantom contact, not a look-ahead: PyBullet
keeps points up to its contact breaking threshold (about 3.5 mm, adapters/pybullet_engine.py),
Box2D and Box3D find speculative contacts up to 2 cm apart (four linear slops), Rapier up to
its prediction distance (2 mm), PhysX up to the sum of the two shapes' contact offsets (its
automatic value, 2 % of a shape's width: 0.002 m for these 5 cm balls, 4 mm a pair), MuJoCo,
DART, Drake and the reference at 0 (margins 0).

After the step the engine's contact points (Simulation.contact_points, as its detection
found them at the start of the step) name the pairs it found. Metrics:
- `missed`: planned pairs with no point;
- `phantom`: pairs with a point that are not planned;
- `depth`: the largest error of a found dimer's deepest point against DEPTH, m.
The reference reads the same way: its contacts come through its sort-and-sweep broad phase
(reference_impl/broadphase.py), whose candidate pairs tests/test_broad_phase.py also sets
against the plan.

The wrong answer planted below grows every body by 2 mm (a contact offset or collision
margin left on): each dimer reads 4 mm deeper.
"""
from __future__ import annotations

import itertools

import numpy as np

from cases.family import CaseFamily, Catch, Check
from cases.scene import Body, Material, Scene, ball

DT = 1e-3
R = 0.05        # ball radius, m
DEPTH = 1e-3    # overlap of a dimer's two balls, m
GAP = 0.05      # surface gap between every other pair of neighbours, m (> every engine's margin: module notes)
MASS = 1.0      # kg


def counts(p) -> tuple[int, int, int]:
    """Lattice counts (x, y, z) of a variant: `side` balls a side (x even: dimers along x)."""
    n = p["side"]
    return (n, n, n) if p["dim"] == 3 else (n, 1, n)


def centres(p) -> np.ndarray:
    """(N, 3) ball centres: dimers along x (2 r - DEPTH apart within, 2 r + GAP between), 2 r + GAP
    apart along y and z; in the x-z plane for 2D. Row order: x fastest, then y, then z."""
    dim = p["dim"]
    nx, ny, nz = counts(p)
    pitch = 2 * R + GAP
    within, between = 2 * R - DEPTH, 2 * R + GAP
    xs = np.cumsum([0.0] + [within if k % 2 == 0 else between for k in range(nx - 1)])
    ys = np.arange(ny) * pitch if dim == 3 else np.zeros(1)
    zs = np.arange(nz) * pitch
    return np.array([(x, y, z) for z, y, x in itertools.product(zs, ys, xs)])


def name(k: int) -> str:
    return f"b{k}"


def planned(p) -> set[frozenset[str]]:
    """The pairs in contact: each dimer (bodies 2i and 2i+1 along a row of x)."""
    return {frozenset((name(k), name(k + 1))) for k in range(0, int(np.prod(counts(p))), 2)}


def scene(p) -> Scene:
    dim = p["dim"]
    bodies = tuple(Body(name(k), ball(R, dim), mass=MASS, position=tuple(float(c) for c in x), rotates=False)
                   for k, x in enumerate(centres(p)))
    return Scene(bodies=bodies, gravity=(0.0, 0.0, 0.0), material=Material(e=0.0, mu_s=0.0), dimension=dim,
                 allowed_overlap=DEPTH + 1e-6)


def observe(traj, p) -> dict:
    plan = planned(p)
    deepest: dict[frozenset[str], float] = {}
    for c in traj.last_points():
        pair = frozenset((c.a, c.b))
        deepest[pair] = max(deepest.get(pair, -np.inf), -float(c.gap))
    found = set(deepest)
    hits = [deepest[pair] for pair in plan & found]
    return {
        "missed": float(len(plan - found)),
        "phantom": float(len(found - plan)),
        "depth": max((abs(d - DEPTH) for d in hits), default=np.inf),
    }


# Depths: a tenth of the 1 mm resting overlap the resting families allow, as the narrow-phase
# family (cases/narrow_phase.py) holds each pair's depth; an exact sphere-sphere routine gives
# it to rounding (float32 engines: 6e-8 of the 1.6 m lattice, 1e-7 m).
PLACE = 1e-4  # m


def expect(p, dt) -> list[Check]:
    n = len(planned(p))
    return [
        Check("missed", "pairs", 0.0, 0.0, "abs",
              f"each of the {n} dimers overlaps by {DEPTH * 1e3:g} mm: a contact the broad phase culls is a "
              "ball that passes through its partner"),
        Check("phantom", "pairs", 0.0, 0.0, "abs",
              f"every other pair is at least {GAP * 1e2:g} cm apart, beyond every engine's contact margin and "
              "speculative distance: a contact there pushes bodies that do not touch"),
        Check("depth", "m", 0.0, PLACE, "abs",
              f"a found dimer's overlap is the {DEPTH * 1e3:g} mm the lattice sets; {PLACE * 1e3:g} mm is a tenth "
              "of the 1 mm resting overlap the resting families allow"),
    ]


FAMILY = CaseFamily(
    name="broad_phase",
    summary="a lattice of balls (discs in 2D) at rest, dimers overlapping by 1 mm and every other pair 5 cm "
            "apart: in one step each engine finds exactly the dimers' contacts (64 bodies; 1000 with --full)",
    source="note 003 (Collision Detection: broad phase by bounding volumes, then the narrow phase); the lattice's "
           "geometry",
    grid=({"side": 4, "dim": 3}, {"side": 8, "dim": 2}),
    full_grid=({"side": 10, "dim": 3}, {"side": 32, "dim": 2}),
    scene=scene,
    duration=lambda p: DT,
    observe=observe,
    expect=expect,
    dt=DT,
    variant_id=lambda p: f"bodies={int(np.prod(counts(p)))},{p['dim']}D",
    needs=frozenset({"contact_geometry"}),  # the points' pair, place, normal and gap; no forces
    catches=(Catch("contact offset", "bodies=64,3D"),),
)
