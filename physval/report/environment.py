"""The machine and the libraries a report was made with, and each engine's version."""
from __future__ import annotations

import datetime as _dt
import os
import platform
import sys

import numpy as np
import pandas as pd


def environment(engine_versions: dict[str, str] | None = None) -> pd.DataFrame:
    env = {
        "date (UTC)": _dt.datetime.now(_dt.timezone.utc).strftime("%Y-%m-%d %H:%M"),
        "python": sys.version.split()[0],
        "numpy": np.__version__,
        "pandas": pd.__version__,
        "platform": platform.platform(),
        "machine": f"{platform.machine()}, {os.cpu_count()} cores",
    }
    for eng, ver in sorted((engine_versions or {}).items()):
        env[eng] = ver or "not run"
    return pd.DataFrame(list(env.items()), columns=["what", "value"])
