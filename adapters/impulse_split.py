"""Contact impulses from what the bodies did, for engines that do not report them exactly
(adapters/box2d_engine.py and adapters/box3d_engine.py, whose module notes derive it): every
velocity change of a dynamic body in a step other than gravity is a contact impulse, so
body i took J_i = m_i (v_i' - v_i) - m_i g dt from its contacts, and the pairs in contact
share it. Where the contact graph (all static bodies one node) is a forest the split is
unique; what a cycle leaves is split by least squares."""
from __future__ import annotations

import numpy as np

# Box2D's (and Box3D's) contacts include speculative ones, up to 2 cm apart. Where such a pair
# would close a cycle of the contact graph (a millimetre box's ground contact, the box resting on
# another), a gap after the step above this marks it as having taken no impulse: resting
# contacts sit at gaps of -1e-5..0 m (soft contact) and float32 places bodies at 1 km to
# 6e-5 m; a millimetre box one box up is 1e-3 m from the ground.
ACTING_GAP = 1e-4  # m


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


def split_impulses(J: dict, pairs: list) -> tuple[dict, bool]:
    """Impulses P_ab (on a; -P_ab on b) of the pairs with sum_pairs(i) +-P = J_i for every
    dynamic body i (J: body -> vector, 2 or 3 components). Leaves of the contact graph first: a body with
    one pair left gives that pair its remaining impulse. What a cycle leaves is split by
    least squares (least norm); the flag says whether that happened."""
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
    names = sorted({n for pair in left for n in pair if n in J})
    index = {n: i for i, n in enumerate(names)}
    A = np.zeros((len(names), len(left)))
    for k, (a, b) in enumerate(left):
        if a in index:
            A[index[a], k] = 1.0
        if b in index:
            A[index[b], k] = -1.0
    solution = np.linalg.lstsq(A, np.array([J[n] for n in names]), rcond=None)[0]
    P.update({pair: tuple(solution[k]) for k, pair in enumerate(left)})
    return P, True
