"""Analytic cases: engine-neutral scenes with closed-form answers and tolerances.

A module that defines `FAMILY` is a case family (cases.registry finds every one, in
subpackages too); one that does not is a library: `scene` (the vocabulary), `family`,
`trajectory`, `observables`, `overlap`, `registry`, and `robustness/__init__.py` (what the
robustness families of that package share). See README.md, "Adding a case".
"""
