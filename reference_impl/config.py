"""Settings of the reference engine: one explicit, immutable object, never globals."""
from __future__ import annotations

from dataclasses import dataclass, field


@dataclass(frozen=True)
class Config:
    # which formulation solves the contacts: a module of reference_impl (see __init__.py)
    formulation: str = "si"
    # velocity iterations: an upper bound; a sweep whose largest velocity change is below
    # `tolerance` ends the loop early (so a warm-started resting stack costs one sweep)
    iterations: int = 200
    tolerance: float = 1e-10           # m/s
    # Baumgarte depenetration (note 001, "de-penetration bias velocity"):
    # v_bias = beta/dt * (delta - slop)+, applied to pseudo-velocities (split impulse)
    beta: float = 0.2
    # m: a dead band on both sides of touching: overlaps up to it are not pushed out, gaps
    # up to it count as touching (a tenth of the 1e-4 m penetration budget)
    slop: float = 1e-5
    position_iterations: int = 200     # pseudo-velocity sweeps, same early exit
    # start from the last step's impulses (note 001, "inter-timestep persistence"); when
    # no contact has any (a scene starting at rest), from the least-squares impulses
    # (sequential_impulses.py) if the system has at most `cold_start_rows` rows
    warm_start: bool = True
    cold_start_rows: int = 1000        # a dense solve of this size costs ~0.1 s, once
    # a contact sticks (mu_s bounds friction) while its tangential speed at the start of
    # the step is below this; above it slides (mu_k). Well above the solver's tolerance
    # (1e-10 m/s) and below one step of the gentlest sliding we test (~1e-4 m/s).
    stick_speed: float = 1e-5          # m/s
    # contacts are made for shapes up to this far apart (speculative contacts: the gap
    # may close this step, no more). Keeps a contact whose corner lifts by a rounding-
    # level tilt, so the contact set of a resting stack does not flicker.
    margin: float = 1e-4               # m
    # formulation-specific settings (each formulation documents its keys)
    params: dict = field(default_factory=dict)

    def __post_init__(self):
        for name, least in (("iterations", 1), ("position_iterations", 1), ("cold_start_rows", 0)):
            value = getattr(self, name)
            if not isinstance(value, int) or value < least:
                raise ValueError(f"{name} = {value!r}: must be a whole number >= {least}")
        for name in ("tolerance", "beta", "slop", "stick_speed", "margin"):
            value = getattr(self, name)
            if not (isinstance(value, (int, float)) and value >= 0):
                raise ValueError(f"{name} = {value!r}: must be a number >= 0")
        if self.beta > 1:
            raise ValueError(f"beta = {self.beta!r}: must lie in [0, 1]")
