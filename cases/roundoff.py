"""Round-off allowances of free flight at an engine's float width (a library for the
families' Check.roundoff and Check.roundoff_at), from a bound that is tight rather than a
worst-case sum of every rounding at its largest.

How a sub-stepped Euler flight rounds (h = dt / k, k sub-steps a step; u = 2^-p the unit
round-off of a p-bit significand; a value x rounds to the nearest float, an error of at
most half an ulp, u bin(x), bin(x) the power of two at or below |x|):
- the velocity adds the same increment g h every sub-step. Within a binade of v the grid of
  floats does not change, so v + g h rounds the same way each time: the errors add up, a
  systematic drift, at most u bin(v) a sub-step (`velocity_roundoff` sums that over the
  run, the binades v passes through included: 2.4 to 5.2 times the drift measured on Box3D and
  Rapier, whose velocities a float32 emulation of v += g h reproduces to the last bit);
- the position adds h v, which changes with v: its roundings, and the velocity's drift
  integrated, make an error that depends on the order in which an engine forms a
  sub-step's products and sums. That part is measured: `flight_position_error` steps the
  flight in the engine's float width (velocity first, k sub-steps: Box2D, Box3D, Rapier,
  MuJoCo; position first differs by a step's worth of the same roundings) and reads it as
  the family does (cases.observables.free_flight_error), and the allowance is
  POSITION_FACTOR times that.
"""
from __future__ import annotations

import functools

import numpy as np

from cases.observables import free_flight_error

# Rapier's float32 flights equal the emulation's bit for bit; Box3D's (another order of
# its sub-step's products) err 0.45 to 0.7 of it; a binade whose increment lands near the
# middle of two floats may round the other way in another order, which can at most double
# that binade's share: 3 covers both.
POSITION_FACTOR = 3.0

FLOAT = {32: np.float32, 64: np.float64}


def _floats(a) -> tuple[float, ...]:
    """A vector as a tuple of floats (hashable: the emulation is cached per flight)."""
    return tuple(float(c) for c in np.atleast_1d(np.asarray(a, float)))


def binade(x) -> np.ndarray:
    """The power of two at or below |x| (0 at 0): rounding x errs by at most u times it."""
    x = np.abs(np.asarray(x, float))
    out = np.zeros_like(x)
    nz = x > 0.0
    out[nz] = 2.0 ** np.floor(np.log2(x[nz]))
    return out


def velocity_roundoff(steps: int, dt: float, v0, g) -> float:
    """Check.roundoff (per unit round-off and sub-step) of the velocity of a free flight of
    `steps` steps from v0 under g: each component's u bin(v) a sub-step (module docstring),
    plus the increment g h's own rounding (g, h and their product: 3 u |g| h). A component
    without gravity adds 0, exactly."""
    v0, g = np.asarray(v0, float), np.asarray(g, float)
    t = np.arange(1, steps + 1) * dt
    v = (v0[None, :] + g[None, :] * t[:, None])[:, g != 0.0]
    return float(binade(v).sum() + 3.0 * np.abs(g).sum() * dt * steps)


@functools.lru_cache(maxsize=64)
def _emulated_position_error(steps: int, dt: float, x0: tuple, v0: tuple, g: tuple, bits: int, k: int) -> float:
    F = FLOAT[bits]
    n = steps * k
    h = F(dt / k)
    x0_, v0_, g_ = (np.asarray(a, float) for a in (x0, v0, g))
    c = (h * g_.astype(F)).astype(F)                           # g h, rounded
    v = np.add.accumulate(np.vstack([v0_.astype(F)[None, :], np.broadcast_to(c, (n, len(c)))]), axis=0, dtype=F)
    dx = (h * v[1:]).astype(F)                                  # velocity first: h v_new
    x = np.add.accumulate(np.vstack([x0_.astype(F)[None, :], dx]), axis=0, dtype=F)
    t = np.arange(steps + 1) * dt
    return free_flight_error(x[::k].astype(float), x0_, v0_, g_, t, dt)


def flight_position_error(steps: int, dt: float, x0, v0, g, bits: int, k: int) -> float:
    """The free_flight_error of a flight stepped velocity first in k sub-steps in IEEE
    binary`bits` arithmetic (x0, v0 and g rounded to it, then v += g h, x += h v)."""
    return _emulated_position_error(int(steps), float(dt), _floats(x0), _floats(v0), _floats(g), int(bits),
                                    max(1, int(k)))


def position_allowance(steps: int, dt: float, x0: tuple, v0: tuple, g: tuple, bits: int, k: int) -> float:
    """Check.roundoff_at of a free flight's positions: POSITION_FACTOR times the emulated
    error at that float width and sub-step count."""
    return POSITION_FACTOR * flight_position_error(steps, dt, x0, v0, g, bits, k)


def position_roundoff(steps: int, dt: float, x0, v0, g):
    """Check.roundoff_at (float_bits, substeps) -> allowance of a free flight's positions."""
    return functools.partial(position_allowance, int(steps), float(dt), _floats(x0), _floats(v0), _floats(g))


def uniform_motion_roundoff(steps: int, dt: float, x_max: float, v: float) -> float:
    """Check.roundoff (per unit round-off and sub-step) of a position moving at constant
    speed v from 0 to x_max in `steps` steps: x + h v adds the same increment every
    sub-step, so within a binade of x it rounds the same way (the velocity's argument
    above), u bin(x) a sub-step; and v, stored rounded, moves it by u bin(v) T."""
    t = np.arange(1, steps + 1) * dt
    return float(binade(np.minimum(abs(v) * t, x_max)).sum() + binade(v) * steps * dt)
