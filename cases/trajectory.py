"""What a simulation run hands to a case: body states and contact normal forces over time,
and (`ContactPoint`) what an engine reports about each contact point after a step.

Adapters produce the raw reads; the harness stacks them into a `Trajectory`; a case's
observables read from it. State layout per row: position (3), orientation quaternion
(w, x, y, z) (4), linear velocity (3), angular velocity in the world frame (3).
"""
from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from cases.scene import pair_key

POS, QUAT, VEL, OMEGA = slice(0, 3), slice(3, 7), slice(7, 10), slice(10, 13)
STATE_SIZE = 13


@dataclass(slots=True)  # not frozen: engines build tens of these a step, and frozen costs 1 us each
class ContactPoint:
    """One contact point after a step, in the world frame, as the engine solved it.

    `n` is the unit normal pointing from body b into body a: the contact pushes a with
    f_n n + f_t and b with the opposite. Forces are the step's impulses divided by dt.
    `gap` is the signed distance the engine's collision detection gave the point
    (negative: overlap). A static body is named like any other. Engines that report only
    one resultant per touching pair give one point per pair (at the mean of its points,
    the smallest gap); the adapter says so in its docstring. Velocities are not part of
    the record: the harness takes them from the bodies' states, the same way for every engine.
    """
    a: str
    b: str
    x: np.ndarray      # (3,) point where the force on a acts, m (an engine may push b at a point
                       # a little apart while sliding: PyBullet's positionOnB, up to mm)
    n: np.ndarray      # (3,) unit normal, from b into a
    f_n: float         # normal force on a along n, N
    f_t: np.ndarray    # (3,) friction force on a, N (perpendicular to n)
    gap: float         # signed distance, m


@dataclass
class Trajectory:
    dt: float
    t: np.ndarray                      # (n+1,) simulated time of each sample
    states: dict[str, np.ndarray]      # body name -> (n+1, 13)
    forces: dict[tuple[str, str], np.ndarray] = field(default_factory=dict)  # pair -> (n+1,) normal force, N
    effects: frozenset[str] = frozenset()  # what the engine says it simulated (Simulation.effects)

    def pos(self, name: str) -> np.ndarray:
        return self.states[name][:, POS]

    def quat(self, name: str) -> np.ndarray:
        return self.states[name][:, QUAT]

    def vel(self, name: str) -> np.ndarray:
        return self.states[name][:, VEL]

    def omega(self, name: str) -> np.ndarray:
        return self.states[name][:, OMEGA]

    def force(self, a: str, b: str) -> np.ndarray:
        """Normal force between a and b at every sample (zeros if they never touched)."""
        return self.forces.get(pair_key(a, b), np.zeros_like(self.t))

    def after(self, t0: float) -> np.ndarray:
        """Boolean mask of the samples at or after time t0."""
        return self.t >= t0 - 1e-12
