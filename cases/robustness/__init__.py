"""The robustness category: hard scenes judged by invariants, not by a closed-form motion.

Each family of this package (`cases/robustness/<what>.py`, family `robustness_<what>`) says
in its docstring why its scenes are hard. They share the invariants below (this module:
a library, it defines no FAMILY), each a `Check` whose tolerance has its reason:

- no NaN or infinity: the harness reports such a run `unstable` (physval.core.record);
- energy: with e <= 1 and nothing doing work but gravity, the mechanical energy
  (`cases.observables.mechanical_energy`) never rises above its initial value;
- penetration: after settling, no two bodies overlap by more than a small part of their size;
- drift: bodies at rest stay where they settled;
- momentum: conserved where no external force acts;
- standing: a structure in equilibrium stands for the whole run; the measured value is
  the time to collapse (a metric: a structure that falls shows when).

Sizes are a body's edge (2 x half-extent) or diameter. Long variants (minutes of
simulated time, hundreds of bodies) live in each family's `FULL_GRID` and are run by
`physval stress --long`, never by the default `physval run`.
"""
from __future__ import annotations

from cases.family import IMPACT_ROUNDINGS, Check, impulse_roundoff

# A body more than this part of its size sideways from where it started, or a whole size
# below it, has left the structure: settling moves a body sideways by round-off and down
# by the contact depths below it (under 1 % of a size each).
COLLAPSE_FRACTION = 0.1


def collapse_time(traj, names, size: float) -> float:
    """The structure's time to collapse (the end of the run if it stood)."""
    from cases.observables import time_to_collapse
    return time_to_collapse(traj, names, COLLAPSE_FRACTION * size, size)
# Contact depth allowed after settling: 0.5 % of the size (1 mm for a 0.2 m box, as in
# resting_blocks), a solver's stabilising depth and well under the 1 % a user would see.
PENETRATION_FRACTION = 5e-3
# Drift allowed after settling: 0.1 % of the size (0.2 mm for a 0.2 m box, as in
# resting_blocks): below what is visible, far above round-off.
DRIFT_FRACTION = 1e-3
# A resting structure may gain at most the energy of being lifted by 0.1 % of a body's size.
LIFT_FRACTION = 1e-3


def at_rest_energy_tolerance(total_mass: float, g: float, size: float) -> float:
    """Energy a resting structure may gain: its weight lifted by LIFT_FRACTION of a size, J."""
    return total_mass * g * LIFT_FRACTION * size


def free_flight_energy_tolerance(total_mass: float, g: float, dt: float, duration: float) -> float:
    """Energy the sampled states of a falling body gain by the integrator alone, J.

    Position-first Euler (x += v dt, then v += g dt, as Pymunk) changes v^2/2 + g z by
    +g^2 dt^2 / 2 per free-flight step (velocity-first Euler by the same amount downwards),
    so at most M g^2 dt T / 2 over a run of T seconds."""
    return 0.5 * total_mass * g * g * dt * duration


def no_energy_gain(tolerance: float, why: str) -> Check:
    return Check("energy_rise", "J", 0.0, tolerance, "abs",
                 "with e <= 1 nothing but gravity does work, so energy never rises; " + why)


def bounded_penetration(size: float) -> Check:
    return Check("penetration", "m", 0.0, PENETRATION_FRACTION * size, "abs",
                 f"rigid bodies do not overlap; 0.5 % of the size ({PENETRATION_FRACTION * size:.3g} m) "
                 "is a solver's stabilising depth, well under the 1 % a user sees")


def bounded_drift(size: float) -> Check:
    return Check("drift", "m", 0.0, DRIFT_FRACTION * size, "abs",
                 f"bodies at rest stay where they settled; 0.1 % of the size ({DRIFT_FRACTION * size:.3g} m) "
                 "is below what is visible and far above round-off")


def stands(duration: float, size: float, dt: float) -> Check:
    """Stands to the last sample, at round(duration / dt) steps (physval.runner.simulate)."""
    return Check("standing_time", "s", max(1, round(duration / dt)) * dt, 0.0, "abs",
                 "a structure in equilibrium on level ground stands the whole run; measured: the time "
                 f"until a body first moved {COLLAPSE_FRACTION * size:.3g} m (10 % of its size) sideways or "
                 "a whole size down, i.e. the time to collapse")


def momentum_conserved(p0: float, impacts: int = 1) -> Check:
    """Momentum p0 brought in by one body, through `impacts` pair impacts at e <= 1: each pair's
    m |v| sums to at most 3 p0 (the struck body leaves with at most 2 p0, the striker p0)."""
    return Check("momentum_change", "kg m/s", 0.0, 1e-9 * max(p0, 1.0), "abs",
                 "no external force acts and contact impulses are equal and opposite: momentum is "
                 f"conserved to round-off (1e-9 in float64; {IMPACT_ROUNDINGS} roundings of m |v| a sub-step "
                 f"for each of {impacts} pair impacts at the engine's float width)", impulse_roundoff(3.0 * p0, impacts))
