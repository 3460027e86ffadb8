"""Contact impulses from what the bodies did, for engines that do not report them exactly
(adapters/box2d_engine.py and adapters/box3d_engine.py, whose module notes derive it): every
velocity change of a dynamic body in a step other than gravity is a contact impulse, so
body i took J_i = m_i (v_i' - v_i) - m_i g dt from its contacts, and the pairs in contact
share it. Each pair's impulse is a normal part along the pair's contact normal and, on a
frictional pair, a tangential part (note 001, "Multiple Contacts": P = n lambda + t tau).
Where the contact graph (all static bodies one node) is a forest the split is unique and
the normals only read it; where a cycle remains (a ball in a V-groove of two planes, a box
resting on the ground against another) the normals decide it: with frictionless pairs the
normal impulses solve sum_pairs(i) +-n lambda = J_i, exactly when the normals are
independent (the groove's two faces each carry m g / (2 cos alpha)). What momentum leaves
open (friction on a cycle: a wedged ball may be squeezed, its faces' friction carrying the
difference; parallel normals) has no unique answer from the bodies' motion: the split
with the least friction, then the least normal impulse, is taken and flagged."""
from __future__ import annotations

import numpy as np

# Box2D's (and Box3D's) contacts include speculative ones, up to 2 cm apart. Where such a pair
# would close a cycle of the contact graph (a millimetre box's ground contact, the box resting on
# another), a gap after the step above this marks it as having taken no impulse: resting
# contacts sit at gaps of -1e-5..0 m (soft contact) and float32 places bodies at 1 km to
# 6e-5 m; a millimetre box one box up is 1e-3 m from the ground.
ACTING_GAP = 1e-4  # m
# The knob record's word for a step whose normal impulses momentum left open (split_impulses)
OPEN_SPLIT = ("least friction, then least normal impulse: momentum leaves a frictional cycle's "
              "normal impulses open")


def acting_pairs(gaps: dict, dynamic) -> list[tuple[str, str]]:
    """The touching pairs that take part in the impulse split: every pair of the contact
    graph's spanning forest grown from the smallest gaps (all static bodies one node), and
    each pair that would close a cycle unless it is more than ACTING_GAP apart after the
    step (a speculative contact that took nothing)."""
    root: dict[str, str] = {}

    def find(x):
        x = x if x in dynamic else "<static>"
        while root.setdefault(x, x) != x:
            root[x] = root[root[x]]
            x = root[x]
        return x

    acting = []
    for key in sorted(gaps, key=gaps.get):
        ra, rb = find(key[0]), find(key[1])
        if ra != rb:
            root[ra] = rb
            acting.append(key)
        elif gaps[key] <= ACTING_GAP:
            acting.append(key)
    return acting


def split_impulses(J: dict, pairs: list, normals: dict, frictional: dict) -> tuple[dict, bool]:
    """Impulses P_ab (on a; -P_ab on b) of the pairs with sum_pairs(i) +-P = J_i for every
    dynamic body i (J: body -> vector, 2 or 3 components); `normals[pair]` the unit contact
    normal from b into a, `frictional[pair]` whether the pair has friction (else P_ab lies
    along its normal). Leaves of the contact graph first: a body with one pair left gives
    that pair its remaining impulse. What cycles leave is solved with the normals
    (`_cycle_impulses`); the flag says whether momentum left their normal impulses open."""
    J = {name: list(j) for name, j in J.items()}
    pairs_of: dict[str, set] = {n: set() for n in J}
    for pair in pairs:
        for n in pair:
            if n in J:
                pairs_of[n].add(pair)
    P: dict[tuple[str, str], tuple] = {}
    leaves = [n for n, ps in pairs_of.items() if len(ps) == 1]
    while leaves:
        n = leaves.pop()
        if len(pairs_of[n]) != 1:
            continue
        (pair,) = pairs_of[n]
        sign = 1.0 if pair[0] == n else -1.0  # P_ab acts on a with +, on b with -
        p = tuple(sign * c for c in J[n])
        P[pair] = p
        for m, s in ((pair[0], 1.0), (pair[1], -1.0)):
            if m in J:
                for i, c in enumerate(p):
                    J[m][i] -= s * c
                pairs_of[m].discard(pair)
                if len(pairs_of[m]) == 1:
                    leaves.append(m)
    left = [pair for pair in pairs if pair not in P]
    if not left:
        return P, False
    cycle, open_ = _cycle_impulses(J, left, normals, frictional)
    P.update(cycle)
    return P, open_


