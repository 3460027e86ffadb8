"""MuJoCo Warp adapter: MuJoCo's own model of the scene, stepped by MuJoCo Warp in float32.

MuJoCo Warp (`mujoco-warp`, on NVIDIA Warp) is MuJoCo's solver rewritten as Warp kernels:
the engine behind MJX's Warp backend, Newton's MuJoCo solver and Isaac Lab. It reads a
compiled MjModel, so the scene's model is exactly the one adapters/mujoco_engine.py
compiles (`MuJoCoAdapter.model`: the same MJCF, pairs, solref, cone, Newton solver,
contact time scale); what differs is the implementation: float32 state and arithmetic,
Warp's collision routines and its Newton solver. Every difference it makes to a check is
therefore the port's own (`physval parity mujoco mujoco-warp`).

Device: the CPU by default (Warp compiles its kernels for the CPU with its bundled
compiler). `PHYSVAL_WARP_DEVICE=cuda:0` (or the adapter's `device` argument) runs the same
kernels on a GPU; the device is part of the engine's version string, so results of two
devices are never mixed in a store.

Stepping: one mujoco_warp.step is ~90 kernel launches, each ~0.1 ms of Python on the CPU.
The adapter records one step as a Warp graph once (`wp.capture_begin`: a CUDA graph on a
GPU; on the CPU an operation stream that Warp replays in C++) and replays it each step:
0.04 ms a step for a ball on the ground instead of 3-9 ms (measured, Warp 1.19).

Warp compiles its kernels on first use into its kernel cache: `WARP_CACHE_PATH`, which
physval sets to `warp/` in its cache folder (physval.core.store.engine_caches) unless it
is set already; with an empty cache the first step of a process costs about a minute of
CPU, with a full one about a second.

MuJoCo Warp never resets a blown-up state (MuJoCo C's autoreset, which the MJCF switches
off, does not exist there): the flag is cleared before the model goes to Warp
(`NOT_IN_WARP`), which asks for the same physics.
"""
from __future__ import annotations

import os
from importlib import metadata

import numpy as np

from adapters.base import Settings, Simulation, Unsupported
from adapters.lazy import require
from adapters.mujoco_engine import (CONTACT_STEPS, MuJoCoAdapter, MuJoCoPortTreeSimulation, MuJoCoSimulation,
                                    float32_capabilities, port_contacts)
from cases.scene import Scene

# warp (~4 s to import, it loads its runtime) and mujoco_warp are imported when a scene is
# first built (adapters/lazy.py)
require("mujoco_warp")
require("warp")

DEVICE_ENV = "PHYSVAL_WARP_DEVICE"  # e.g. cuda:0; unset: the CPU

# MuJoCo C's flags MuJoCo Warp does not have, and why clearing them asks for the same physics
NOT_IN_WARP = {"mjDSBL_AUTORESET": "MuJoCo Warp never resets a state that blew up (MuJoCo C's autoreset "
                                   "is off in the MJCF)"}

# Contacts a pair can make at once in MuJoCo's colliders (box-box: up to 8; box-plane: 4
# corners; a sphere: 1), and the cap of the per-world contact buffer: a body touches few
# others at once, so piles of hundreds of pairs need no buffer for every pair at its worst.
# A step that needs more raises (ContactOverflow), never drops contacts silently.
CONTACTS_PER_PAIR = 8
CONTACTS_PER_BODY = 48


def contact_capacity(model, ndyn: int) -> tuple[int, int]:
    """(nconmax, njmax) of one world of `model` (an MjModel whose contacts come from its pairs)
    with `ndyn` dynamic bodies: CONTACTS_PER_PAIR a pair, at most CONTACTS_PER_BODY a dynamic
    body, at least 16; and a contact's rows (its pair's condim, the elliptic cone) for each."""
    nconmax = max(16, min(CONTACTS_PER_PAIR * model.npair, CONTACTS_PER_BODY * ndyn))
    rows = int(model.pair_dim.max()) if model.npair else 1
    return nconmax, nconmax * rows


class ContactOverflow(RuntimeError):
    """More contacts in one step than the buffer the adapter allotted."""


def _warp():
    import warp as wp
    wp.config.quiet = True  # no banner on stdout
    wp.config.log_level = wp.LOG_WARNING  # no line per kernel module loaded (log level info)
    return wp


