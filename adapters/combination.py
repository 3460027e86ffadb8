"""Pair materials onto an engine's combination rule.

Engines store friction and restitution per body and combine two bodies' values into the
pair's (PyBullet and Pymunk: product; DART: min for friction, product for restitution;
MuJoCo: max for friction; Drake: the harmonic mean 2 a b / (a + b) for friction). A scene states pair values; this module finds per-body values
whose combination reproduces every pair of the scene exactly, or says it cannot.
"""
from __future__ import annotations

import math

import numpy as np
from typing import Callable

from adapters.base import Unsupported
from cases.scene import Body, Material, Scene

RULES: dict[str, Callable[[float, float], float]] = {
    "product": lambda a, b: a * b,
    "min": min,
    "max": max,
    # Drake's CalcContactFrictionFromSurfaceProperties, 0 / 0 taken as 0
    "harmonic": lambda a, b: 2.0 * a * b / (a + b) if a + b > 0.0 else 0.0,
}
# A value that leaves the partner's value unchanged under each rule (the harmonic mean
# has none: only 2 a x / (a + x) -> 2 a as x grows).
NEUTRAL = {"product": 1.0, "min": 1e6, "max": 0.0}


def per_body_values(scene: Scene, value_of: Callable[[Material], float], rule: str,
                    what: str, pair_value: Callable[[Body, Body], float] | None = None) -> dict[str, float]:
    """Per-body values v with rule(v[a], v[b]) == value_of(pair material) for every pair
    that may touch (or == pair_value(a, b), where the value an engine combines depends on
    the bodies too, e.g. a lever arm divided by their radius). Tries, in order: static
    bodies neutral and each dynamic body the value of its pairs; every body the same value
    (sqrt of it for the product rule); for the product rule, the solution of the pairs'
    equations in logs."""
    combine = RULES[rule]
    if pair_value is None:
        def pair_value(a: Body, b: Body) -> float:
            return value_of(scene.material_of(a.name, b.name))
    pairs = [(a.name, b.name, pair_value(a, b)) for a, b in scene.contact_pairs()]

    def fits(v: dict[str, float]) -> bool:
        return all(math.isclose(combine(v[a], v[b]), c, rel_tol=1e-12, abs_tol=1e-15) for a, b, c in pairs)

    candidates = []
    # 1. static bodies neutral, each dynamic body carries its pair value
    if rule in NEUTRAL:
        v = {b.name: NEUTRAL[rule] for b in scene.bodies if b.static}
        for a, b, c in pairs:
            for name in (a, b):
                if name not in v:
                    v[name] = c
        candidates.append(v)
    # 2. one value for everyone
    values = {c for _, _, c in pairs}
    if len(values) == 1:
        (c,) = values
        same = math.sqrt(c) if rule == "product" else c
        candidates.append({b.name: same for b in scene.bodies})
    # 3. the product rule in logs: log v_a + log v_b = log c over every pair, a linear
    # system; its least-squares solution reproduces the pairs when any solution does (e.g.
    # ground at e, two balls at 1: ground-ball pairs e, ball-ball 1). Values kept in (0, 1].
    if rule == "product" and pairs and all(c > 0.0 for _, _, c in pairs):
        names = list(dict.fromkeys(n for a, b, _ in pairs for n in (a, b)))
        index = {n: i for i, n in enumerate(names)}
        A = np.zeros((len(pairs), len(names)))
        for row, (a, b, _) in enumerate(pairs):
            A[row, index[a]] += 1.0
            A[row, index[b]] += 1.0
        x = np.linalg.lstsq(A, np.log([c for _, _, c in pairs]), rcond=None)[0]
        v = {n: float(np.exp(x[i])) for n, i in index.items()}
        if all(0.0 < val <= 1.0 + 1e-12 for val in v.values()):
            candidates.append({n: min(val, 1.0) for n, val in v.items()})
    for v in candidates:
        if all(b.name in v for b in scene.bodies) and fits(v):
            return v
        if rule in NEUTRAL and fits({**{b.name: NEUTRAL[rule] for b in scene.bodies}, **v}):
            return {**{b.name: NEUTRAL[rule] for b in scene.bodies}, **v}
    raise Unsupported(f"the scene's pair {what} values cannot be expressed as per-body values "
                      f"under this engine's {rule} rule")
