"""Each adapter's undoing of its engine's combination rule, checked in the engine itself,
pair by pair: a block of pair_friction slides in the two-block scene (its pair's mu
reached through the per-body values the adapter solved for) as it slides alone on the
ground with that mu as the only material (a scene every engine maps the same way, and
which slide_to_stop judges against the closed form). A pair table read wrongly (the
default material for the pair's, a per-body value that combines to another mu) moves the
block's stop by v0^2 / (2 g) (1/mu' - 1/mu), 68 mm or more here, and its path by
(mu' - mu) g t^2 / 2 while it slides, 22 mm or more by 0.15 s (checked by breaking the
PyBullet adapter's values: the pair table ignored, or a per-body value that squares); a
right one only by the solver's coupling of a second body: 27 um at most while the block
slides (the paths are compared up to its stop: after it PyBullet's friction anchors
spring a stopped box back by up to 2 mm, a recorded deviation, which another body on the
ground changes).

Each engine skips cleanly when its package is missing."""
from __future__ import annotations

import numpy as np
import pytest

from adapters import registry
from adapters.base import Settings
from cases import pair_friction as pf
from cases.scene import Scene

STEPS = 300   # 0.3 s at dt = 1e-3: the mu = 0.5 block has stopped (0.20 s), the other slides
# Engines that map pair materials onto per-body values (combination rules), and two that
# take pairs natively (MuJoCo's <pair>, Pymunk's pre_solve) for the same contract.
ENGINES3D = ("pybullet", "pybullet-rigid", "dart", "rapier", "drake-sap", "drake-tamsi", "drake", "mujoco")
ENGINES2D = ("box2d", "pymunk", "rapier", "drake-sap")


def _path(engine: str, scene: Scene, body: str) -> np.ndarray:
    sim = registry.get(engine).build(scene, Settings(dt=1e-3))
    try:
        xs = []
        for _ in range(STEPS):
            sim.step()
            xs.append(float(sim.states()[body][0]))
        return np.array(xs)
    finally:
        sim.close()


@pytest.mark.parametrize("engine,p", [(e, pf.GRID[0]) for e in ENGINES3D] + [(e, pf.GRID[1]) for e in ENGINES2D],
                         ids=lambda x: x if isinstance(x, str) else pf.variant_id(x))
def test_each_block_slides_as_it_would_with_its_pairs_mu_alone(engine, p):
    if not registry.available(engine):
        pytest.skip(f"{engine} not installed")
    full = pf.scene(p)
    checks = {c.metric: c for c in pf.expect(p, 1e-3)}
    for block in pf.BLOCKS:
        alone = Scene(bodies=(full.body("ground"), full.body(block)), gravity=full.gravity,
                      material=full.material_of("ground", block), dimension=full.dimension)
        sliding = int(checks[f"stop_time_{block}"].expected / 1e-3)  # steps before its stop
        diff = np.abs(_path(engine, full, block) - _path(engine, alone, block))[:sliding].max()
        assert diff < 2e-3, f"{engine}: block {block} off by {diff:.3g} m from its pair's mu alone"