class MuJoCoWarpSimulation(MuJoCoSimulation):
    """MuJoCoSimulation with its data on Warp: the state rows, the contact read-out and the
    bookkeeping are MuJoCo C's (the base class), read from Warp's arrays."""

    run = None  # no rollout in MuJoCo Warp: step() and write_state() in turn

    def __init__(self, scene: Scene, model, knobs: dict, iterations: int, device: str):
        super().__init__(scene, model, knobs, iterations)  # the start state, in an MjData
        wp = _warp()
        import mujoco
        import mujoco_warp as mjw
        self._wp, self._mjw = wp, mjw
        cleared = {}
        for flag, why in NOT_IN_WARP.items():
            bit = int(getattr(mujoco.mjtDisableBit, flag))
            if model.opt.disableflags & bit:
                model.opt.disableflags &= ~bit
                cleared[flag] = why
        nconmax, njmax = contact_capacity(model, len(scene.dynamic_bodies))
        with wp.ScopedDevice(device):
            try:
                self._wm = mjw.put_model(model)
            except (NotImplementedError, ValueError) as exc:
                raise Unsupported(f"MuJoCo Warp cannot take the model: {exc}") from None
            self._wd = mjw.put_data(model, self._data, nconmax=nconmax, njmax=njmax,
                                    njmax_nnz=njmax * min(model.nv, 12))  # a contact row touches 2 bodies
            wp.capture_begin(device)
            try:
                mjw.step(self._wm, self._wd)
            finally:
                self._graph = wp.capture_end(device)
        self._device = device
        self._naconmax = self._wd.naconmax
        self._cpu = wp.get_device(device).is_cpu
        from mujoco_warp._src.types import ContactType
        self._exported = int(ContactType.CONSTRAINT)  # the contacts the solver acted on
        self._bind_state()
        knobs["mujoco_warp"] = {"device": device, "float_bits": 32, "nconmax": nconmax, "njmax": njmax,
                                "stepping": "one step recorded as a Warp graph, replayed each step",
                                "cleared_flags": cleared}

    def _bind_state(self) -> None:
        """The state arrays write_state and states() read: on the CPU views into Warp's own
        memory (float32), which every step updates; on a GPU copies, taken after each step."""
        self._qpos = self._wd.qpos.numpy()[0]
        self._qvel = self._wd.qvel.numpy()[0]
        self._nacon = self._wd.nacon.numpy()

    def step(self) -> None:
        self._wp.capture_launch(self._graph)
        if not self._cpu:
            self._bind_state()
        if self._nacon[0] > self._naconmax:
            raise ContactOverflow(f"{int(self._nacon[0])} contacts in one step, more than the "
                                  f"{self._naconmax} allotted (CONTACTS_PER_BODY)")

    def _contacts(self):
        """The last step's contacts in the layout the base class reads from an MjData
        (ncon, contact.*, efc_force with each contact's rows contiguous from its
        efc_address), taken from Warp's arrays: the contacts of this world that are
        constraints (those get_data_into exports and MuJoCo does not exclude), without copying the rest
        of the data (3.4 ms a step for a ball)."""
        if not self._elliptic:  # the base class decodes pyramidal forces with MuJoCo C
            self._mjw.get_data_into(self._data, self._model, self._wd)
            return self._data
        c = self._wd.contact
        n = min(int(self._wd.nacon.numpy()[0]), self._naconmax)
        keep = np.flatnonzero((c.worldid.numpy()[:n] == 0) & ((c.type.numpy()[:n] & self._exported) != 0))
        return port_contacts(c.efc_address.numpy()[keep], c.dim.numpy()[keep], self._wd.efc.force.numpy()[0],
                             c.geom.numpy()[keep], c.frame.numpy()[keep].reshape(-1, 9), c.pos.numpy()[keep],
                             c.dist.numpy()[keep], c.adhesion.numpy()[keep])

    def close(self) -> None:
        super().close()
        self._wm = self._wd = self._graph = None


class MuJoCoWarpTreeSimulation(MuJoCoWarpSimulation, MuJoCoPortTreeSimulation):
    """A scene with joints or loads on MuJoCo Warp: stepped as MuJoCoWarpSimulation, its
    states read through MuJoCo C's kinematics of Warp's qpos and qvel."""


class MuJoCoWarpAdapter(MuJoCoAdapter):
    name = "mujoco-warp"
    package = "mujoco-warp"
    # MuJoCo Warp is released with MuJoCo, one release number for both: `physval versions`
    # installs the pair. 3.13.0 is the oldest on which the conformance battery passes with
    # today's Warp (measured with 1.19.0): 3.11-3.12 have no contact adhesion to read forces
    # with, 3.10 does not compile on this Warp, 3.5 has put_data without njmax_nnz.
    supported = ">=3.13.0,<5"
    packages = ("mujoco-warp", "mujoco")
    # MuJoCo C's (float32_capabilities): qpos, qvel, masses and every kernel's arithmetic in
    # single precision; joints and loads as MuJoCo C's model has them
    capabilities = float32_capabilities()

    # A default run (and the default test suite) runs the core families and the conformance
    # battery on it; named (`--engines mujoco-warp`, `pytest --engine mujoco-warp`) every family.
    # The model is MuJoCo's, which the default run covers in full, and every process pays Warp's
    # start (~4 s warm; ~40 s of compiling with an empty kernel cache).
    default_tags = frozenset({"core", "conformance"})
    plantable = frozenset()  # MuJoCoSimulation.plant builds MuJoCo's C engine, not its Warp port

    def __init__(self, contact_steps: float = CONTACT_STEPS, ground: str = "plane", device: str | None = None):
        """As MuJoCoAdapter; device: a Warp device ("cpu", "cuda:0"), by default
        $PHYSVAL_WARP_DEVICE, else the CPU."""
        super().__init__(contact_steps, ground)
        self.device = device or os.environ.get(DEVICE_ENV) or "cpu"

    def version(self) -> str:
        return f"{metadata.version('mujoco-warp')} (warp {metadata.version('warp-lang')}, {self.device})"

    def build(self, scene: Scene, settings: Settings) -> Simulation:
        kind = MuJoCoWarpTreeSimulation if scene.joints or scene.loads else MuJoCoWarpSimulation
        return kind(scene, *self.model(scene, settings), device=self.device)

