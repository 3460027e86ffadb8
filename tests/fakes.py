"""Stand-in engines for testing the harness itself: they need no physics package."""
from __future__ import annotations

import math

import numpy as np

from adapters.base import Adapter, Capabilities, Simulation, Unsupported
from adapters.frames import state_row

ALL_SHAPES = frozenset({"sphere", "box", "plane", "circle", "rect"})


class Ballistic(Simulation):
    """Every dynamic body flies free under gravity (symplectic Euler); contact is ignored."""

    def __init__(self, scene, settings, blow_up_at=None, crash_at=None):
        self.scene, self.dt = scene, settings.dt
        self.x = {b.name: np.array(b.position, float) for b in scene.dynamic_bodies}
        self.v = {b.name: np.array(b.velocity, float) for b in scene.dynamic_bodies}
        self.q = {b.name: b.orientation for b in scene.dynamic_bodies}
        self.g = np.array(scene.gravity, float)
        self.k, self.blow_up_at, self.crash_at = 0, blow_up_at, crash_at
        self.knobs = {"integrator": "symplectic Euler"}
        self.effects = frozenset(scene.effects & {"gravity"})
        self.iterations = None
        self.closed = 0

    def step(self):
        self.k += 1
        if self.crash_at is not None and self.k >= self.crash_at:
            raise RuntimeError("engine crashed")
        for n in self.v:
            self.v[n] = self.v[n] + self.g * self.dt
            self.x[n] = self.x[n] + self.v[n] * self.dt
            if self.blow_up_at is not None and self.k >= self.blow_up_at:
                self.v[n] = self.v[n] * np.nan

    def states(self):
        return {n: state_row(self.x[n], self.q[n], self.v[n], (0, 0, 0)) for n in self.x}

    def contact_forces(self):
        return {}

    def close(self):
        self.closed += 1


class FakeAdapter(Adapter):
    package = "none"

    def __init__(self, name="fake", blow_up_at=None, crash_at=None, crash_on_build=False, unsupported=None,
                 dimensions=frozenset({2, 3}), contact_forces=True):
        self.name = name
        self.capabilities = Capabilities(dimensions=dimensions, shapes=ALL_SHAPES, native_restitution=True,
                                         static_kinetic=True, contact_forces=contact_forces, iterations=False)
        self.blow_up_at, self.crash_at = blow_up_at, crash_at
        self.crash_on_build, self.unsupported = crash_on_build, unsupported
        self.built = []

    def version(self):
        return "0.0"

    def build(self, scene, settings):
        if self.unsupported:
            raise Unsupported(self.unsupported)
        if self.crash_on_build:
            raise MemoryError("out of memory inside the engine")
        sim = Ballistic(scene, settings, self.blow_up_at, self.crash_at)
        self.built.append(sim)
        return sim


class OtherFake(FakeAdapter):
    """A second stand-in engine, `fake-2` (`--adapter tests/fakes.py:OtherFake`)."""

    def __init__(self):
        super().__init__("fake-2")


class CompilingFake(FakeAdapter):
    """A stand-in engine, `fake-compiling` (`--adapter tests/fakes.py:CompilingFake`), that
    compiles on first use as the reference does on a fresh install: while the folder
    `folder()` exists, two parts, each writing `started-<part>` in it as it begins and
    `done-<part>` as it ends, after it saw the other part begin (or 60 s); part b also
    stays open while the folder holds a file `hold` (or 60 s)."""

    def __init__(self):
        super().__init__("fake-compiling")

    @staticmethod
    def folder():
        """In the session's cache folder, which the workers see too (tests/conftest.py)."""
        import os
        import tempfile
        from pathlib import Path
        return Path(os.environ.get("PHYSVAL_CACHE_DIR", tempfile.gettempdir())) / "fake-compiling"

    def uncompiled(self):
        return [(str(self.folder()), part) for part in ("a", "b")] if self.folder().is_dir() else []

    def compile_part(self, part):
        import os
        import time
        from pathlib import Path
        folder, name = Path(part[0]), part[1]
        (folder / f"started-{name}").write_text(str(os.getpid()))
        other = folder / f"started-{'b' if name == 'a' else 'a'}"
        deadline = time.monotonic() + 60
        while not other.exists() and time.monotonic() < deadline:
            time.sleep(0.01)
        while name == "b" and (folder / "hold").exists() and time.monotonic() < deadline:
            time.sleep(0.01)
        (folder / f"done-{name}").write_text(str(other.exists()))


