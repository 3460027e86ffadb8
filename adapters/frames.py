"""Orientation conversions shared by adapters. The scene's quaternions are (w, x, y, z)."""
from __future__ import annotations

import numpy as np


def wxyz_to_xyzw(q) -> list[float]:
    w, x, y, z = q
    return [x, y, z, w]


def xyzw_to_wxyz(q) -> list[float]:
    x, y, z, w = q
    return [w, x, y, z]


def state_row(pos, quat_wxyz, vel, omega_world) -> np.ndarray:
    """The 13-number state row of cases.trajectory."""
    return np.concatenate([np.asarray(pos, float), np.asarray(quat_wxyz, float),
                           np.asarray(vel, float), np.asarray(omega_world, float)])
