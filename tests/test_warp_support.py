"""adapters/warp_support.py: Warp is configured for physval's engines even where another engine
started it first in the same worker process (ovphysx starts Warp with its defaults for its array
views; a Newton job after it then printed a line for every kernel module it loaded)."""
from __future__ import annotations

import pytest

from adapters.warp_support import init_warp


def test_warp_started_by_another_engine_is_still_quiet_and_compiles_no_backward_passes(monkeypatch, tmp_path):
    wp = pytest.importorskip("warp")
    monkeypatch.setattr(wp.config, "kernel_cache_dir", str(tmp_path))  # as Warp's own start sets it
    monkeypatch.setattr(wp.config, "log_level", 20)
    monkeypatch.setattr(wp.config, "enable_backward", True)
    monkeypatch.setattr(wp, "init", lambda: None)  # started already: the test's process keeps its own Warp
    assert init_warp() is wp
    assert wp.config.log_level == 30 and wp.config.enable_backward is False
    assert wp.config.kernel_cache_dir == str(tmp_path)  # a cache already chosen is kept
