"""Pair materials onto an engine's combination rule.

Engines store friction and restitution per body and combine two bodies' values into the
pair's (PyBullet and Pymunk: product; DART: min for friction, product for restitution;
MuJoCo: max for friction; Drake: the harmonic mean 2 a b / (a + b) for friction; Newton:
the arithmetic mean (a + b) / 2, and for friction in its VBD solver the geometric mean
sqrt(a b)). A scene states pair values; this module finds per-body values
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
    # Newton's shape materials (adapters/newton_engine.py)
    "mean": lambda a, b: 0.5 * (a + b),
    "geometric": lambda a, b: math.sqrt(a * b),
}
# A value that leaves the partner's value unchanged under each rule (the harmonic mean
# has none: only 2 a x / (a + x) -> 2 a as x grows).
NEUTRAL = {"product": 1.0, "min": 1e6, "max": 0.0}
# max and min: the body value that stays within every pair's (the max rule's bodies
# lie at or below their pairs' values, the min rule's at or above).
EXTREME = {"max": min, "min": max}
# Rules linear in a transform t of the per-body values: t(v_a) + t(v_b) = forward(c) for a
# pair value c; (forward, back from t to v, whether a solution t is usable). The product
# in logs (values kept in (0, 1]: engines clamp or reject a restitution above 1); the
# harmonic mean in reciprocals, 1/v_a + 1/v_b = 2/c (values finite and positive).
LINEAR: dict[str, tuple[Callable[[float], float], Callable[[float], float], Callable[[float], bool]]] = {
    "product": (math.log, lambda t: min(math.exp(t), 1.0), lambda t: t <= 1e-12),
    "harmonic": (lambda c: 2.0 / c, lambda t: 1.0 / t, lambda t: t > 0.0),
    # the arithmetic mean in the values themselves, v_a + v_b = 2 c (values >= 0); the
    # geometric mean in logs, log v_a + log v_b = 2 log c (values > 0, not capped: a
    # friction coefficient may exceed 1)
    "mean": (lambda c: 2.0 * c, lambda t: max(t, 0.0), lambda t: t >= -1e-12),
    "geometric": (lambda c: 2.0 * math.log(c), math.exp, lambda t: True),
}


def per_body_values(scene: Scene, value_of: Callable[[Material], float], rule: str,
                    what: str, pair_value: Callable[[Body, Body], float] | None = None) -> dict[str, float]:
    """Per-body values v with rule(v[a], v[b]) == value_of(pair material) for every pair
    that may touch (or == pair_value(a, b), where the value an engine combines depends on
    the bodies too, e.g. a lever arm divided by their radius). Tries, in order: static
    bodies neutral and each dynamic body the value of its pairs; every body the same value
    (sqrt of it for the product rule); for the max and min rules, each body at the extreme
    value its pairs allow (EXTREME); for the product and harmonic rules, the solution of the
    pairs' equations in logs or reciprocals (LINEAR). Every candidate is checked against
    every pair before it is used."""
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
        same = math.sqrt(c) if rule == "product" else c  # harmonic: 2 c c / (c + c) = c
        candidates.append({b.name: same for b in scene.bodies})
    # 3. max and min: each body at the least (max rule) or the largest (min rule) value of
    # its pairs. Under max every body lies at or below each of its pairs' values, and
    # raising it to the least of them keeps every pair's max: so if any per-body values
    # reproduce the pairs, these do (min: the same, mirrored).
    if rule in EXTREME:
        v = {}
        for a, b, c in pairs:
            for name in (a, b):
                v[name] = EXTREME[rule](v.get(name, c), c)
        candidates.append(v)
    # 4. rules linear in a transform of the values (LINEAR): the product rule in logs,
    # log v_a + log v_b = log c, and the harmonic mean in reciprocals, 1/v_a + 1/v_b = 2/c,
    # over every pair: a linear system whose least-squares solution reproduces the pairs
    # when any solution does (e.g. ground at e, two balls at 1: ground-ball pairs e,
    # ball-ball 1); kept only if its values lie in the rule's range.
    if rule in LINEAR and pairs and (rule == "mean" or all(c > 0.0 for _, _, c in pairs)):
        forward, back, usable = LINEAR[rule]
        names = list(dict.fromkeys(n for a, b, _ in pairs for n in (a, b)))
        index = {n: i for i, n in enumerate(names)}
        A = np.zeros((len(pairs), len(names)))
        for row, (a, b, _) in enumerate(pairs):
            A[row, index[a]] += 1.0
            A[row, index[b]] += 1.0
        x = np.linalg.lstsq(A, np.array([forward(c) for _, _, c in pairs]), rcond=None)[0]
        if all(usable(float(xi)) for xi in x):
            candidates.append({n: back(float(x[i])) for n, i in index.items()})
    for v in candidates:
        if all(b.name in v for b in scene.bodies) and fits(v):
            return v
        if rule in NEUTRAL and fits({**{b.name: NEUTRAL[rule] for b in scene.bodies}, **v}):
            return {**{b.name: NEUTRAL[rule] for b in scene.bodies}, **v}
    raise Unsupported(f"the scene's pair {what} values cannot be expressed as per-body values "
                      f"under this engine's {rule} rule")
