"""Engines by name: the built-in adapters, plug-ins registered by installed packages under
the entry-point group `physval.engines` (name = "module:Class"), and adapters named ad hoc
with `--adapter module:Class` (or `path/to/file.py:Class`). An engine's package is
imported only when the engine is used, so a missing engine fails only the runs that need it.

A plug-in entry point or ad-hoc spec names an `Adapter` subclass (instantiated without
arguments), an `Adapter` instance, or a function returning one. Its known deviations live
in the file the adapter declares (`Adapter.deviations_file()`; by default
`xfails/<name>.txt` beside the adapter's module), so a plug-in ships them with itself.

`version_problem(name)` says in one line when the installed engine release lies outside the
range its adapter declares (`Adapter.supported`).
"""
from __future__ import annotations

import functools
import importlib
import importlib.util
import sys
from dataclasses import dataclass, field
from importlib import metadata
from importlib.metadata import entry_points
from pathlib import Path

from adapters.base import Adapter
from cases.family import user_code

ENTRY_POINT_GROUP = "physval.engines"

# name -> (module, class, keyword arguments)
ENGINES: dict[str, tuple[str, str, dict]] = {
    "reference": ("adapters.reference_engine", "ReferenceAdapter", {}),
    # every formulation of the lecture notes as its own engine (reference_impl/<module>.py)
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
    # PyBullet's other constraint solvers (constraintSolverType): the MLCP solver around
    # Dantzig's pivoting and around projected Gauss-Seidel (pybullet ignores NNCG, Lemke
    # and block PGS: adapters/pybullet_engine.py SOLVERS)
    "pybullet-dantzig": ("adapters.pybullet_engine", "PyBulletAdapter", {"name": "pybullet-dantzig", "solver": "dantzig"}),
    "pybullet-pgs": ("adapters.pybullet_engine", "PyBulletAdapter", {"name": "pybullet-pgs", "solver": "pgs"}),
    # continuous collision: Bullet's swept sphere on every dynamic body (adapters/pybullet_engine.py)
    "pybullet-ccd": ("adapters.pybullet_engine", "PyBulletAdapter", {"name": "pybullet-ccd", "ccd": True}),
    "mujoco": ("adapters.mujoco_engine", "MuJoCoAdapter", {}),
    # what a user gets who tunes nothing: pyramidal cone, impratio 1, default solimp, solref
    # where e = 0 and solreffriction (adapters/mujoco_engine.py, "mujoco-defaults")
    "mujoco-defaults": ("adapters.mujoco_engine", "MuJoCoAdapter", {"name": "mujoco-defaults", "defaults": "all"}),
    # MuJoCo 4's speculative contacts (flag speculative): contacts a step ahead of fast geoms
    "mujoco-speculative": ("adapters.mujoco_engine", "MuJoCoAdapter",
                           {"name": "mujoco-speculative", "speculative": True}),
    # MuJoCo's model stepped by its Warp port in float32 (adapters/mujoco_warp_engine.py)
    "mujoco-warp": ("adapters.mujoco_warp_engine", "MuJoCoWarpAdapter", {}),
    # MuJoCo's model stepped by MJX, its JAX port, in float32 on the CPU (adapters/mjx_engine.py)
    "mujoco-mjx": ("adapters.mjx_engine", "MjxAdapter", {}),
    "pymunk": ("adapters.pymunk_engine", "PymunkAdapter", {}),
    # a 1 mm collision slop: stacks stand at 60 Hz, bodies rest 1 mm deep (pymunk_engine.py)
    "pymunk-slop1mm": ("adapters.pymunk_engine", "PymunkAdapter", {"name": "pymunk-slop1mm", "collision_slop": 1e-3}),
    "dart": ("adapters.dart_engine", "DartAdapter", {}),
    "box2d": ("adapters.box2d_engine", "Box2DAdapter", {}),
    "box3d": ("adapters.box3d_engine", "Box3DAdapter", {}),  # Box3D through robox3d's C API
    "rapier": ("adapters.rapier_engine", "RapierAdapter", {}),
    # continuous collision: Box2D's and Box3D's bullets (continuous on, isBullet on every dynamic
    # body), Rapier's CCD (ccd_enabled); in a default run only the families tagged "swept"
    "box2d-bullet": ("adapters.box2d_engine", "Box2DAdapter", {"name": "box2d-bullet", "bullet": True}),
    "box3d-bullet": ("adapters.box3d_engine", "Box3DAdapter", {"name": "box3d-bullet", "bullet": True}),
    "rapier-ccd": ("adapters.rapier_engine", "RapierAdapter", {"name": "rapier-ccd", "ccd": True}),
    # PhysX 5 through ovphysx (pre-release, USD-authored scenes; adapters/physx_engine.py)
    "physx": ("adapters.physx_engine", "PhysXAdapter", {}),
    # PhysX's projected Gauss-Seidel solver: static friction holds to about 0.42 for mu_s = 0.5, mu_k = 0.3
    # (TGS: only to mu_k; adapters/physx_engine.py)
    "physx-pgs": ("adapters.physx_engine", "PhysXAdapter", {"name": "physx-pgs", "solver": "PGS"}),
    # continuous collision: PhysX's swept CCD (enableCCD on the scene and every dynamic body); in a
    # default run only the families tagged "swept"
    "physx-ccd": ("adapters.physx_engine", "PhysXAdapter", {"name": "physx-ccd", "ccd": True}),
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
    # the continuous plant integrated by CENIC, Drake's error-controlled convex integrator (ICF
    # contact, Hunt & Crossley): its accuracy target, not dt, sets the error
    "drake-cenic": ("adapters.drake_engine", "DrakeAdapter", {"approximation": "cenic"}),
    # Newton's rigid-body solvers, each its own engine (adapters/newton_engine.py)
    "newton-xpbd": ("adapters.newton_engine", "NewtonAdapter", {"solver": "xpbd"}),
    "newton-semi-implicit": ("adapters.newton_engine", "NewtonAdapter", {"solver": "semi-implicit"}),
    "newton-featherstone": ("adapters.newton_engine", "NewtonAdapter", {"solver": "featherstone"}),
    "newton-vbd": ("adapters.newton_engine", "NewtonAdapter", {"solver": "vbd"}),
    "newton-mujoco": ("adapters.newton_engine", "NewtonAdapter", {"solver": "mujoco"}),
    "newton-kamino": ("adapters.newton_engine", "NewtonAdapter", {"solver": "kamino"}),
    # Genesis' rigid solver on the CPU (adapters/genesis_engine.py): the elliptic cone, which it
    # resolves to 'signorini' (the more faithful), and its default resolution (pyramidal cone, 'convex')
    "genesis": ("adapters.genesis_engine", "GenesisAdapter", {}),
    "genesis-defaults": ("adapters.genesis_engine", "GenesisAdapter", {"configuration": "defaults"}),
}
# The pip extra that installs each built-in engine's package (README, pyproject.toml).
EXTRAS = {"pybullet": "pybullet", "mujoco": "mujoco", "mujoco-warp": "mujoco-warp", "mujoco-mjx": "mjx",
          "pymunk": "pymunk", "dart": "dart",
          "box2d": "box2d", "box3d": "box3d", "rapier": "rapier", "drake": "drake", "newton": "newton",
          "physx": "physx", "genesis": "genesis"}


