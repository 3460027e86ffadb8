"""Broad phase: which pairs of bodies may touch (note 001, "broad phase sweep").

Sort-and-sweep along one axis: sort the bounding boxes by their lower end, sweep, and keep
an active list of boxes whose interval is still open; only boxes overlapping on the sweep
axis are tested on the other two. Cost O(n log n + k) for k overlapping intervals,
instead of the n^2 / 2 tests of all pairs. Planes are unbounded: each is paired with the
bodies whose box reaches it.
"""
from __future__ import annotations

from reference_impl.geometry import below_plane, bounds


def sweep_axis(boxes) -> int:
    """The axis along which the box centres spread most (fewest overlapping intervals)."""
    best, spread = 0, -1.0
    for axis in range(3):
        centres = [lo[axis] + hi[axis] for lo, hi, _ in boxes]
        s = max(centres) - min(centres) if centres else 0.0
        if s > spread:
            best, spread = axis, s
    return best


def overlap(lo1, hi1, lo2, hi2, margin: float) -> bool:
    return all(lo1[k] <= hi2[k] + margin and lo2[k] <= hi1[k] + margin for k in range(3))


def candidate_pairs(bodies, margin: float, grow=None) -> list[tuple[int, int]]:
    """Index pairs (i < j), sorted, of bodies whose bounding boxes, each grown by
    grow[k] (0 if None), come within `margin`; at least one of them dynamic."""
    boxes, planes = [], []
    for k, body in enumerate(bodies):
        bb = bounds(body)
        if bb is None:
            planes.append(k)
        else:
            g = grow[k] if grow else 0.0
            lo, hi = bb
            if g:
                lo, hi = (lo[0] - g, lo[1] - g, lo[2] - g), (hi[0] + g, hi[1] + g, hi[2] + g)
            boxes.append((lo, hi, k))
    out = []
    axis = sweep_axis(boxes)
    active = []
    for lo, hi, k in sorted(boxes, key=lambda b: b[0][axis]):
        active = [a for a in active if a[1][axis] + margin >= lo[axis]]
        for alo, ahi, j in active:
            if overlap(lo, hi, alo, ahi, margin) and not (bodies[j].static and bodies[k].static):
                out.append((min(j, k), max(j, k)))
        active.append((lo, hi, k))
    for p in planes:
        for lo, hi, k in boxes:
            if not bodies[k].static and below_plane(bodies[p].shape, lo, hi, margin):
                out.append((min(p, k), max(p, k)))
    out.sort()
    return out
