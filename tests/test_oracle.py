"""The reference's contact problems against Pinocchio's solvers (physval/readings/oracle.py).

The capture is checked without Pinocchio (the reference's own solution solves the problem it
read, exactly); the agreement with Pinocchio's ADMM skips cleanly without the `oracle` extra.
Agreement is in what is unique: each body's velocity change and total impulse (a box's four
corners share its weight in many ways), within oracle.tolerance (1e-6 of the problem's velocity
scale: Lemke's own acceptance). A planted wrong reference (mu doubled, a normal flipped) must
part from it.
"""
from __future__ import annotations

import numpy as np
import pytest

from physval.readings import oracle

# The scenes whose problems the tests read (a subset of oracle.SCENES, for time): the box at
# rest on four corners (singular A), sliding (friction at its bound), the 3-box stack, and a
# brick's impact on an edge (two contacts) and on a corner (one: A of full rank).
TESTED = ("box at rest", "box sliding", "box sliding at 22.5 deg", "stack of 3", "impact on an edge",
          "impact on a corner")


@pytest.fixture(scope="module")
def problems():
    return {p.name: p for p in oracle.capture([s for s in oracle.SCENES if s[0] in TESTED])}


@pytest.mark.parametrize("name", TESTED)
def test_capture_is_the_problem_the_reference_solved(problems, name):
    # Lemke's solution of the step satisfies the captured problem to the rounding of its
    # pivots (measured: up to 2.2e-12 of the velocity scale max |b|; 1e-10 leaves room for
    # more pivots, and is 4 orders below Lemke's 1e-6 acceptance); a capture off by one row, a
    # sign or a target is off by the problem's own velocities (1e-2 to 1 of max |b|)
    p = problems[name]
    assert oracle.pyramid_residual(p, p.gamma) <= 1e-10 * np.max(np.abs(p.b)), oracle.pyramid_residual(p, p.gamma)
    assert np.all(p.gamma[p.rows.is_normal] >= 0.0)


def test_problems_survive_save_and_load(problems, tmp_path):
    path = tmp_path / "problems.npz"
    oracle.save(list(problems.values()), path)
    back = oracle.load(path)
    assert [p.name for p in back] == list(problems)
    for p, q in zip(problems.values(), back):
        assert np.array_equal(p.A, q.A) and np.array_equal(p.b, q.b) and np.array_equal(p.gamma, q.gamma)


def test_a_box_on_four_corners_has_no_unique_impulses(problems):
    # why impulses are not compared there: 4 contacts x 3 rows of a single body's 6 freedoms
    p = problems["box at rest"]
    assert p.contacts == 4 and np.linalg.matrix_rank(p.A) == 6 < len(p.rows.a)


def test_an_unknown_planted_fault_is_refused(problems):
    with pytest.raises(ValueError, match="fault 'gravity'"):
        oracle.planted(problems["box sliding"], "gravity")


@pytest.fixture(scope="module")
def pinocchio():
    return pytest.importorskip("pinocchio", reason='the oracle extra: pip install ".[oracle]"')


@pytest.mark.parametrize("name", TESTED)
def test_reference_moves_the_bodies_as_pinocchio_does(problems, pinocchio, name):
    p = problems[name]
    d = oracle.differences(p, p)
    assert d["velocity m/s"] <= d["tolerance m/s"], f"{name}: {d}, but should be within tolerance"


def test_unique_impulses_are_pinocchios(problems, pinocchio):
    # one contact: A has full rank, so the impulses themselves are unique; Lemke accepts an
    # impulse 1e-6 of itself off (lemke.lemke_or_retry)
    p = problems["impact on a corner"]
    assert np.linalg.matrix_rank(p.A) == len(p.rows.a)
    theirs = oracle.solve(p, "pinocchio admm")
    assert np.max(np.abs(p.gamma - theirs)) <= oracle.REL_TOL * np.max(np.abs(theirs)), (p.gamma, theirs)


# Planted where the fault shows: mu where contacts slide (the corner's impact sticks: mu
# doubled changes nothing there, measured), a flipped normal where every contact carries load
# (a box resting on four corners stands as well on three, measured)
@pytest.mark.parametrize("name, fault", [("box sliding", "mu"), ("box sliding at 22.5 deg", "mu"),
                                         ("impact on a corner", "normal"),
                                         ("impact on an edge", "normal")])
def test_a_planted_wrong_reference_parts_from_pinocchio(problems, pinocchio, name, fault):
    p = problems[name]
    wrong = oracle.planted(p, fault)
    d = oracle.differences(p, wrong)
    assert d["velocity m/s"] > 100 * d["tolerance m/s"], f"{name}, {fault} planted: {d}, but should part"


def test_bench_oracle_without_pinocchio_says_so_in_one_line(monkeypatch, tmp_path, capsys):
    from physval.cli import main
    monkeypatch.setattr(oracle, "available", lambda: False)
    assert main(["bench", "oracle", "--out", str(tmp_path)]) == 2
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1 and 'pip install "physval[oracle]"' in err, err
    assert not (tmp_path / "bench.md").exists()
