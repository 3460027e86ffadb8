"""What the adapters share about a scene's joints: for the reduced-coordinate ones the
kinematic tree they hang the jointed bodies on (DART's skeleton, PyBullet's multibody,
Drake's MultibodyPlant), the joints that would close a loop in it, and each tree joint's
start rate (the joint velocity that the scene's start velocities of both bodies give); for
all, a joint's frame in a body's frame at the start (local_frame)."""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from adapters.base import Unsupported
from cases import rotations
from cases.scene import Body, Joint, Scene

# A child's start velocity must be its parent's carried along plus the joint's own rate to
# this relative size (of the largest speed in it, m/s or rad/s times the lever): the scenes
# compute one from the other in float64 (cases/elbow_toss.py start_velocities), which leaves
# round-off of a few 1e-16; a scene that moves the two bodies apart is refused.
RATE_TOLERANCE = 1e-9


@dataclass(frozen=True)
class TreeJoint:
    """A scene joint that hangs `joint.body` in the tree: on `parent` (a dynamic body's name,
    or None for the world or a static body), `index` its place in Scene.joints."""
    index: int
    joint: Joint
    parent: str | None


def joint_tree(scene: Scene, loose: frozenset[str] = frozenset()) \
        -> tuple[dict[str, TreeJoint], list[tuple[int, Joint]]]:
    """The kinematic tree of the scene's joints: each jointed dynamic body's TreeJoint, in an
    order where a parent comes before its children (a body's first joint hangs it); and the
    joints (index, joint) that close a loop (a body's second joint, or one whose parent hangs
    on its body), which no tree holds, with the joints of the kinds in `loose` (an engine
    without a tree joint of that kind holds them as constraints between free bodies, as a
    loop's). Unsupported for a static body as a joint's `body`."""
    static = {b.name for b in scene.bodies if b.static}
    tree: dict[str, TreeJoint] = {}
    closing: list[tuple[int, Joint]] = []
    for j, joint in enumerate(scene.joints):
        if joint.body in static:
            raise Unsupported(f"joints[{j}]: {joint.body!r}, a static body, as the joint's `body`: the tree hangs "
                              "the moving body on the other (name the dynamic body as `body`)")
        up = None if joint.parent is None or joint.parent in static else joint.parent
        seen = up
        while seen is not None and seen != joint.body:
            seen = tree[seen].parent if seen in tree else None
        if joint.body in tree or seen == joint.body or joint.kind in loose:
            closing.append((j, joint))
        else:
            tree[joint.body] = TreeJoint(j, joint, up)
    ordered: dict[str, TreeJoint] = {}

    def place(name: str) -> None:
        if name in ordered:
            return
        up = tree[name].parent
        if up is not None and up in tree:
            place(up)
        ordered[name] = tree[name]
    for name in tree:
        place(name)
    return ordered, closing


