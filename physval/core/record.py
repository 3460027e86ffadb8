"""Stepping and recording one simulation: the trajectory, contact forces where the case
reads them, and the wall time of stepping alone.

Recording is kept to a copy per step: each step's raw engine state goes into one row of a
preallocated array (`Simulation.write_state`) and is decoded into state rows in blocks
(`Simulation.decode_states`), which is also when a blow-up is looked for. Contact forces
are read only when asked for (a family that declares needs={"contact_forces"}), and so are
the contact points after the last step (needs={"contact_points"} or {"contact_geometry"}).
"""
from __future__ import annotations

import time
from dataclasses import dataclass

import numpy as np

from adapters.base import Simulation
from cases.scene import Scene
from cases.trajectory import Trajectory

BLOCK = 256  # steps decoded and checked for a blow-up at a time
RUN_BLOCK = 2048  # steps an engine that steps in bulk (Simulation.run) takes per call


class Unstable(Exception):
    """The engine's own state became NaN or infinite, or blew up."""


@dataclass
class Run:
    trajectory: Trajectory
    wall_s: float          # stepping only, warm-up steps excluded
    steps: int
    knobs: dict
    effects: frozenset
    iterations: int | None
    cpu_s: float = 0.0     # this thread's CPU time over the whole run (recording and warm-up included)
    whole_s: float = 0.0   # wall time of the whole run: stepping, warm-up, recording, blow-up checks


def speed_limit(scene: Scene, duration: float) -> float:
    """A speed no body reaches unless the integration blew up: ten times what initial
    speed plus gravity acting for the whole run could give, and at least 100 m/s."""
    v0 = max(np.linalg.norm(b.velocity) + np.linalg.norm(b.angular_velocity) * 10 for b in scene.dynamic_bodies)
    return max(100.0, 10.0 * (v0 + np.linalg.norm(scene.gravity) * duration + 1.0))


def _blow_up(states: np.ndarray, first: int, dt: float, v_max: float) -> str | None:
    """Why samples `first`.. of decoded `states` (samples, bodies, 13) show a blow-up, or None."""
    finite = np.isfinite(states).all(axis=(1, 2))
    if not finite.all():
        k = first + int(np.argmin(finite))
        return f"NaN or infinity in the state at t = {k * dt:.4g} s"
    speed = np.linalg.norm(states[:, :, 7:10], axis=2).max(axis=1)
    if speed.max() > v_max:
        k = int(np.argmax(speed > v_max))
        return f"speed {speed[k]:.3g} m/s at t = {(first + k) * dt:.4g} s exceeds {v_max:.3g} m/s: blew up"
    return None


def simulate(sim: Simulation, scene: Scene, dt: float, steps: int, forces: bool = False, warmup: int = 0,
             on_step=None, points: bool = False) -> Run:
    """Step a built simulation `steps` times, recording every step; `Run.wall_s` is the
    time of the steps after the first `warmup`. `forces`: read the pair normal forces
    each step; `points`: read the contact points after the last step. `on_step(sim, k)`: a reading that looks at the engine after step k (and at
    its start, k = 0).
    Raises Unstable (NaN, infinity, blow-up of the engine's state) or what the engine raises."""
    cpu0, start = time.thread_time(), time.perf_counter()
    names = sim.body_order()
    expected = {b.name for b in scene.dynamic_bodies}
    if set(names) != expected:
        raise RuntimeError(f"the adapter reports bodies {sorted(names)}, the scene has {sorted(expected)}")
    raw = np.empty((steps + 1, sim.state_size()))
    step, write, clock = sim.step, sim.write_state, time.perf_counter
    write(raw[0])
    pair_forces = [] if forces else None
    v_max = speed_limit(scene, steps * dt)
    decoded = [sim.decode_states(raw[0:1])]
    checked = 0
    wall = 0.0
    k = 0
    if on_step is not None:
        on_step(sim, 0)
    if sim.run is not None and not forces and on_step is None and not points:
        return _run_in_blocks(sim, scene, dt, steps, warmup, names, raw, decoded, v_max, cpu0, start)
    try:
        for k in range(1, steps + 1):
            t0 = clock()
            step()
            t1 = clock()
            if k > warmup:
                wall += t1 - t0
            write(raw[k])
            if forces:
                pair_forces.append(sim.contact_forces())
            if on_step is not None:
                on_step(sim, k)
            if k - checked == BLOCK:
                decoded.append(sim.decode_states(raw[checked + 1:k + 1]))
                why = _blow_up(decoded[-1], checked + 1, dt, v_max)
                if why:
                    raise Unstable(why)
                checked = k
    except Unstable:
        raise
    except Exception:
        # an engine that throws after its state went bad blew up first
        why = _blow_up(sim.decode_states(raw[checked + 1:k]), checked + 1, dt, v_max) if k > checked + 1 else None
        if why:
            raise Unstable(why) from None
        raise
    if checked < steps:
        decoded.append(sim.decode_states(raw[checked + 1:steps + 1]))
        why = _blow_up(decoded[-1], checked + 1, dt, v_max)
        if why:
            raise Unstable(why)
    states = np.concatenate(decoded)
    traj = Trajectory(dt=dt, t=np.arange(steps + 1) * dt,
                      states={n: states[:, i] for i, n in enumerate(names)},
                      forces=_stack_forces(pair_forces, steps) if forces else None,
                      effects=frozenset(sim.effects), bodies=frozenset(b.name for b in scene.bodies),
                      points=sim.contact_points() if points else None)
    return Run(traj, wall, steps, dict(sim.knobs), frozenset(sim.effects), sim.iterations, time.thread_time() - cpu0,
               time.perf_counter() - start)


def _run_in_blocks(sim, scene, dt, steps, warmup, names, raw, decoded, v_max, cpu0, start) -> Run:
    """The engine steps and records a block of steps in one call (Simulation.run); wall_s
    is the time of those calls after the warm-up block (the engine's own recording in
    it is a copy per step)."""
    wall, k = 0.0, 0
    while k < steps:
        n = min(RUN_BLOCK, steps - k) if k >= warmup else min(warmup - k, steps - k)
        t0 = time.perf_counter()
        sim.run(n, raw[k + 1:k + 1 + n])
        if k >= warmup:
            wall += time.perf_counter() - t0
        decoded.append(sim.decode_states(raw[k + 1:k + 1 + n]))
        why = _blow_up(decoded[-1], k + 1, dt, v_max)
        if why:
            raise Unstable(why)
        k += n
    states = np.concatenate(decoded)
    traj = Trajectory(dt=dt, t=np.arange(steps + 1) * dt, states={n: states[:, i] for i, n in enumerate(names)},
                      forces=None, effects=frozenset(sim.effects), bodies=frozenset(b.name for b in scene.bodies))
    return Run(traj, wall, steps, dict(sim.knobs), frozenset(sim.effects), sim.iterations, time.thread_time() - cpu0,
               time.perf_counter() - start)


def _stack_forces(per_step: list[dict], steps: int) -> dict[tuple[str, str], np.ndarray]:
    out: dict[tuple[str, str], np.ndarray] = {}
    for k, forces in enumerate(per_step, start=1):
        for pair, f in forces.items():
            if pair not in out:
                out[pair] = np.zeros(steps + 1)
            out[pair][k] = f
    return out
