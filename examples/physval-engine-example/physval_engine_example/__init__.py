"""An example physval engine plug-in: MuJoCo with a softer contact, as an engine of its own.

physval's built-in `mujoco` adapter maps a coefficient of restitution e onto a contact
spring-damper that lasts about n = 16 time steps (adapters/mujoco_engine.py: its
`CONTACT_STEPS`, the adapter's accuracy knob). This plug-in is the same adapter at
n = 32: the contact's natural frequency is halved (stiffness k = w^2 quartered), so a
contact lasts twice as long and bodies press about twice as deep (peak penetration
~ v n dt / pi), while the mapping of e onto the damping ratio stays exact for a lone
contact without gravity. Nothing else changes: same engine, same MJCF, same knobs
recorded (the knob `restitution_map.contact_steps_n` reads 32).

It is an example of how a plug-in is written, not a recommended setting. Its measured
shortfalls are in `xfails/mujoco-soft.txt` beside this file (with measured bands written
by `physval known mujoco-soft --write`), which `Adapter.deviations_file()` finds by
default: a plug-in ships its known deviations with itself.
"""
from __future__ import annotations

from adapters.mujoco_engine import MuJoCoAdapter

CONTACT_STEPS = 32  # the contact lasts about 32 steps (the built-in adapter: 16)


class SoftMuJoCo(MuJoCoAdapter):
    """MuJoCo with every contact lasting about CONTACT_STEPS steps: the engine `mujoco-soft`."""

    name = "mujoco-soft"  # must equal the entry point's name

    def __init__(self):
        super().__init__(contact_steps=CONTACT_STEPS)