class EngineError(ValueError):
    """An unknown or unavailable engine; the message says which and what to do."""


@dataclass(frozen=True)
class EngineSpec:
    """Where an engine comes from and how to make its adapter."""
    name: str
    origin: str                 # "built-in", "entry point (distribution)", "--adapter"
    target: str                 # "module:Class" or "path/file.py:Class"
    kwargs: dict = field(default_factory=dict)


def _builtin() -> dict[str, EngineSpec]:
    return {n: EngineSpec(n, "built-in", f"{m}:{c}", kw) for n, (m, c, kw) in ENGINES.items()}


@functools.cache
def _plugins() -> dict[str, EngineSpec]:
    out = {}
    for ep in entry_points(group=ENTRY_POINT_GROUP):
        dist = getattr(ep, "dist", None)
        origin = f"entry point ({dist.name} {dist.version})" if dist is not None else "entry point"
        out[ep.name] = EngineSpec(ep.name, origin, ep.value)
    return out


# What an adapter's code may do, said in the one-line error when it does something else.
ADAPTER_RULE = "an adapter's module must import, and its class be made, without error or exit"


def _import_target(target: str):
    """The object a 'module:attr' or 'path/to/file.py:attr' spec names. EngineError if
    it cannot be found, or importing it raises (an exit included)."""
    if ":" not in target:
        raise EngineError(f"--adapter {target!r}: must read 'module:Class' or 'path/to/file.py:Class'")
    where, attr = target.rsplit(":", 1)
    path = Path(where).resolve()
    if where.endswith(".py") and not path.is_file():
        raise EngineError(f"--adapter {target!r}: no file {where}")
    with user_code(f"adapter {target!r}", "cannot be imported:", ADAPTER_RULE, error=EngineError):
        if where.endswith(".py"):
            name = f"physval_user_adapters.{path.stem}"
            module = sys.modules.get(name)
            if module is None or getattr(module, "__file__", None) != str(path):
                spec = importlib.util.spec_from_file_location(name, path)
                module = importlib.util.module_from_spec(spec)
                sys.modules[name] = module
                try:
                    spec.loader.exec_module(module)
                except BaseException:
                    del sys.modules[name]  # not half-loaded the next time
                    raise
        else:
            module = importlib.import_module(where)
    try:
        return getattr(module, attr)
    except AttributeError:
        raise EngineError(f"adapter {target!r}: {where} has no {attr!r}") from None


