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
    "mujoco": ("adapters.mujoco_engine", "MuJoCoAdapter", {}),
    "pymunk": ("adapters.pymunk_engine", "PymunkAdapter", {}),
    "dart": ("adapters.dart_engine", "DartAdapter", {}),
    # Drake's contact models and discrete approximations as variants (adapters/drake_engine.py).
    # The plain name is Drake's own default configuration (MultibodyPlantConfig):
    # hydroelastic contact, Lagged approximation; point contact gives one point per pair,
    # so boxes rest on one corner at a time and stacks sink by centimetres
    "drake": ("adapters.drake_engine", "DrakeAdapter",
              {"approximation": "lagged", "contact_model": "hydroelastic", "name": "drake"}),
    "drake-sap": ("adapters.drake_engine", "DrakeAdapter", {"approximation": "sap"}),
    "drake-lagged": ("adapters.drake_engine", "DrakeAdapter", {"approximation": "lagged"}),
    "drake-similar": ("adapters.drake_engine", "DrakeAdapter", {"approximation": "similar"}),
    "drake-tamsi": ("adapters.drake_engine", "DrakeAdapter", {"approximation": "tamsi"}),
    "drake-hydro": ("adapters.drake_engine", "DrakeAdapter",
                    {"approximation": "sap", "contact_model": "hydroelastic"}),
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
        extra = name.split("-")[0]  # an engine's variants share its extra (drake-sap: drake)
        raise EngineError(f"engine {name!r} is not installed ({exc.name or exc}): "
                          f"pip install '.[{extra}]'") from None
    return getattr(mod, cls)(**kwargs)


def available(name: str) -> bool:
    try:
        get(name)
        return True
    except EngineError:
        return False
