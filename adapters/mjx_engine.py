"""MJX adapter: MuJoCo's own model of the scene, stepped by MJX (MuJoCo in JAX) on the CPU.

MJX (`mujoco-mjx`, imported as `mujoco.mjx`) is MuJoCo's pipeline rewritten in JAX: the
route to MuJoCo that learning users take (Brax, MuJoCo Playground). Like MuJoCo Warp
(adapters/mujoco_warp_engine.py) it reads a compiled MjModel, so the scene's model is
exactly the one adapters/mujoco_engine.py compiles (`MuJoCoAdapter.model`: the same MJCF,
pairs, solref, cone, Newton solver, contact time scale); what differs is the
implementation: JAX's float32 by default, MJX's own collision functions (a fixed contact
count per geom pair, each contact's row in the constraint problem whether it touches or
not) and its Newton solver. Every difference it makes to a check is therefore the port's
own (`physval parity mujoco mujoco-mjx`).

Releases: MJX is released with MuJoCo, one release number for both, but MuJoCo 4 ships no
MJX of its own and `mujoco-mjx` stops at 3.17.0, which declares `mujoco>=3.17.0.dev0` and
so installs beside MuJoCo 4.0.0 (measured: `put_model` takes MuJoCo 4's MjModel, and every
family it can represent runs). That pairing is what `pip install ".[mjx]"` gives, and what
the known deviations were measured on.

Implementation: `impl="jax"` (MJX's own; its "warp" implementation is MuJoCo Warp, which
is `mujoco-warp` here) on JAX's CPU device. One step is `jax.jit(mjx.step)` (milliseconds of
Python dispatch); a run that reads no forces or points steps in jitted scans of ROLLOUT steps
(`run`, tens of microseconds a step, the same states bit for bit). What is compiled depends
on the model's sizes only, so scenes of the same shape share it within a process. JAX compiles on first use (several seconds of CPU a new model shape) into its
persistent cache, `JAX_COMPILATION_CACHE_DIR`, which physval points into its cache folder
(physval.core.store.engine_caches) unless it is set already.

Contacts are read in MuJoCo C's layout (MuJoCoSimulation._contacts): the contacts MJX solved,
from MJX's own arrays (elliptic cone) or through `mjx.get_data_into` (pyramidal, whose forces
MuJoCo C decodes).
"""
from __future__ import annotations

import functools
from importlib import metadata
from pathlib import Path

import numpy as np

from adapters.base import Settings, Simulation, Unsupported
from adapters.mujoco_engine import (CONTACT_STEPS, MuJoCoAdapter, MuJoCoPortTreeSimulation, MuJoCoSimulation,
                                    float32_capabilities, geom_bodies, port_contacts)
from cases.scene import Scene

# mujoco-mjx installs into MuJoCo's package (mujoco/mjx) and jax (~1 s to import) comes with
# it: both are imported when a scene is first built (adapters/lazy.py); a missing MJX is an
# ImportError now, so the registry reports the engine as not installed
try:
    metadata.version("mujoco-mjx")
except metadata.PackageNotFoundError:
    raise ImportError("No module named 'mujoco.mjx'", name="mujoco.mjx") from None

IMPL = "jax"  # MJX's own implementation (its "warp" one is MuJoCo Warp, adapters/mujoco_warp_engine.py)

# MJX 3.17.0's Newton solver fails on an elliptic cone whose contacts are all frictionless
# (condim 1): it indexes with an empty list, which JAX takes as a float array (TypeError,
# mjx/_src/solver.py _update_constraint). Without friction rows the cone has nothing to
# shape, so such a model is stepped with the pyramidal cone: the same physics.
FRICTIONLESS_CONE = "pyramidal"


# Steps a compiled rollout (jax.lax.scan over mjx.step) takes per call in Simulation.run; the
# rest of a call's steps go one at a time. One length, so one compile per model shape.
ROLLOUT = 256


@functools.cache
def _rollout(length: int):
    """jax.jit of `length` mjx.steps in one scan, returning the last data and every step's
    qpos and qvel."""
    jax, mjx, _, _ = _mjx()

    def roll(m, d):
        def body(d, _):
            d = mjx.step(m, d)
            return d, (d.qpos, d.qvel)
        return jax.lax.scan(body, d, None, length=length)
    return jax.jit(roll)


