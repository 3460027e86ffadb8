"""Judging an invariance relation (cases.relations) on one engine: the tolerance of what
the engine promises, the two runs compared through the relation, and where they part.

A job with a `relation` (physval.core.jobs.Job.relation) runs its scene twice through the
core's one build-and-step (physval.core.jobs.run_scene, in the job's worker): as given, and
transformed (or on more threads, as a world of a batch, saved and restored midway). The
second run's trajectory is mapped back into the first's frame and the two are compared state
by state, each quantity relative to its scale in the job (physval.core.parting, the measure
`physval compare` uses between two runs). The verdict's value is the largest difference over
the run; its row's reason says at which step the two runs first differ by more than the
tolerance and in what, or that they never do.

The tolerance is what the engine promises (Relation.promise):
- bit-identical: 0. Another thread count, another world of a batch, a restored state run
  the same arithmetic on the same numbers.
- round-off: ROUNDINGS_PER_STEP roundings of the engine's unit round-off u (its declared
  float width: 2^-53 for float64, 2^-24 for float32; per sub-step where it sub-steps) a step,
  over the run's steps, at the size of the numbers the second run computes with relative to
  the scene's (a scene moved D from the origin rounds (D + L) / L times coarser, L the
  scene's size), and at most MEANINGFUL: beyond a thousandth of the scene's scale a
  difference is physics whatever its cause (1 mm on a metre: the size of a case's
  tolerance), so a float width too coarse for the coordinates cannot hold the invariance.
"""
from __future__ import annotations

import math
import re
from dataclasses import dataclass, replace

import numpy as np

from cases.family import UNIT_ROUNDOFF, Check
from cases.overlap import reach
from cases.relations import BIT_IDENTICAL, Relation
from cases.scene import Scene
from cases.trajectory import Trajectory
from physval.core.parting import apart, first_past

# A step passes each state component through its integration (a few roundings), the contact
# solver's iterations (tens, each rounding the velocities through every row's impulse: a few
# hundred over the handful of rows of a library scene) and the relation's own mapping there
# and back (a few): 2^10 roundings of numbers of the scene's scale bound what one step adds
# to the difference of two runs that differ by rounding alone (measured: the reference's
# turned slide differs by 4e-11 of its scale after 708 steps, 510 roundings a step; MuJoCo's
# by 1e-14). A difference that grows faster is amplified by the scene or the engine: a contact
# decided by the sign of a rounding, a bounce that moves from one step to the next.
ROUNDINGS_PER_STEP = 2**10
MEANINGFUL = 1e-3
UNIT = "of scale"  # the verdict's value: a difference relative to its quantity's scale in the job


def size_of(scene: Scene) -> float:
    """The scene's size L (m): the farthest reach of a dynamic body from the origin."""
    return max(float(np.linalg.norm(b.position)) + reach(b.shape) for b in scene.dynamic_bodies)


def tolerance(relation: Relation, scene: Scene, steps: int, float_bits: int = 64, substeps: int = 1) -> float:
    """The difference (of scale) the engine promises the two runs stay within (module docstring)."""
    if relation.promise == BIT_IDENTICAL:
        return 0.0
    L = size_of(scene)
    coarser = (relation.offset(scene) + L) / L
    return min(ROUNDINGS_PER_STEP * UNIT_ROUNDOFF[float_bits] * max(1, substeps) * steps * coarser, MEANINGFUL)


def check(relation: Relation, scene: Scene, steps: int, float_bits: int = 64, substeps: int = 1) -> Check:
    """The verdict of `relation` on a run of `steps` steps of `scene` at `float_bits`."""
    tol = tolerance(relation, scene, steps, float_bits, substeps)
    if relation.promise == BIT_IDENTICAL:
        why = f"bit-identical: {relation.why}"
    else:
        coarser = relation.offset(scene) > 0
        why = (f"round-off: {relation.why}; {ROUNDINGS_PER_STEP} roundings of float{float_bits}'s u a step"
               + (f" (x {substeps} sub-steps)" if substeps > 1 else "") + f" over {steps} steps"
               + (" at the moved coordinates' size" if coarser else "")
               + (f", capped at {MEANINGFUL:g} of scale (beyond it a difference is physics)" if tol == MEANINGFUL
                  else ""))
    return Check(relation.metric, UNIT, 0.0, tol, "abs", why, measures="invariance")


def settings_for(relation: Relation, settings):
    """The second run's settings: the time step scaled, the relation's own fields set."""
    return replace(settings, dt=settings.dt * relation.time_scale, **dict(relation.settings))


# --- the second run of a restart: saved midway, restored into a freshly built engine -----------

class Saving:
    """A probe (physval.core.jobs.Probe) that saves the engine's state after the run."""
    forces = False
    on_step = None  # nothing read between steps: the engine may step in bulk

    def after(self, run, sim, rebuild) -> dict:
        return {"state": sim.save_state()}


class Restoring:
    """A probe that restores `state` into the freshly built engine before its first step."""
    forces = False

    def __init__(self, state):
        self.state = state

    def on_step(self, sim, k: int) -> None:
        if k == 0:
            sim.restore_state(self.state)

    def after(self, run, sim, rebuild) -> dict:
        return {}


def joined(first: Trajectory, then: Trajectory) -> Trajectory:
    """The trajectory of a run saved after `first` and continued (restored) as `then`: the
    restored run's sample 0 (the freshly built scene, before the restore) is left out."""
    states = {name: np.concatenate([s, then.states[name][1:]]) for name, s in first.states.items()}
    n = len(next(iter(states.values())))
    return replace(first, states=states, t=np.arange(n) * first.dt, forces=None)


# --- comparing the two runs --------------------------------------------------------------------------

@dataclass
class Parting:
    """How the second run (mapped back) differs from the first: the largest difference (of
    scale) and where it first exceeds the tolerance (step, time, what), if it does."""
    largest: float
    at: int | None = None     # the step of the largest difference
    step: int | None = None   # the first step past the tolerance
    time: float = math.nan
    what: str = ""
    steps: int = 0

    def text(self, tol: float) -> str:
        if self.largest == 0:
            return f"the two runs are identical to the last bit over {self.steps} steps"
        largest = f"largest difference {self.largest:.3g} of scale (step {self.at})"
        if self.step is None:
            return f"{largest}, within {tol:.3g} throughout"
        return (f"the two runs part at step {self.step} of {self.steps} (t = {self.time:.4g} s), first in "
                f"{self.what}; {largest}")


PARTS_AT = re.compile(r"the two runs part at step (\d+) ")


def parted_at(reason: str) -> int:
    """The step a verdict's reason (Parting.text) says the two runs part at; -1 if none."""
    m = PARTS_AT.search(reason or "")
    return int(m[1]) if m else -1


def compare(a: Trajectory, b: Trajectory, tol: float) -> Parting:
    """The runs' difference step by step (physval.core.parting), and where it exceeds `tol`."""
    n = min(len(a.t), len(b.t))
    worst, per_body = apart(a, b, n)
    largest = float(worst.max(initial=0.0))
    out = Parting(largest, int(np.argmax(worst)) if n else None, steps=n - 1)
    if where := first_past(worst, per_body, tol):
        out.step, out.time, out.what = where["step"], float(a.t[where["step"]]), where["what"]
    return out
