"""Broad phase: which pairs of bodies may touch (note 001, "broad phase sweep").

Sort-and-sweep along one axis: sort the bounding boxes by their lower end, sweep, and keep
an active list of boxes whose interval is still open; only boxes overlapping on the sweep
axis are tested on the other two. Cost O(n log n + k) for k overlapping intervals,
instead of the n^2 / 2 tests of all pairs. Planes are unbounded: each is paired with the
bodies whose box reaches it.
"""
from __future__ import annotations

import numpy as np

from reference_impl.compiled import njit
from reference_impl.geometry import PLANE, box_bounds, reaches_plane


@njit
def sweep_axis(lo, hi, boxes) -> int:
    """The axis along which the centres of the boxes (rows `boxes` of lo, hi) spread most
    (fewest overlapping intervals)."""
    best, spread = 0, -1.0
    for axis in range(3):
        s = 0.0
        if len(boxes):
            top = bottom = lo[boxes[0], axis] + hi[boxes[0], axis]
            for k in boxes:
                centre = lo[k, axis] + hi[k, axis]
                top, bottom = max(top, centre), min(bottom, centre)
            s = top - bottom
        if s > spread:
            best, spread = axis, s
    return best


@njit
def overlap(lo1, hi1, lo2, hi2, margin) -> bool:
    for k in range(3):
        if not (lo1[k] <= hi2[k] + margin and lo2[k] <= hi1[k] + margin):
            return False
    return True


@njit
def pairs(bodies, margin, grow):
    """(i, j) index pairs (i < j), sorted, of bodies whose bounding boxes, each grown by
    grow[k], come within `margin`; at least one of them dynamic; as an (P, 2) array."""
    N = len(bodies.x)
    lo, hi = np.empty((N, 3)), np.empty((N, 3))
    boxes, planes, n_boxes, n_planes = np.empty(N, np.int64), np.empty(N, np.int64), 0, 0
    for k in range(N):
        if bodies.shape[k] == PLANE:
            planes[n_planes] = k
            n_planes += 1
            continue
        low, high = box_bounds(bodies, k)
        g = grow[k]
        for c in range(3):
            lo[k, c], hi[k, c] = (low[c] - g, high[c] + g) if g != 0.0 else (low[c], high[c])
        boxes[n_boxes] = k
        n_boxes += 1
    boxes, planes, static = boxes[:n_boxes], planes[:n_planes], bodies.static
    found, n_found = np.empty(4 * N + 16, np.int64), 0  # i N + j of each pair found
    axis = sweep_axis(lo, hi, boxes)
    active, n_active = np.empty(n_boxes, np.int64), 0  # open intervals, in the order they opened
    for k in boxes[_order(lo[boxes, axis])]:
        kept = 0
        for t in range(n_active):  # close those that end before this one starts
            if hi[active[t], axis] + margin >= lo[k, axis]:
                active[kept] = active[t]
                kept += 1
        n_active = kept
        for t in range(n_active):
            j = active[t]
            if overlap(lo[k], hi[k], lo[j], hi[j], margin) and not (static[j] and static[k]):
                found, n_found = _append(found, n_found, min(j, k) * N + max(j, k))
        active[n_active] = k
        n_active += 1
    for p in planes:
        for k in boxes:
            if not static[k] and reaches_plane(bodies.normal[p], bodies.offset[p], lo[k], hi[k], margin):
                found, n_found = _append(found, n_found, min(p, k) * N + max(p, k))
    found = found[:n_found]
    out = np.empty((n_found, 2), np.int64)
    for row, f in enumerate(_order(found)):
        out[row, 0], out[row, 1] = found[f] // N, found[f] % N
    return out


@njit
def _append(items, n, item):
    """items[:n] with item after them, in items or, when full, in a copy twice the size."""
    if n == len(items):
        grown = np.empty(2 * n, items.dtype)
        for k in range(n):
            grown[k] = items[k]
        items = grown
    items[n] = item
    return items, n + 1


@njit
def _order(key):
    """The indices of key in increasing order of key, equal keys in their order
    (insertion sort: simple, and the broad phase sorts a few hundred bodies at most)."""
    out = np.arange(len(key))
    for k in range(1, len(out)):
        item, t = out[k], k
        while t > 0 and key[out[t - 1]] > key[item]:
            out[t] = out[t - 1]
            t -= 1
        out[t] = item
    return out


def candidate_pairs(bodies, margin: float, grow=None) -> list[tuple[int, int]]:
    """Index pairs (i < j), sorted, of bodies (a list of rigid_body.RigidBody) whose
    bounding boxes, each grown by grow[k] (0 if None), come within `margin`; at least one
    of them dynamic."""
    from reference_impl.rigid_body import new_bodies, stack
    grow = np.zeros(len(bodies)) if grow is None else np.asarray(grow, dtype=float)
    return [(int(i), int(j)) for i, j in pairs(new_bodies(stack(bodies)), float(margin), grow)]
