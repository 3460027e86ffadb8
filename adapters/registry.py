"""Engines by name. Each entry is one adapter file; the engine's package is imported only
when the engine is used, so a missing engine fails only the runs that need it."""
from __future__ import annotations

import importlib

from adapters.base import Adapter

# name -> (module, class, keyword arguments)
ENGINES: dict[str, tuple[str, str, dict]] = {
    "reference": ("adapters.reference_engine", "ReferenceAdapter", {}),
    # every formulation of the lecture notes as its own engine (reference_impl/<module>.py)
    "reference-si": ("adapters.reference_engine", "ReferenceAdapter", {"formulation": "si", "name": "reference-si"}),
    "reference-pgs": ("adapters.reference_engine", "ReferenceAdapter", {"formulation": "pgs"}),
    "reference-lemke": ("adapters.reference_engine", "ReferenceAdapter", {"formulation": "lemke"}),
    "reference-spook": ("adapters.reference_engine", "ReferenceAdapter", {"formulation": "spook"}),
    "reference-force": ("adapters.reference_engine", "ReferenceAdapter",
                        {"formulation": "acceleration_lcp", "name": "reference-force"}),
    "reference-newton-coulomb": ("adapters.reference_engine", "ReferenceAdapter",
                                 {"formulation": "single_contact", "name": "reference-newton-coulomb"}),
    "reference-hertz": ("adapters.reference_engine", "ReferenceAdapter",
                        {"formulation": "compliant", "name": "reference-hertz", "params": {"compliant_law": "hertz"}}),
    "reference-hooke": ("adapters.reference_engine", "ReferenceAdapter",
                        {"formulation": "compliant", "name": "reference-hooke", "params": {"compliant_law": "hooke"}}),
    "pybullet": ("adapters.pybullet_engine", "PyBulletAdapter", {}),
    # configurations users run, each its own engine with its own deviations (the module
    # notes of adapters/pybullet_engine.py): rigid bodies with warm starting everywhere,
    # no friction anchors, and a box for the ground plane
    "pybullet-rigid": ("adapters.pybullet_engine", "PyBulletAdapter", {"name": "pybullet-rigid", "bodies": "rigid"}),
    "pybullet-noanchor": ("adapters.pybullet_engine", "PyBulletAdapter",
                          {"name": "pybullet-noanchor", "friction_anchor": False}),
    "pybullet-boxground": ("adapters.pybullet_engine", "PyBulletAdapter", {"name": "pybullet-boxground", "ground": "box"}),
    "mujoco": ("adapters.mujoco_engine", "MuJoCoAdapter", {}),
    "pymunk": ("adapters.pymunk_engine", "PymunkAdapter", {}),
    # a 1 mm collision slop: stacks stand at 60 Hz, bodies rest 1 mm deep (pymunk_engine.py)
    "pymunk-slop1mm": ("adapters.pymunk_engine", "PymunkAdapter", {"name": "pymunk-slop1mm", "collision_slop": 1e-3}),
    "dart": ("adapters.dart_engine", "DartAdapter", {}),
}


class EngineError(ValueError):
    """An unknown or unavailable engine; the message says which and what to do."""


def engine_names() -> list[str]:
    return list(ENGINES)


def get(name: str) -> Adapter:
    if name not in ENGINES:
        raise EngineError(f"unknown engine {name!r}: choose from {', '.join(ENGINES)}")
    module, cls, kwargs = ENGINES[name]
    try:
        mod = importlib.import_module(module)
    except ImportError as exc:
        raise EngineError(f"engine {name!r} is not installed ({exc.name or exc}): "
                          f"pip install '.[{name}]'") from None
    return getattr(mod, cls)(**kwargs)


def available(name: str) -> bool:
    try:
        get(name)
        return True
    except EngineError:
        return False
