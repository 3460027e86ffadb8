"""Figures: matplotlib without a display, a colour and marker per engine, and a PNG written
atomically (an interrupt leaves the former picture or none, never half of one)."""
from __future__ import annotations

import os
import tempfile
from pathlib import Path

MARKERS = ("o", "^", "v", "D", "P", "X", "*", "h")


def pyplot():
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    return plt


def engine_styles(engines) -> dict[str, dict]:
    """A colour and a marker per engine for line plots: one colour per engine family (the
    name before its first '-': pybullet, pybullet-rigid, ...) and one marker per member,
    so a plot of 17 engines does not repeat tab10's ten colours."""
    colour, seen, out = {}, {}, {}
    for e in engines:
        family = e.split("-")[0]
        colour.setdefault(family, f"C{len(colour) % 10}")
        k = seen[family] = seen.get(family, -1) + 1
        out[e] = {"color": colour[family], "marker": MARKERS[k % len(MARKERS)]}
    return out


def save_figure(fig, path: Path) -> None:
    plt = pyplot()
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    fd, tmp = tempfile.mkstemp(dir=path.parent, prefix=f".{path.name}.", suffix=".png")
    os.close(fd)
    try:
        fig.savefig(tmp, dpi=110)
        os.chmod(tmp, 0o644)
        os.replace(tmp, path)
    except BaseException:
        if os.path.exists(tmp):
            os.unlink(tmp)
        raise
    finally:
        plt.close(fig)
