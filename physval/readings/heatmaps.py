"""The run report's heat maps: the worst error in tolerances per family and engine (the
summary's), and every check of one family per engine (each family's page)."""
from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pandas as pd

from physval.readings.checks import STATUS_MARK
from physval.report import pyplot, save_figure


def plot_summary(df: pd.DataFrame, engines: list[str], path: Path, title: str) -> None:
    """Heat map of the worst error/tolerance per family and engine (log colour scale)."""
    plt = pyplot()
    fams = sorted(df[df.engine.isin(engines)].case.unique())
    worst = np.full((len(fams), len(engines)), np.nan)
    most = df.dropna(subset=["over_tol"]).groupby(["case", "engine"]).over_tol.max()  # one pass over df
    for i, f in enumerate(fams):
        for j, e in enumerate(engines):
            if (f, e) in most.index:
                worst[i, j] = max(most[(f, e)], 1e-6)
    fig, ax = plt.subplots(figsize=(1.3 * len(engines) + 3.4, 0.42 * len(fams) + 1.8), layout="constrained")
    im = ax.imshow(np.log10(np.clip(worst, 1e-3, 1e3)), cmap="RdYlGn_r", vmin=-3, vmax=3, aspect="auto")
    ax.set_xticks(range(len(engines)), engines, rotation=30, ha="right")
    ax.set_yticks(range(len(fams)), fams, fontsize=8)
    for i in range(len(fams)):
        for j in range(len(engines)):
            text = "n/a" if np.isnan(worst[i, j]) else f"{worst[i, j]:.2g}"
            ax.text(j, i, text, ha="center", va="center", fontsize=7)
    fig.colorbar(im, ax=ax, label="log10(worst error / tolerance)")
    ax.set_title(f"{title}: worst error in tolerances (<1: within tolerance)", fontsize=10)
    save_figure(fig, path)


LABEL_EVERY_CELL_UP_TO = 300  # cells; a larger grid labels only the cells that are neither pass nor n/a,
LABELS_AT_MOST = 200          # the worst this many of them (each label costs ~2 ms to lay out and draw)


def plot_family(df: pd.DataFrame, family: str, path: Path) -> None:
    """One row per check (variant: metric), one column per engine, coloured by the error in
    tolerances, each cell labelled with that number and the status. On a grid of more
    than LABEL_EVERY_CELL_UP_TO cells the passes and n/a cells go unlabelled (colour and
    blank say it; the family's table has the numbers), and at most LABELS_AT_MOST of them,
    the worst: drawing the text is most of the plot's time (3 of 5 s for 110 checks on 24
    engines, measured)."""
    plt = pyplot()
    sub = df[df.case == family]
    engines = list(dict.fromkeys(sub.engine))
    checks = list(dict.fromkeys(zip(sub.variant, sub.metric)))
    grid = np.full((len(checks), len(engines)), np.nan)
    label = [[""] * len(engines) for _ in checks]
    index = {c: i for i, c in enumerate(checks)}
    for r in sub.itertuples():
        i, j = index[(r.variant, r.metric)], engines.index(r.engine)
        if math.isfinite(r.over_tol):
            grid[i, j] = max(r.over_tol, 1e-6)
        elif r.status in ("fail", "deviation"):
            grid[i, j] = 1e3
        mark = STATUS_MARK[r.status]
        label[i][j] = f"{r.over_tol:.2g} {mark}" if math.isfinite(r.over_tol) else mark
    fig, ax = plt.subplots(figsize=(1.25 * len(engines) + 4.5, 0.24 * len(checks) + 1.6), layout="constrained")
    ax.imshow(np.log10(np.clip(grid, 1e-3, 1e3)), cmap="RdYlGn_r", vmin=-3, vmax=3, aspect="auto",
              interpolation="nearest")
    ax.set_xticks(range(len(engines)), engines, rotation=30, ha="right", fontsize=8)
    ax.set_yticks(range(len(checks)), [f"[{v}] {m}" for v, m in checks], fontsize=7)
    every = len(checks) * len(engines) <= LABEL_EVERY_CELL_UP_TO
    cells = [(index[(r.variant, r.metric)], engines.index(r.engine)) for r in sub.itertuples()
             if every or r.status not in ("pass", "unsupported")]
    capped = len(cells) > LABELS_AT_MOST
    if capped:  # the worst first, n/a cells last
        cells = sorted(cells, key=lambda c: -np.nan_to_num(grid[c], nan=-np.inf))[:LABELS_AT_MOST]
    for i, j in cells:
        ax.text(j, i, label[i][j], ha="center", va="center", fontsize=6)
    shown = ")" if every else "; pass and n/a cells unlabelled)"
    if capped:
        shown = f"; only the {LABELS_AT_MOST} worst cells labelled)"
    ax.set_title(f"{family}: error / tolerance per check (green < 1 <= red; pass, dev = known deviation, FAIL"
                 + shown, fontsize=9)
    save_figure(fig, path)
