"""Imported once by the fork server that local workers start from (forkserver start
method), so each worker begins with the harness and the built-in families loaded."""
from cases.registry import builtin_families
from physval.core import jobs  # noqa: F401

builtin_families()