class OnDemandFake(FakeAdapter):
    """A stand-in engine too slow for any default run, `fake-slow` (`--adapter
    tests/fakes.py:OnDemandFake`): every run is left out unless --on-demand."""

    def __init__(self):
        super().__init__("fake-slow")

    def on_demand(self, scene):
        return "a stand-in for an engine that takes minutes a run"


class CoreOnDemandFake(OnDemandFake):
    """A stand-in engine slow beyond its core families, `fake-core` (`--adapter
    tests/fakes.py:CoreOnDemandFake`): as Newton's solvers, the core families run in every
    run, the others only with --on-demand."""
    default_tags = frozenset({"core"})

    def __init__(self):
        FakeAdapter.__init__(self, "fake-core")


class CrashingFake(FakeAdapter):
    """A stand-in engine whose every run raises in its first step, `fake-crash`
    (`--adapter tests/fakes.py:CrashingFake`)."""

    def __init__(self):
        super().__init__("fake-crash", crash_at=1)


class FaultAboveFriction(FakeAdapter):
    """For `--adapter tests/fakes.py:<subclass>`: a ballistic engine (FakeAdapter, made
    without arguments) that fails, the way a crashing or hanging engine does, while
    stepping any scene whose friction coefficient exceeds FRICTION; below it it runs.
    So one parameter set of a run can crash its worker while another completes."""
    FRICTION = 0.3
    name_ = "fake-fault"

    def __init__(self):
        super().__init__(name=self.name_, dimensions=frozenset({3}))

    def build(self, scene, settings):
        sim = super().build(scene, settings)
        if scene.material.mu_s > self.FRICTION:
            sim.step = self.fault
        return sim

    @staticmethod
    def fault():
        raise NotImplementedError


class SegfaultAboveFriction(FaultAboveFriction):
    name_ = "fake-segfault"

    @staticmethod
    def fault():
        import ctypes
        ctypes.string_at(0)  # reads address 0: SIGSEGV, as an engine's bad pointer does


class HangAboveFriction(FaultAboveFriction):
    name_ = "fake-hang"

    @staticmethod
    def fault():
        import time
        time.sleep(3600)


# --- a time-stepped bouncing ball: the discrete impacts the rebound tolerances cover ------

def stepped_ball(e: float, h: float, dt: float, duration: float, order: str = "velocity",
                 gravity: str = "cancelled", detection: str = "late", radius: float = 0.1,
                 g: float = 9.81):
    """A ball dropped from rest with its bottom h above the ground z = 0, stepped as a rigid
    engine steps it, without any physics package. Returns (trajectory, impacts): the
    trajectory of body "ball" (centre at bottom + radius) and, for every impact step,
    (sample index, depth d of the bottom below the ground there, kappa of the step).

    order:     "velocity" (symplectic Euler: v then x) or "position" (x then v, then the
               contact found at the new position, as Pymunk);
    gravity:   where the impact step's gravity goes: "before" (restitution of the speed
               after it), "cancelled" (restitution of the speed before it, the impulse
               also cancelling the step's gravity), "after" (added after the impulse);
    detection: when the impact is resolved (velocity order only; position order finds it
               once overlapping): "late" (the first sample at or below the ground), "nearest"
               (the step boundary nearest the moment of contact), "early" (the step in
               which the gap would close).
    A ball left not rising by its impulse rests: its velocity is zeroed, its depth kept (no
    push-out: the rebound from that depth is what the tolerance must cover)."""
    from adapters.frames import state_row
    from cases.trajectory import Trajectory

    n = int(round(duration / dt))
    z, v = h, 0.0
    zs, vs, impacts = [z], [v], []

    def rebound(s: float) -> tuple[float, float]:
        """(v+, c) of an impact at approach speed s (before this step's gravity)."""
        c = {"before": e, "cancelled": 0.0, "after": -1.0}[gravity]
        return e * s + c * g * dt, c

    for k in range(n):
        if order == "velocity":
            s = -v
            hits = s > 0.0 and {"late": z <= 0.0, "nearest": z <= s * dt / 2.0, "early": z <= s * dt}[detection]
            if hits:
                v_plus, c = rebound(s)
                impacts.append((k, -z, c + (1.0 - e) / 2.0))
                v = v_plus if v_plus > 0.0 else 0.0
            else:
                v -= g * dt
            z += v * dt
        else:
            z += v * dt
            if z <= 0.0 and v < 0.0:
                s = -v
                v_plus, c = rebound(s)
                impacts.append((k + 1, -z, c + (1.0 - e) / 2.0))
                v = v_plus if v_plus > 0.0 else 0.0
            else:
                v -= g * dt
        zs.append(z)
        vs.append(v)
    t = np.arange(n + 1) * dt
    rows = np.array([state_row((0.0, 0.0, zz + radius), (1.0, 0.0, 0.0, 0.0), (0.0, 0.0, vv), (0.0, 0.0, 0.0))
                     for zz, vv in zip(zs, vs)])
    return Trajectory(dt=dt, t=t, states={"ball": rows}), impacts


