"""The case format: a family is a scene builder, a parameter grid, observables, closed-form
expectations and tolerances (each with a one-line reason). One file per family under
`cases/`, exporting `FAMILY`; users add families the same way from `--cases-dir DIR`.
"""
from __future__ import annotations

import json
import math
from dataclasses import dataclass
from typing import Callable

from cases.scene import Scene
from cases.trajectory import Trajectory


class CaseError(ValueError):
    """A case family that cannot be used; the message names the family and the field."""


@dataclass(frozen=True)
class Check:
    """One verdict: `metric` measured against a closed-form `expected` value.

    `kind` says which error the tolerance bounds: "abs" (|measured - expected|, in `unit`)
    or "rel" (that divided by |expected|). `why` is the one-line reason for its size."""
    metric: str
    unit: str
    expected: float
    tolerance: float
    kind: str
    why: str

    def __post_init__(self):
        if self.kind not in ("abs", "rel"):
            raise CaseError(f"check {self.metric!r}: kind = {self.kind!r}: must be 'abs' or 'rel'")
        if not (math.isfinite(self.tolerance) and self.tolerance >= 0):
            raise CaseError(f"check {self.metric!r}: tolerance = {self.tolerance!r}: must be finite and >= 0")
        if not self.why.strip():
            raise CaseError(f"check {self.metric!r}: why is empty: every tolerance needs its reason")


@dataclass(frozen=True)
class Variant:
    family: str
    id: str
    params: dict

    @property
    def test_id(self) -> str:
        return f"{self.family}[{self.id}]"

    @property
    def params_json(self) -> str:
        return json.dumps(self.params, sort_keys=True)


def friction_label(p: dict) -> str:
    """'mu=0.5' when mu_s = mu_k, else 'mu_s=0.5,mu_k=0.3': for variant ids."""
    return f"mu={p['mu_s']}" if p["mu_s"] == p["mu_k"] else f"mu_s={p['mu_s']},mu_k={p['mu_k']}"


def plane_label(p: dict) -> str:
    """',2D' for a 2D variant (params 'dim' = 2), else '': for variant ids."""
    return ",2D" if p.get("dim", 3) == 2 else ""


def _default_id(params: dict) -> str:
    return ",".join(f"{k}={v}" for k, v in params.items())


@dataclass(frozen=True)
class CaseFamily:
    name: str
    summary: str                                        # one sentence for `physval list`
    source: str                                         # where the closed form comes from
    grid: tuple[dict, ...]                              # one params dict per variant
    scene: Callable[[dict], Scene]                      # params -> Scene
    duration: Callable[[dict], float]                   # params -> simulated seconds
    observe: Callable[[Trajectory, dict], dict]         # trajectory, params -> {metric: value}
    expect: Callable[[dict, float], list[Check]]        # params, dt -> checks
    dt: float | Callable[[dict], float] = 1e-3          # default time step, s, or params -> one per variant
    needs: frozenset[str] | Callable[[dict], frozenset[str]] = frozenset()  # e.g. {"contact_forces"}, or per variant
    sweep_variants: tuple[str, ...] = ()                # variant ids `physval sweep` varies dt on (default: the first)
    variant_id: Callable[[dict], str] = _default_id     # params -> readable id
    cross_engine: bool = False                          # the report and tests also compare engines with each other

    def dt_for(self, params: dict) -> float:
        """A variant's default time step (e.g. fine enough to sample a 1 ms compliant contact)."""
        return float(self.dt(params) if callable(self.dt) else self.dt)

    def needs_of(self, params: dict) -> frozenset[str]:
        """Capabilities beyond the scene's that a variant needs (e.g. contact forces)."""
        return frozenset(self.needs(params) if callable(self.needs) else self.needs)

    @property
    def variants(self) -> tuple[Variant, ...]:
        return tuple(Variant(self.name, self.variant_id(p), dict(p)) for p in self.grid)

    def validate(self) -> None:
        """Raise CaseError unless every variant builds a valid scene and its checks."""
        from cases.scene import SceneError
        if not self.name.isidentifier():
            raise CaseError(f"family name {self.name!r}: must be an identifier (letters, digits, _)")
        if not self.grid:
            raise CaseError(f"{self.name}: grid is empty: a family needs at least one variant")
        ids = set()
        for v in self.variants:
            where = f"{self.name}[{v.id}]"
            if v.id in ids:
                raise CaseError(f"{where}: variant id repeats: make variant_id distinguish the grid")
            ids.add(v.id)
            try:
                json.dumps(v.params)
            except TypeError as exc:
                raise CaseError(f"{where}: params must be JSON-serialisable ({exc})") from None
            try:
                scene = self.scene(v.params)
            except SceneError as exc:
                raise CaseError(f"{where}: {exc}") from None
            if not isinstance(scene, Scene):
                raise CaseError(f"{where}: scene() returned {type(scene).__name__}, not a Scene")
            dt = self.dt_for(v.params)
            if not (math.isfinite(dt) and dt > 0):
                raise CaseError(f"{where}: dt = {dt!r}: must be > 0")
            T = self.duration(v.params)
            if not (math.isfinite(T) and T > 0):
                raise CaseError(f"{where}: duration = {T!r}: must be > 0 s")
            checks = self.expect(v.params, dt)
            if not checks:
                raise CaseError(f"{where}: expect() returned no checks")
            metrics = [c.metric for c in checks]
            if len(set(metrics)) != len(metrics):
                raise CaseError(f"{where}: expect() names a metric twice: {metrics}")
        unknown = set(self.sweep_variants) - ids
        if unknown:
            raise CaseError(f"{self.name}: sweep_variants names no variant: {sorted(unknown)}")
