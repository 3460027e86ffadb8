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

# Where each quantity lies in a state row (Trajectory.states[name][k, POS] ...).
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
    An adapter that reports the geometry and not the forces (`Capabilities.contact_geometry`
    without `contact_points`) gives f_n and every f_t component as NaN: not read.
    """
    a: str
    b: str
    x: np.ndarray      # (3,) point where the force on a acts, m (an engine may push b at a point
                       # a little apart while sliding: PyBullet's positionOnB, up to mm)
    n: np.ndarray      # (3,) unit normal, from b into a
    f_n: float         # normal force on a along n, N
    f_t: np.ndarray    # (3,) friction force on a, N (perpendicular to n)
    gap: float         # signed distance, m


class TrajectoryError(KeyError):
    """A reading the trajectory cannot give: a body not in the scene, or contact forces of
    a run that did not record them (the family must declare needs={"contact_forces"})."""

    def __str__(self):
        return self.args[0]


@dataclass
class Trajectory:
    """What an engine did, one sample per step: sample k is the state after k steps
    (sample 0 is the scene's start state), at time t[k] = k dt.

    `states[name]` is an (n+1, 13) array per dynamic body (layout in this module's
    docstring); `forces[pair]` the normal force between a pair at every sample (sample k:
    step k's force, zero at sample 0), recorded only when the family declares
    needs={"contact_forces"}. `bodies` names every body of the scene, static ones too.
    `points` the contact points the engine reported after its last step, recorded only
    when the family declares needs={"contact_points"} or {"contact_geometry"} (None: not recorded).
    """
    dt: float
    t: np.ndarray                      # (n+1,) simulated time of each sample
    states: dict[str, np.ndarray]      # body name -> (n+1, 13)
    forces: dict[tuple[str, str], np.ndarray] | None = field(default_factory=dict)  # None: not recorded
    effects: frozenset[str] = frozenset()  # what the engine says it simulated (Simulation.effects)
    bodies: frozenset[str] = frozenset()   # every body of the scene (empty: not checked)
    points: list[ContactPoint] | None = None  # after the last step; None: not recorded

    def _state(self, name: str) -> np.ndarray:
        try:
            return self.states[name]
        except KeyError:
            known = ", ".join(sorted(self.states))
            raise TrajectoryError(f"no dynamic body {name!r} in this trajectory (dynamic bodies: {known})") from None

    def pos(self, name: str) -> np.ndarray:
        """(n+1, 3) position of the body's centre of mass, m, world frame."""
        return self._state(name)[:, POS]

    def quat(self, name: str) -> np.ndarray:
        """(n+1, 4) orientation, unit quaternion (w, x, y, z), body to world."""
        return self._state(name)[:, QUAT]

    def vel(self, name: str) -> np.ndarray:
        """(n+1, 3) velocity of the centre of mass, m/s, world frame."""
        return self._state(name)[:, VEL]

    def omega(self, name: str) -> np.ndarray:
        """(n+1, 3) angular velocity, rad/s, world frame."""
        return self._state(name)[:, OMEGA]

    def force(self, a: str, b: str) -> np.ndarray:
        """Normal force between a and b at every sample (zeros where they did not touch)."""
        if self.forces is None:
            raise TrajectoryError("contact forces were not recorded: the family must declare "
                                  "needs={'contact_forces'} to read them")
        for n in (a, b):
            if self.bodies and n not in self.bodies:
                raise TrajectoryError(f"no body {n!r} in this scene (bodies: {', '.join(sorted(self.bodies))})")
        return self.forces.get(pair_key(a, b), np.zeros_like(self.t))

    def last_points(self) -> list[ContactPoint]:
        """The contact points the engine reported after the last step (ContactPoint)."""
        if self.points is None:
            raise TrajectoryError("contact points were not recorded: the family must declare "
                                  "needs={'contact_geometry'} (or 'contact_points', for their forces too) "
                                  "to read them")
        return list(self.points)

    def after(self, t0: float) -> np.ndarray:
        """Boolean mask of the samples at or after time t0."""
        return self.t >= t0 - 1e-12
