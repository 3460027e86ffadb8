"""A joint-limit impact with restitution: the hinged rod of cases/hinged_rod_stop.py, its
stop now the hinge's own limit.

The rod (mass m, length L, one end on a hinge at the pivot) is let go at rest, horizontal,
and swings down until the hinge's upper limit, theta_c, stops it; the joint's restitution at
its limit is e (cases.scene.Joint.limit_e). A limit is a unilateral row on the joint's own
coordinate (the joint's rate, Jacobian 1 in theta), so its collision matrix is 1 / I_p and
Newton's law on that row gives omega+ = -e omega- directly: the same rebound as the contact
with the pivot (whose K = d^2 / I_p at the lever d), without a lever, a contact or a normal.

Checks, tolerances and their reasons are hinged_rod_stop's (the fall to theta_c and the
rebound read off the samples: max(1, e) alpha dt / omega- for the ratio, 2 alpha dt for the
impact speed), imported from there. Which engines honour a restitution at a limit is an
adapter's declaration (Capabilities.limit_restitution); the others report it unsupported
with the reason.
"""
from __future__ import annotations


from cases import hinged_rod_stop as rod
from cases.family import CaseFamily, Catch
from cases.scene import Body, Joint, Scene

LOWER = -1.0  # rad: the limit below the start, never met (the rod falls towards theta_c)

# Grid: a plastic limit (e = 0: every engine with limits runs it) and one restitution, in
# 3D and in 2D (the 2D engines' limited revolute joints).
GRID = tuple({"e": e, "dim": dim} for e in (0.0, 0.5) for dim in (3, 2))


def scene(p) -> Scene:
    dim = p["dim"]
    body = Body("rod", rod._rod_shape(dim), mass=rod.MASS, position=(rod.PIVOT[0] + rod.L / 2, 0.0, rod.PIVOT[2]))
    # falling turns the rod about +y (x towards -z): the hinge's coordinate grows to theta_c
    hinge = Joint("revolute", "rod", None, anchor=rod.PIVOT, axis=(0.0, 1.0, 0.0),
                  limits=(LOWER, rod.THETA_C), limit_e=p["e"])
    return Scene(bodies=(body,), gravity=(0.0, 0.0, -rod.G), dimension=dim, joints=(hinge,))


FAMILY = CaseFamily(
    name="limit_impact",
    summary="a hinged rod released onto its hinge's limit, restitution e at the limit: omega+ = -e omega- "
            "(the limit's row on the joint's coordinate)",
    source="note 001 (CG3 II.5): Newton's restitution on one constraint row; the fall of a rigid body about a pivot",
    grid=GRID,
    scene=scene,
    duration=rod.duration,
    observe=rod.observe,
    expect=rod.expect,
    dt=rod.DT,
    variant_id=lambda p: f"e={p['e']:g}" + (",2D" if p["dim"] == 2 else ""),
    # the restitution at the limit planted on the reference's sequential impulses, whose
    # limit row takes limit_e (the rebound ratio sees it off or doubled); the impact speed
    # sees the inertia, planted on DART's plastic limit
    catches=(Catch("restitution off", "e=0.5"), Catch("restitution doubled", "e=0.5"),
             Catch("inertia", "e=0", "dart")),
)