# --- Coulomb friction integrated in time: a second way to the friction closed forms ------

def coulomb_on_plane(g_t: float, g_n: float, mu_s: float, mu_k: float, k: float | None = None,
                     radius: float = 0.1, duration: float = 1.0, stiffness: float = 1e6,
                     rolling: float = 0.0, start: tuple[float, float] = (0.0, 0.0)) -> tuple[float, float]:
    """(a, alpha): the downhill acceleration of a body released on a plane (at rest, or at
    `start` = (v, w)), and the angular acceleration about the axis of forward roll, fitted
    over the second half of `duration`, from integrating Newton-Euler in time (scipy Radau)
    with gravity g_t along the plane, g_n into it, and Coulomb friction at the contact point
    against its slip s (a regularised law: per unit mass, f = stiffness * s while that is
    within mu_s g_n, the sticking branch; mu_k g_n otherwise). A box when k is None (it
    cannot turn); a ball with I = k m R^2 otherwise (slip s = v - R w), against a rolling
    resistance torque of lever arm `rolling` (the same regularised law on w, bounded by
    rolling g_n per unit mass). No closed form enters: whether it sticks, rolls or slips,
    and how fast, comes out of the integration."""
    from scipy.integrate import solve_ivp

    def rates(t, y):
        v, w = y
        s = v - radius * w if k is not None else v
        f = stiffness * s
        if abs(f) > mu_s * g_n:
            f = math.copysign(mu_k * g_n, s)
        if k is None:
            return [g_t - f, 0.0]
        tau = max(-rolling * g_n, min(rolling * g_n, stiffness * radius * radius * w))
        return [g_t - f, (f * radius - tau) / (k * radius * radius)]

    t = np.linspace(0.0, duration, 201)
    sol = solve_ivp(rates, (0.0, duration), list(start), method="Radau", t_eval=t, rtol=1e-10, atol=1e-12)
    late = t >= duration / 2
    return float(np.polyfit(t[late], sol.y[0][late], 1)[0]), float(np.polyfit(t[late], sol.y[1][late], 1)[0])


def square_or_crash(x):
    """A plain call for map_calls: x**2, a raised error for x < 0, a dead process for x == 13."""
    if x == 13:
        import os
        os.abort()
    if x < 0:
        raise ValueError(f"negative: {x}")
    return x * x


def echo(data):
    """A plain call that answers what it was sent (as large as it came)."""
    return data


class ReleaseBallistic(FakeAdapter):
    """A stand-in engine whose "releases" are those of a tiny PyPI package (iniconfig): from
    2.0 its gravity is 0.1 % strong, so `physval versions` on 1.1.1 and 2.0.0 has a change
    to find (free fall leaves Euler's closed form)."""
    package = "iniconfig"
    supported = ">=1.1.1,<3"

    def __init__(self):
        super().__init__(name="fake-release")

    def version(self):
        from importlib import metadata
        return metadata.version("iniconfig")

    def build(self, scene, settings):
        sim = super().build(scene, settings)
        if int(self.version().split(".")[0]) >= 2:
            sim.g = sim.g * 1.001
        return sim


BUILDS = [0]  # scenes built in this process


class HistoryFake(FakeAdapter):
    """`fake-history`: a ballistic engine with a history, as DART's (a world built where the
    last was freed): every scene a process builds starts 1e-7 faster than the one before."""

    def __init__(self):
        super().__init__("fake-history")

    def build(self, scene, settings):
        sim = super().build(scene, settings)
        BUILDS[0] += 1
        sim.v = {n: v * (1 + 1e-7 * BUILDS[0]) for n, v in sim.v.items()}
        return sim