def _cross(a, b) -> np.ndarray:
    """a x b of two 3-vectors: np.cross's products and differences, without its cost of
    tens of microseconds a call (this runs for every frictional pair of every step)."""
    return np.array([a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]])


def _tangents(n: np.ndarray) -> np.ndarray:
    """(d, d-1) orthonormal basis of the plane normal to the unit vector n."""
    if len(n) == 2:
        return np.array([[-n[1]], [n[0]]])
    a = np.eye(3)[int(np.argmin(np.abs(n)))]
    t1 = _cross(n, a)
    t1 /= np.linalg.norm(t1)
    return np.stack([t1, _cross(n, t1)], axis=1)


def _cycle_impulses(J: dict, pairs: list, normals: dict, frictional: dict) -> tuple[dict, bool]:
    """The pairs' impulses P = n lambda + T tau (tau only on frictional pairs) that balance
    the bodies' remaining J_i in the least-squares sense: unique where A x = J determines
    x; else, of all solutions, the least |tau|, then the least |lambda| (flag True when
    lambda was left open)."""
    names = sorted({n for pair in pairs for n in pair if n in J})
    index = {n: i for i, n in enumerate(names)}
    d = len(next(iter(J.values())))
    columns, blocks = [], []  # per unknown: its column of A; per pair: (columns' slice, kinds)
    lam, tau = [], []
    for a, b in pairs:
        n = np.asarray(normals[(a, b)], float)
        dirs = [n] + (list(_tangents(n).T) if frictional[(a, b)] else [])
        first = len(columns)
        for k, direction in enumerate(dirs):
            col = np.zeros(d * len(names))
            if a in index:
                col[d * index[a]:d * index[a] + d] += direction
            if b in index:
                col[d * index[b]:d * index[b] + d] -= direction
            (lam if k == 0 else tau).append(len(columns))
            columns.append(col)
        blocks.append((first, dirs))
    A = np.array(columns).T
    rhs = np.concatenate([np.asarray(J[n], float) for n in names])
    x = np.linalg.lstsq(A, rhs, rcond=None)[0]
    null = _null_space(A)
    # momentum leaves the normal impulses open when a solution of A x = 0 moves a lambda
    open_ = bool(null.shape[1]) and float(np.linalg.norm(null[lam])) > 1e-9
    if null.shape[1]:
        rest = null
        if tau:  # the least friction among the solutions ...
            x = x + null @ np.linalg.lstsq(null[tau], -x[tau], rcond=None)[0]
            rest = null @ _null_space(null[tau])
        if rest.shape[1]:  # ... then the least normal impulse among those
            x = x + rest @ np.linalg.lstsq(rest[lam], -x[lam], rcond=None)[0]
    out = {}
    for pair, (first, dirs) in zip(pairs, blocks):
        out[pair] = tuple(sum(x[first + k] * direction for k, direction in enumerate(dirs)))
    return out, open_


def _null_space(A: np.ndarray) -> np.ndarray:
    """Orthonormal basis (columns) of A's null space (relative rank tolerance 1e-10)."""
    if A.shape[1] == 0:
        return np.zeros((0, 0))
    _, s, vt = np.linalg.svd(A)
    rank = int(np.sum(s > 1e-10 * (s[0] if s.size else 0.0)))
    return vt[rank:].T