def _make(target: str, kwargs: dict) -> Adapter:
    obj = _import_target(target)
    if isinstance(obj, Adapter):
        return obj
    with user_code(f"adapter {target!r}", "cannot be made:", ADAPTER_RULE, error=EngineError):
        made = obj(**kwargs)
    if not isinstance(made, Adapter):
        raise EngineError(f"adapter {target!r} gives a {type(made).__name__}, not an adapters.base.Adapter")
    return made


@functools.cache
def adhoc(target: str) -> EngineSpec:
    """The spec of an `--adapter module:Class`, named by the adapter's own `name`."""
    adapter = _make(target, {})
    return EngineSpec(adapter.name, "--adapter", target)


def specs(adapters: tuple[str, ...] = ()) -> dict[str, EngineSpec]:
    """Every engine by name: built-ins, then installed plug-ins, then ad-hoc adapters; a
    plug-in or ad-hoc adapter may not take a name already in use."""
    out = _builtin()
    for extra in list(_plugins().values()) + [adhoc(t) for t in adapters]:
        if extra.name in out and out[extra.name].target != extra.target:
            raise EngineError(f"engine name {extra.name!r} of {extra.origin} {extra.target} is taken by "
                              f"{out[extra.name].origin} {out[extra.name].target}: rename it")
        out[extra.name] = extra
    return out


def engine_names(adapters: tuple[str, ...] = ()) -> list[str]:
    return list(specs(adapters))


def get(name: str, adapters: tuple[str, ...] = ()) -> Adapter:
    """The adapter of an engine; EngineError if unknown or not installed."""
    known = specs(adapters)
    if name not in known:
        raise EngineError(f"unknown engine {name!r}: choose from {', '.join(known)}")
    spec = known[name]
    if spec.origin == "built-in":
        module, cls = spec.target.split(":")
        try:  # an adapter may require a package of its own configuration (newton-mujoco: mujoco_warp)
            return getattr(importlib.import_module(module), cls)(**spec.kwargs)
        except ImportError as exc:
            extra = EXTRAS.get(name) or EXTRAS.get(name.split("-")[0], name.split("-")[0])
            raise EngineError(f"engine {name!r} is not installed ({exc.name or exc}): "
                              f"pip install '.[{extra}]'") from None
    adapter = _make(spec.target, spec.kwargs)
    if adapter.name != name:
        raise EngineError(f"{spec.origin} {name!r} = {spec.target} makes an adapter named {adapter.name!r}: "
                          "the names must agree")
    return adapter


def available(name: str, adapters: tuple[str, ...] = ()) -> bool:
    try:
        get(name, adapters)
        return True
    except EngineError:
        return False


def range_problem(adapter: Adapter, installed: str) -> str | None:
    """One line if release `installed` of the adapter's package lies outside the adapter's
    `supported` range, else None (also when it declares none). Pre-releases count as
    their release."""
    if adapter.supported is None:
        return None
    from packaging.specifiers import SpecifierSet
    from packaging.version import InvalidVersion, Version
    try:
        inside = SpecifierSet(adapter.supported).contains(Version(installed), prereleases=True)
    except InvalidVersion:
        return (f"{adapter.package} {installed} is not a PEP 440 version: whether it lies in the supported "
                f"range {adapter.supported} of adapter {adapter.name} cannot be told")
    if inside:
        return None
    return f"{adapter.package} {installed} is outside the supported range {adapter.supported} of adapter {adapter.name}"


def version_problem(name: str, adapters: tuple[str, ...] = ()) -> str | None:
    """One line if the installed release of engine `name` lies outside its adapter's
    `supported` range ("mujoco 3.1.0 is outside the supported range >=3.2.6,<5 of adapter
    mujoco"), else None. EngineError as `get` for an unknown or missing engine."""
    return release_problem(get(name, adapters))


def installed_release(adapter: Adapter) -> str | None:
    """The installed release of the adapter's engine package (its distribution's metadata);
    None where the adapter declares no supported releases (the reference: part of physval)
    or the package is not installed as a distribution."""
    if adapter.supported is None or not getattr(adapter, "package", None):
        return None
    try:
        return metadata.version(adapter.package)
    except metadata.PackageNotFoundError:
        return None


def release_problem(adapter: Adapter) -> str | None:
    """version_problem of an adapter already made."""
    if adapter.supported is None:
        return None
    try:
        installed = metadata.version(adapter.package)
    except metadata.PackageNotFoundError:
        return (f"adapter {adapter.name} declares supported releases of {adapter.package}, "
                "which is not installed as a distribution")
    return range_problem(adapter, installed)
