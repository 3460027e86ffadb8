"""Prisms as point sets, for engines that build a shape the scene names from a convex hull:
a 2D scene's `Polygon` embedded in 3D (a prism along y, as a `Rect` is a box along y), and a
`Cylinder` where the engine has no cylinder of its own (an n-sided prism inscribed in it)."""
from __future__ import annotations

import math

import numpy as np


def embedded_half_depth(corners) -> float:
    """Half the depth along y of a 2D polygon's prism: its largest |x| or |z| (a square of
    half side a: a, as the 3D engines make a Rect a box as deep as its larger half-extent).
    The depth only spreads the contact points, symmetrically about y = 0."""
    return float(np.abs(np.asarray(corners, dtype=float)).max())


def polygon_prism(corners, half_depth: float) -> np.ndarray:
    """The corners (2n, 3) of the prism over a 2D polygon (corners (x, z), n of them) from
    y = -half_depth to +half_depth: each corner at y = -half_depth, then each at +half_depth."""
    c = np.asarray(corners, dtype=float)
    n = len(c)
    out = np.empty((2 * n, 3))
    out[:, 0] = np.tile(c[:, 0], 2)
    out[:, 1] = np.repeat([-half_depth, half_depth], n)
    out[:, 2] = np.tile(c[:, 1], 2)
    return out


def cylinder_prism(radius: float, half_length: float, sides: int) -> np.ndarray:
    """The corners (2 sides, 3) of the regular prism inscribed in a cylinder along z: each
    end's corners on its rim at angles 2 pi k / sides from +x, the end at z = -half_length
    first. Its flat sides lie radius cos(pi / sides) from the axis (the apothem)."""
    angle = 2.0 * math.pi * np.arange(sides) / sides
    rim = np.stack([radius * np.cos(angle), radius * np.sin(angle)], axis=1)
    out = np.empty((2 * sides, 3))
    out[:, :2] = np.tile(rim, (2, 1))
    out[:, 2] = np.repeat([-half_length, half_length], sides)
    return out
