"""Analytic cases: engine-neutral scenes with closed-form answers and tolerances.

`cases.scene` is the shared vocabulary; each other module defines one case family
(`FAMILY`). See README.md, "Adding a case".
"""