def missing_collision(model, scene: Scene) -> str | None:
    """Why MJX cannot collide a geom pair that `model` (scene_mjcf's compiled model of
    `scene`) collides, or None. MJX has a collision function for some pairs of geom types
    only (mjx/_src/collision_driver.py, _COLLISION_FUNC, asked through has_collision_fn):
    in 3.17.0 none for box-cylinder and cylinder-mesh (so none for a cylinder against a box,
    a rect, a hull or a polygon's prism), which MuJoCo C collides by general convex
    collision. put_model refuses such a model with the geom types only; this names the
    scene's bodies and shapes, and is asked before any JAX array is made."""
    import mujoco
    from mujoco.mjx._src import collision_driver
    body_of = geom_bodies(scene)
    shape_of = {b.name: b.shape.kind for b in scene.bodies}
    for g1, g2, _ in collision_driver.geom_pairs(model):
        t1, t2 = model.geom_type[g1], model.geom_type[g2]
        if collision_driver.has_collision_fn(t1, t2):
            continue
        names = [body_of.get(mujoco.mj_id2name(model, mujoco.mjtObj.mjOBJ_GEOM, g), "?") for g in (g1, g2)]
        kinds = " against ".join(f"{shape_of.get(n, '?')} {n!r}" for n in names)
        types = "-".join(mujoco.mjtGeom(t).name[len("mjGEOM_"):].lower() for t in (t1, t2))
        return (f"{kinds}: MJX {metadata.version('mujoco-mjx')} has no collision function for MuJoCo's "
                f"{types} geom pair (mjx/_src/collision_driver.py), which MuJoCo C collides by general convex "
                "collision")
    return None


# JAX keeps every program it compiled loaded for the process's life (jit's caches), each in
# memory mappings of its own: 1000-3000 a model shape (measured: 12360 after 11 jobs of 5
# families). A worker that had run ~140 MJX jobs held 40-47 thousand of Linux's 65530
# (vm.max_map_count); XLA's LLVM then failed ("Cannot allocate memory") and the worker died
# (SIGSEGV): 2 of 287 jobs of an on-demand run. Past this share of the limit, a new scene
# first drops the compiled programs (jax.clear_caches: 1123 maps left); a shape met again
# loads from JAX's persistent cache (2.9 s against 8.4 s compiling, 1.0 s still loaded).
MAPS_SHARE = 0.5


def _release_programs_if_crowded(jax) -> None:
    """jax.clear_caches() when the process's memory mappings pass MAPS_SHARE of the
    system's limit (Linux; elsewhere nothing is read and nothing dropped)."""
    try:
        limit = int(Path("/proc/sys/vm/max_map_count").read_text())
        with open("/proc/self/maps", "rb") as maps:
            held = sum(1 for _ in maps)
    except (OSError, ValueError):
        return
    if held > MAPS_SHARE * limit:
        jax.clear_caches()


@functools.cache
def _mjx():
    """(jax, mjx, the jitted step, the CPU device), once a process."""
    import jax
    from mujoco import mjx
    return jax, mjx, jax.jit(mjx.step), jax.devices("cpu")[0]


