"""physval: the harness that drives cases through adapters into verdicts and reports.

Data flows one way: case -> scene -> adapter -> trajectory and contact forces ->
observables -> verdict rows -> CSV, markdown, plots.
"""
__version__ = "0.1.0"
