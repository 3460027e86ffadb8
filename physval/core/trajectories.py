"""Saved trajectories: `physval run --save-trajectories DIR` writes what each engine did,
one `.npz` file per job (states of every dynamic body, contact normal forces per pair,
and what the run was), so a user can plot it or try an observer on it:

    from physval.core.trajectories import load
    traj, meta = load("DIR/central_impact[drop,e=0.5]-mujoco.npz")
    z = traj.pos("ball")[:, 2]; meta["engine"], meta["dt"]
    FAMILY.observe(traj, meta["params"])          # the family's own observer, on this run
"""
from __future__ import annotations

import json
import re
from dataclasses import replace
from pathlib import Path

import numpy as np

from cases.trajectory import Trajectory
from physval.core.jobs import Job, Probe


def file_name(job: Job) -> str:
    return re.sub(r"[^\w.,=:+\-\[\]]+", "_", job.test_id) + ".npz"


class Saver(Probe):
    """Writes the job's trajectory and contact forces to DIR (probe_args 'dir')."""
    forces = True

    def __init__(self, job: Job):
        self.job = job
        self.folder = Path(dict(job.probe_args)["dir"])

    def after(self, run, sim, rebuild) -> dict:
        traj = run.trajectory
        arrays = {f"state:{n}": s for n, s in traj.states.items()}
        arrays |= {f"force:{a}|{b}": f for (a, b), f in (traj.forces or {}).items()}
        meta = {"family": self.job.family, "variant": self.job.variant.id, "params": self.job.variant.params,
                "engine": self.job.engine, "dt": traj.dt, "effects": sorted(traj.effects),
                "bodies": sorted(traj.bodies), "knobs": run.knobs}
        self.folder.mkdir(parents=True, exist_ok=True)
        path = self.folder / file_name(self.job)
        tmp = path.with_name("." + path.name + ".tmp.npz")
        np.savez_compressed(tmp, t=traj.t, meta=np.array(json.dumps(meta, default=str)), **arrays)
        tmp.replace(path)
        return {}


def with_saving(job: Job, folder: Path) -> Job:
    return replace(job, probe=f"{__name__}:Saver", probe_args=(("dir", str(Path(folder).resolve())),))


def load(path) -> tuple[Trajectory, dict]:
    """(Trajectory, what the run was) from a saved file."""
    with np.load(path) as data:
        meta = json.loads(str(data["meta"]))
        t = data["t"]
        states = {k.split(":", 1)[1]: data[k] for k in data.files if k.startswith("state:")}
        forces = {tuple(k.split(":", 1)[1].split("|")): data[k] for k in data.files if k.startswith("force:")}
    traj = Trajectory(dt=meta["dt"], t=t, states=states, forces=forces, effects=frozenset(meta["effects"]),
                      bodies=frozenset(meta["bodies"]))
    return traj, meta
