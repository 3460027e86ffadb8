"""What the reduced-coordinate adapters that hang a body on one scene joint share: the
scene's joints by body, each to the world or a static body (DART's skeleton root, PyBullet's
multibody on a fixed base, Drake's joint to the world frame)."""
from __future__ import annotations

from adapters.base import Unsupported
from cases.scene import Scene


def world_joints(scene: Scene, whole: str) -> dict:
    """The scene joints by body name, each joining a moving body to the world or a static
    body. Unsupported for a joint between two moving bodies (`whole` names what would hold
    both, e.g. "one skeleton of both"), for a body on two joints, and for a jointed body's
    start velocity (not mapped onto joint velocities)."""
    out = {}
    for j, joint in enumerate(scene.joints):
        if joint.parent is not None and scene.body(joint.parent).dynamic:
            raise Unsupported(f"joints[{j}] joins two moving bodies ({joint.parent!r}, {joint.body!r}): {whole} "
                              "is not mapped; only joints to the world or a static body are")
        body = scene.body(joint.body)
        if body.static or joint.body in out:
            raise Unsupported(f"joints[{j}]: {joint.body!r} as the joint's `body` must be a moving body on one joint")
        if any(body.velocity) or any(body.angular_velocity):
            raise Unsupported(f"joints[{j}]: {joint.body!r} starts moving: a jointed body's start velocity is not "
                              "mapped onto joint velocities")
        out[joint.body] = joint
    return out