class MjxSimulation(MuJoCoSimulation):
    """MuJoCoSimulation with its data in JAX: the start state and the read-out are MuJoCo
    C's (the base class), the stepping MJX's."""

    def __init__(self, scene: Scene, model, knobs: dict, iterations: int):
        import mujoco
        changed = {}
        if model.opt.cone == mujoco.mjtCone.mjCONE_ELLIPTIC and not (model.pair_dim > 1).any():
            model.opt.cone = getattr(mujoco.mjtCone, f"mjCONE_{FRICTIONLESS_CONE.upper()}")
            changed["cone"] = f"{FRICTIONLESS_CONE}: no contact has friction rows (FRICTIONLESS_CONE)"
        super().__init__(scene, model, knobs, iterations)  # the start state, in an MjData
        jax, mjx, self._step, device = _mjx()
        _release_programs_if_crowded(jax)
        try:
            self._mx = mjx.put_model(model, device=device, impl=IMPL)
        except (NotImplementedError, ValueError) as exc:
            raise Unsupported(f"MJX cannot take the model: {exc}") from None
        self._dx = mjx.put_data(model, self._data, device=device, impl=IMPL)
        self._mjx = mjx
        self._pulled = True  # self._data holds the current step's contacts
        self._bind_state()
        knobs["mjx"] = {"impl": IMPL, "device": str(device), "float_bits": 32 if not jax.config.jax_enable_x64 else 64,
                        "stepping": f"jax.jit(mjx.step) a step; runs without read-outs in jitted scans of {ROLLOUT} steps",
                        "changed": changed}

    def _bind_state(self) -> None:
        """The state arrays write_state and states() read: host copies of this step's."""
        self._qpos = np.asarray(self._dx.qpos)
        self._qvel = np.asarray(self._dx.qvel)

    def step(self) -> None:
        self._dx = self._step(self._mx, self._dx)
        self._bind_state()
        self._pulled = False

    def run(self, steps: int, out: np.ndarray) -> None:
        """`steps` steps recorded into out (qpos then qvel a row), ROLLOUT at a time in one
        compiled scan (one Python call instead of one a step), the rest with step()."""
        i, nq = 0, self._nq
        while steps - i >= ROLLOUT:
            self._dx, (qpos, qvel) = _rollout(ROLLOUT)(self._mx, self._dx)
            out[i:i + ROLLOUT, :nq], out[i:i + ROLLOUT, nq:] = np.asarray(qpos), np.asarray(qvel)
            i += ROLLOUT
        self._bind_state()
        self._pulled = False
        while i < steps:
            self.step()
            self.write_state(out[i])
            i += 1

    def _contacts(self):
        """The last step's contacts in MuJoCo C's layout (ncon, contact.*, efc_force) when
        first asked for after a step. With the elliptic cone, from MJX's own arrays: the
        contacts get_data_into would export (dist <= 0), each with all its rows
        (port_contacts). get_data_into itself deletes every row whose Jacobian is zero and
        renumbers the rest, so a planar (2D) scene's contacts kept 2 of their 3 rows (the
        tangent out of the plane moves nothing) and the read-out took another contact's row
        for the third (IndexError past the last). The pyramidal cone's forces are decoded
        by MuJoCo C (mj_contactForce) from the MjData get_data_into fills."""
        if self._elliptic:
            import jax
            c = jax.device_get(self._dx._impl.contact)
            keep = np.flatnonzero(c.dist <= 0)
            dim = c.dim[keep]
            rows = c.efc_address[keep][:, None] + np.arange(max(int(dim.max()), 1) if len(keep) else 1)
            return port_contacts(rows, dim, np.asarray(self._dx._impl.efc_force), c.geom[keep],
                                 c.frame[keep].reshape(-1, 9), c.pos[keep], c.dist[keep], np.zeros(len(keep)))
        if not self._pulled:
            self._mjx.get_data_into(self._data, self._model, self._dx)
            # get_data_into copies the contacts MJX solved (dist <= 0, each with its rows) but
            # not mjContact's exclude and adhesion, which MJX's Contact lacks: what
            # _realloc_con_efc left there dropped solved contacts from the read-out and took
            # an adhesion off others (measured: a lying cylinder at rest read 4.905 N of its
            # 9.81, a resting box 3.45). None is excluded, and no scene has adhesion.
            self._data.contact.exclude[:] = 0
            self._data.contact.adhesion[:] = 0.0
            self._pulled = True
        return self._data

    def close(self) -> None:
        super().close()
        self._mx = self._dx = None


class MjxTreeSimulation(MjxSimulation, MuJoCoPortTreeSimulation):
    """A scene with joints or loads on MJX: stepped as MjxSimulation a step at a time (the
    scans' rows are qpos and qvel, not the tree's states), its states read through MuJoCo
    C's kinematics of MJX's qpos and qvel."""

    run = None


class MjxAdapter(MuJoCoAdapter):
    name = "mujoco-mjx"
    package = "mujoco-mjx"
    # mujoco-mjx 3.17.0 (its last release) beside MuJoCo 4.0.0: the pair the battery ran on
    supported = ">=3.17.0,<4"
    packages = ("mujoco-mjx", "mujoco")
    # MuJoCo C's (float32_capabilities): JAX's default floats, single precision for qpos, qvel and
    # every operation; joints and loads as MuJoCo C's model has them
    capabilities = float32_capabilities()
    # Runs only when asked (--on-demand): a step that reads forces or contact points costs
    # 1-4 ms of Python dispatch and copying (25 us in the scans of a run that reads neither), a
    # new model shape 8-12 s of compiling; central_impact alone took 1276 s of wall time on
    # one worker of a loaded machine (44 jobs, the dt = 1e-4 drops 65-425 s each before the
    # scans; measured again: 13-316 s a job, 45-160 s typical, with 7 sessions on 2 cores).
    # The model is MuJoCo's, which the default run covers in full; its known deviations are
    # recorded for the families a narrow run covered (xfails/mujoco-mjx.txt).
    default_tags = frozenset()

    def on_demand(self, scene: Scene) -> str | None:
        return ("MJX costs milliseconds a step from Python and seconds of compiling a model shape; "
                "run with --on-demand")
    plantable = frozenset()  # MuJoCoSimulation.plant builds MuJoCo's C engine, not MJX

    def __init__(self, contact_steps: float = CONTACT_STEPS, ground: str = "plane"):
        super().__init__(contact_steps, ground)

    def version(self) -> str:
        return f"{metadata.version('mujoco-mjx')} (mujoco {metadata.version('mujoco')}, jax {metadata.version('jax')}, cpu)"

    def build(self, scene: Scene, settings: Settings) -> Simulation:
        model, knobs, iterations = self.model(scene, settings)
        reason = missing_collision(model, scene)
        if reason:
            raise Unsupported(reason)
        return (MjxTreeSimulation if scene.joints or scene.loads else MjxSimulation)(scene, model, knobs, iterations)
