"""Orientation conversions shared by adapters. The scene's quaternions are (w, x, y, z)."""
from __future__ import annotations

import math

import numpy as np

from adapters.base import Unsupported


def wxyz_to_xyzw(q) -> list[float]:
    w, x, y, z = q
    return [x, y, z, w]


def xyzw_to_wxyz(q) -> list[float]:
    x, y, z, w = q
    return [w, x, y, z]


def require_turn_about_y(body, why: str) -> None:
    """Unsupported unless the 2D body's orientation (w, x, y, z) is a rotation about y alone,
    the only orientation a body in the x-z plane has; `why`: what the engine could not do."""
    w, x, y, z = body.orientation
    if abs(x) > 1e-12 or abs(z) > 1e-12:
        raise Unsupported(f"2D body {body.name!r}: orientation {body.orientation} is not a rotation about y, {why}")


def z_to(n) -> list[float]:
    """Unit quaternion (w, x, y, z) turning +z onto the unit vector n (a plane's frame: its
    normal along the frame's z); -z is a half turn about x."""
    n = np.asarray(n, float)
    axis = np.cross([0.0, 0.0, 1.0], n)
    s, c = float(np.linalg.norm(axis)), float(n[2])
    if s < 1e-12:
        return [1.0, 0.0, 0.0, 0.0] if c > 0 else [0.0, 1.0, 0.0, 0.0]
    half = math.atan2(s, c) / 2.0
    return [math.cos(half)] + [float(a) for a in axis / s * math.sin(half)]


def state_row(pos, quat_wxyz, vel, omega_world) -> np.ndarray:
    """The 13-number state row of cases.trajectory."""
    return np.concatenate([np.asarray(pos, float), np.asarray(quat_wxyz, float),
                           np.asarray(vel, float), np.asarray(omega_world, float)])


# --- many samples at once (Simulation.decode_states) -------------------------------------

def planar_states(x, z, turn, vx, vz, spin) -> np.ndarray:
    """State rows (cases.trajectory layout) of bodies moving in the x-z plane, each argument
    an array of one shape (samples, bodies): position (x, 0, z), the rotation by `turn`
    about +y, velocity (vx, 0, vz), angular velocity (0, spin, 0)."""
    out = np.zeros(np.shape(x) + (13,))
    out[..., 0], out[..., 2] = x, z
    out[..., 3], out[..., 5] = np.cos(turn / 2), np.sin(turn / 2)  # cases.scene.quat_about_y
    out[..., 7], out[..., 9] = vx, vz
    out[..., 11] = spin
    return out


def about_y_many(angle: np.ndarray) -> np.ndarray:
    """Rotations by `angle` (n,) about +y as (n, 4) quaternions."""
    z = np.zeros_like(angle)
    return np.stack([np.cos(angle / 2), z, np.sin(angle / 2), z], axis=1)