def _velocity_at(body: Body | None, point: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(linear velocity of the body's material point now at `point`, angular velocity); the
    world (None) or a static body: at rest."""
    if body is None or body.static:
        return np.zeros(3), np.zeros(3)
    w = np.asarray(body.angular_velocity, float)
    return np.asarray(body.velocity, float) + np.cross(w, point - np.asarray(body.position, float)), w


def start_rate(scene: Scene, tj: TreeJoint) -> np.ndarray:
    """The joint's start rate from the scene's start velocities of its body B and parent P:
    B's velocity relative to P (its angular velocity w_B - w_P, and the velocity of B's
    centre relative to P's point there) is what the joint lets through: a revolute joint
    turns at qdot about its axis a (w_rel = qdot a, v_rel = qdot a x (x_B - anchor)), a
    prismatic one slides (w_rel = 0, v_rel = qdot a), a ball turns (w_rel any, v_rel =
    w_rel x (x_B - anchor)), a fixed one holds (both 0). Returns [qdot] (revolute,
    prismatic), w_rel (ball, world frame) or [] (fixed); Unsupported when the two bodies'
    start velocities are not one the joint allows."""
    joint, body = tj.joint, scene.body(tj.joint.body)
    x = np.asarray(body.position, float)
    v_p, w_p = _velocity_at(None if tj.parent is None else scene.body(tj.parent), x)
    if joint.parent is not None and tj.parent is None and any(scene.body(joint.parent).velocity):
        raise Unsupported(f"joints[{tj.index}]: its static parent {joint.parent!r} has a velocity")
    w_rel = np.asarray(body.angular_velocity, float) - w_p
    v_rel = np.asarray(body.velocity, float) - v_p
    a, lever = np.asarray(joint.unit_axis, float), x - np.asarray(joint.anchor, float)
    if joint.kind == "revolute":
        rate = np.array([w_rel @ a])
        w_fit, v_fit = rate[0] * a, np.cross(rate[0] * a, lever)
    elif joint.kind == "prismatic":
        rate = np.array([v_rel @ a])
        w_fit, v_fit = np.zeros(3), rate[0] * a
    elif joint.kind == "ball":
        rate = w_rel
        w_fit, v_fit = w_rel, np.cross(w_rel, lever)
    else:
        rate = np.zeros(0)
        w_fit, v_fit = np.zeros(3), np.zeros(3)
    size = max(np.abs(np.concatenate([v_rel, v_p, np.cross(w_rel, lever), np.cross(w_p, lever)])).max(), 1.0)
    miss = max(np.abs(w_rel - w_fit).max() * max(np.linalg.norm(lever), 1.0), np.abs(v_rel - v_fit).max())
    if miss > RATE_TOLERANCE * size:
        raise Unsupported(f"joints[{tj.index}] ({joint.kind}): {joint.body!r} starts with a velocity relative to "
                          f"{tj.parent or 'the world'!r} that the joint does not allow (off by {miss:.3g} m/s): "
                          "a jointed body's start velocity must be its parent's plus the joint's own rate")
    return rate


def closing_ball_points(scene: Scene, closing: list[tuple[int, Joint]], constraint: str) \
        -> list[tuple[int, str, np.ndarray, str | None, np.ndarray]]:
    """The joints that close a loop (joint_tree) as ball constraints, each (index, body, the
    joint's point in the body's frame, parent (None: the world or a static body), the point
    in the parent's frame (the world's for None)). A ball constraint holds the point, not
    an axis: it is a revolute joint too where the loop is planar (every joint of the scene a
    hinge about the same axis, or fixed), since the tree's hinges already keep the bodies
    from turning about any other axis. Unsupported for other closing joints."""
    out = []
    for j, joint in closing:
        if joint.kind == "revolute":
            others = [o for o in scene.joints if o is not joint and o.kind != "fixed"]
            if any(o.kind != "revolute" or abs(abs(float(np.dot(o.unit_axis, joint.unit_axis))) - 1.0) > 1e-9
                   for o in others):
                raise Unsupported(f"joints[{j}] closes a loop that is not planar: {constraint} holds its point but "
                                  "not its axis; only planar loops (parallel hinges) are mapped")
        elif joint.kind != "ball":
            raise Unsupported(f"joints[{j}] ({joint.kind}) closes a loop: only revolute (in a planar loop) and ball "
                              f"joints close a loop as {constraint}")
        anchor = np.asarray(joint.anchor, float)
        parent = None if joint.parent is None or scene.body(joint.parent).static else joint.parent
        out.append((j, joint.body, _in_frame(scene.body(joint.body), anchor), parent,
                    anchor if parent is None else _in_frame(scene.body(parent), anchor)))
    return out


def _in_frame(body: Body, point: np.ndarray) -> np.ndarray:
    """A world point in the body's frame at its start pose."""
    return local_frame(body, point, np.array([1.0, 0.0, 0.0, 0.0]))[0]


def local_frame(body: Body | None, point, turn) -> tuple[np.ndarray, np.ndarray]:
    """A world frame at the start, its origin `point` and its orientation `turn` (w, x, y, z),
    in the body's frame at its start pose: the point turned by the conjugate of the body's
    orientation, and that conjugate times `turn`. The world (None): the frame as given."""
    point, turn = np.asarray(point, float), np.asarray(turn, float)
    if body is None:
        return point, turn
    q = rotations.conjugate(np.asarray(body.orientation, float) / np.linalg.norm(body.orientation))
    return rotations.rotate(q, point - np.asarray(body.position, float)), rotations.multiply(q, turn)
