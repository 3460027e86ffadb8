"""Warp (NVIDIA's kernel compiler) as the engines built on it use it.

Warp compiles each kernel module on first use (tens of seconds a solver on a 2-core CPU)
and keeps the binaries in a kernel cache. physval puts that cache in a folder of its own
under the user's cache (Warp's own `WARP_CACHE_PATH`, which the harness points into its
cache folder, names another), so every worker process and
every run shares one compiled copy; compiles no backward (gradient) passes, which no
engine here uses and which cost about half the compile time; and silences Warp's
per-module load messages.
"""
from __future__ import annotations

import os
from pathlib import Path


def warp_cache_dir() -> Path:
    """The kernel cache folder: $WARP_CACHE_PATH (Warp's own variable, which physval's
    harness sets to its cache folder's warp/ unless the user set it), else physval/warp
    under the user's cache ($XDG_CACHE_HOME, else ~/.cache)."""
    named = os.environ.get("WARP_CACHE_PATH")
    if named:
        return Path(named)
    base = os.environ.get("XDG_CACHE_HOME") or Path.home() / ".cache"
    return Path(base) / "physval" / "warp"


def init_warp():
    """Warp, configured and initialised; call before a Warp-based engine builds a model
    (the settings are read when Warp initialises and when it compiles). Returns the module."""
    import warp as wp
    if wp.config.kernel_cache_dir is None:  # Warp's default: not configured yet in this process
        wp.config.kernel_cache_dir = str(warp_cache_dir())
    # every call: another engine may have started Warp with its defaults in this worker first
    # (ovphysx does, for its array views), after which a Newton job logged every module it loaded
    wp.config.enable_backward = False
    wp.config.log_level = 30  # warnings and errors only (default 20: info, a line per module)
    wp.init()  # once per process; later calls return at once
    return wp
