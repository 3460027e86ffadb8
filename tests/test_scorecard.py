"""The engine scorecard: each grade follows its stated rule from the checks behind it, and
every run's report opens with it."""
from __future__ import annotations

import math

import pandas as pd
import pytest

from physval.readings import closest, scorecard


def _checks(*rows) -> pd.DataFrame:
    return pd.DataFrame([{"engine": "e", "case": "central_impact", "metric": "v1_after", "status": s,
                          "over_tol": x} for s, x in rows])


def _pass(n: int) -> tuple:
    return (("pass", 0.5),) * n


# Hand-worked grades: the letter is the share of checks within tolerance (A all, B >= 90 %,
# C >= 70 %, D >= 50 %, F below), the digit the decade of the median miss in tolerances
# (1 up to 10, 2 up to 100, 3 up to 1000, 4 beyond; a blow-up or a raise misses by inf).
@pytest.mark.parametrize("rows, grade", [
    ((), "-"),
    ((("pass", 0.5), ("pass", 1.0)), "A"),
    (_pass(9) + (("deviation", 9.9),), "B1"),        # 9/10 within; the one miss 9.9 tol
    (_pass(9) + (("deviation", 10.1),), "B2"),       # 10.1 tol: the second decade
    (_pass(19) + (("deviation", 150.0),), "B3"),     # 19/20
    (_pass(3) + (("deviation", 2.0),), "C1"),        # 3/4 = 75 %
    (_pass(6) + (("deviation", 2.0),) * 4, "D1"),    # 6/10 = 60 %
    ((("pass", 0.5), ("deviation", 5.0), ("deviation", 50.0), ("deviation", 5000.0)), "F2"),  # 1/4; median 50
    ((("pass", 0.5), ("deviation", 2.0), ("fail", 1.5)), "F1"),  # a fail is a miss like the others: 1.75 tol
    ((("pass", 0.1), ("unstable", math.nan)), "D4"),  # 1/2; a blow-up misses by an infinite amount
    ((("pass", 0.1), ("error", math.nan)), "D4"),
    ((("pass", 0.1), ("deviation", math.inf)), "D4"),  # a count or yes/no that allows no error
    ((("deviation", 1.5), ("deviation", 1500.0)), "F3"),  # none within; median 750.75
])
def test_the_grade_follows_its_rule(rows, grade):
    assert scorecard.grade(_checks(*rows)) == grade


def test_the_rule_s_constants_give_the_grades_in_order():
    assert scorecard.ORDER == ["A", "B1", "B2", "B3", "B4", "C1", "C2", "C3", "C4", "D1", "D2", "D3", "D4",
                               "F1", "F2", "F3", "F4"]
    assert [scorecard.grade_of(s, 5.0) for s in (1.0, 0.9, 0.899, 0.7, 0.5, 0.49)] == ["A", "B1", "C1", "C1", "D1",
                                                                                        "F1"]
    assert [scorecard.grade_of(0.95, m) for m in (1.01, 10.0, 10.01, 100.0, 1000.0, 1000.1, math.inf)] == [
        "B1", "B1", "B2", "B2", "B3", "B4", "B4"]


def test_each_effect_ranks_its_engines_and_names_the_closest_with_its_cost():
    """Hand-worked: on restitution `a` is within on all its 2 checks (A), `b` on 9 of 10 with
    a miss of 20 tol (B2), `c` on 9 of 10 with a miss of 3 tol (B1), `d` on 3 of 10 (F); the
    reference is A too but stands aside. Each run costs its wall_s / sim_s: a 2 ms per
    simulated second, c 4 and 8 (median 6)."""
    rows = []

    def add(engine, n_pass, misses, variant_cost=()):
        for k in range(n_pass + len(misses)):
            miss = k >= n_pass
            rows.append({"engine": engine, "case": "central_impact", "variant": f"v{k}", "metric": "v1_after",
                         "status": "deviation" if miss else "pass", "over_tol": misses[k - n_pass] if miss else 0.5,
                         "wall_s": variant_cost[k] if k < len(variant_cost) else 1.0, "sim_s": 1.0})
    add("reference", 10, [])
    add("a", 2, [], (0.002, 0.002))
    add("b", 9, [20.0])
    add("c", 9, [3.0], (0.004,) * 5 + (0.008,) * 5)
    add("d", 3, [2.0] * 7)
    card = scorecard.measure(pd.DataFrame(rows))
    rest = card[card.effect == "restitution"].set_index("engine")
    assert rest.grade.to_dict() == {"reference": "A", "a": "A", "b": "B2", "c": "B1", "d": "F1"}
    assert rest["rank"].to_dict() == {"reference": 1, "a": 2, "c": 3, "b": 4, "d": 5}  # A: the more checks first
    assert rest.ms_per_s["a"] == pytest.approx(2.0) and rest.ms_per_s["c"] == pytest.approx(6.0)
    (line,) = closest.answers(card)
    assert line == ("- **restitution**: a (**A**, 2/2 within; 2 ms per simulated second); then c **B1**, b **B2**, "
                    "d **F1**")
    text = closest.section(card)
    assert "| restitution | reference A, a A, c B1, b B2, d F1 |" in text.replace("  ", "")


def test_engines_tied_at_the_top_are_named_together():
    rows = [{"engine": e, "case": "slide_to_stop", "variant": "v", "metric": "distance", "status": "pass",
             "over_tol": 0.1, "wall_s": 0.001, "sim_s": 1.0} for e in ("x", "y")]
    (line,) = closest.answers(scorecard.measure(pd.DataFrame(rows)))
    assert line.startswith("- **kinetic friction**: x (**A**, 1/1 within; 1 ms per simulated second), y (**A**")
    assert line.endswith("(tied)")


def test_a_family_tests_the_effects_of_its_metrics():
    assert scorecard.effect_of("incline_threshold", "slides") == ["static friction"]
    assert scorecard.effect_of("incline_threshold", "sliding_acceleration") == ["kinetic friction"]
    assert scorecard.effect_of("robustness_pile", "energy_gain") == ["stability"]
    assert scorecard.effect_of("no_such_family", "x") == []


def test_the_grasp_effect_grades_the_determinate_grasps_only():
    """The ball (one point a pad) and the 2D block hold with determinate frictions; the 3D
    block's four coplanar corners a pad split them indeterminately (cases/pinch_grasp.py), so
    its checks grade no effect."""
    assert scorecard.effect_of("pinch_grasp", "holding_friction", "2muF/mg=0.8,ball") == ["grasp"]
    assert scorecard.effect_of("pinch_grasp", "slides", "2muF/mg=1.25,2D") == ["grasp"]
    assert scorecard.effect_of("pinch_grasp", "holding_friction", "2muF/mg=0.8") == []
    rows = [{"engine": "x", "case": "pinch_grasp", "variant": v, "metric": "holding_friction", "status": s,
             "over_tol": t, "wall_s": 0.001, "sim_s": 1.0}
            for v, s, t in (("2muF/mg=0.8,ball", "pass", 0.1), ("2muF/mg=0.8", "fail", 50.0))]
    card = scorecard.measure(pd.DataFrame(rows)).set_index(["engine", "effect"])
    assert card.loc[("x", "grasp"), "grade"] == "A" and card.loc[("x", "grasp"), "judged"] == 1


def test_unsupported_checks_are_not_graded():
    df = pd.concat([_checks(("pass", 0.2)), _checks(("unsupported", math.nan)).assign(engine="f")])
    card = scorecard.measure(df).set_index(["engine", "effect"])
    assert card.loc[("e", "restitution"), "grade"] == "A" and card.loc[("f", "restitution"), "grade"] == "-"
    assert card.loc[("e", "restitution"), "within"] == 1 == card.loc[("e", "restitution"), "judged"]


def test_integration_order_checks_are_graded_apart_from_the_physics():
    """A check that measures the integrator (Check.measures = "integrator": free_rigid_body's
    second-order drift bounds) is graded under "integration order", not under its effect."""
    from cases import free_rigid_body as fr
    checks = {c.metric: c.measures for c in fr.expect({"spin": 5.0, "wobble": 2.0, "dim": 3}, fr.DT)}
    assert checks["energy_drift"] == checks["flip_time"] == "integrator" and checks["com_velocity_error"] == "physics"
    rows = [{"engine": "e", "case": "free_rigid_body", "metric": m, "status": s, "over_tol": x, "measures": k}
            for m, s, x, k in (("com_velocity_error", "pass", 0.1, "physics"),
                               ("energy_drift", "deviation", 1500.0, "integrator"))]
    card = scorecard.measure(pd.DataFrame(rows)).set_index(["engine", "effect"])
    assert card.loc[("e", "rotation and inertia"), "grade"] == "A"
    assert card.loc[("e", scorecard.INTEGRATION), "grade"] == "F4"  # 0/1 within; the miss 1500 tol
    assert card.loc[("e", scorecard.INTEGRATION), "judged"] == 1


def test_the_run_report_opens_with_the_scorecard(tmp_path):
    from physval.cli import main
    out = tmp_path / "out"
    assert main(["run", "--cases", "central_impact[drop,e=0.5]", "--engines", "reference", "--quiet",
                 "--readings", "none", "--out", str(out)]) == 0
    report = (out / "report.md").read_text()
    first = report.index("\n## ", report.index("## Contents") + 1)
    assert report[first:].startswith("\n## Scorecard")
    assert "| reference | **A** 2/2 |" in report.replace("  ", "").replace(" |", " |")


def _beside(out):
    """Readings of sweep, stress and real as those commands write them, with values chosen
    so each cell's text can be worked out by hand."""
    (out / "sweep").mkdir(parents=True)
    (out / "stress").mkdir()
    (out / "real").mkdir()
    pd.DataFrame([{"case": "central_impact", "variant": "drop,e=0.5", "engine": "reference",
                   "reach_cost_us_per_sim_s": 2000.0},
                  {"case": "bounce_series", "variant": "e=0.5", "engine": "reference", "reach_cost_us_per_sim_s": 500.0},
                  {"case": "central_impact", "variant": "drop,e=0.5", "engine": "mujoco",
                   "reach_cost_us_per_sim_s": math.nan}]).to_csv(out / "sweep" / "sweep_summary.csv", index=False)
    pd.DataFrame([{"engine": "reference", "scene": "a", "status": "deterministic"},
                  {"engine": "reference", "scene": "b", "status": "differs"}]).to_csv(
        out / "stress" / "determinism.csv", index=False)
    pd.DataFrame([{"engine": "reference", "param_set": "nominal", "corner_mean_median": 0.30},
                  {"engine": "reference", "param_set": "fitted", "corner_mean_median": 0.25},
                  {"engine": "mujoco", "param_set": "nominal", "corner_mean_median": 0.20},
                  {"engine": "noise floor", "param_set": "", "corner_mean_median": 0.001}]).to_csv(
        out / "real" / "real_summary.csv", index=False)


def test_the_other_readings_beside_a_run_fill_their_columns(tmp_path):
    """The sweep's cost (the dearest swept variant of the effect's families at its cheapest
    setting), the real tier's error at the fitted parameters with its rank (the noise floor
    is not an engine), and the share of scenes that repeat bit for bit."""
    _beside(tmp_path)
    beside = scorecard.companions(tmp_path)
    assert len(beside.sources) == 3
    df = pd.concat([_checks(("pass", 0.2)), _checks(("pass", 0.3)).assign(engine="mujoco")])
    df = df.assign(engine=df.engine.replace({"e": "reference"}))
    card = scorecard.measure(df, beside).set_index(["engine", "effect"])
    assert card.loc[("reference", "restitution"), "cost"] == "tol at 2 ms/s"
    assert card.loc[("mujoco", "restitution"), "cost"] == "tol in 0/1 swept"
    assert card.loc[("reference", scorecard.REAL), "text"] == "0.25, rank 2/2"
    assert card.loc[("mujoco", scorecard.REAL), "text"] == "0.2, rank 1/2"
    assert card.loc[("reference", scorecard.DETERMINISM), "grade"] == "D"  # 1 of 2 scenes repeat: 50 %
    assert card.loc[("mujoco", scorecard.DETERMINISM), "grade"] == "-"


def test_the_run_report_shows_the_readings_beside_it(tmp_path):
    from physval.cli import main
    out = tmp_path / "out"
    _beside(out)
    assert main(["run", "--cases", "central_impact[drop,e=0.5]", "--engines", "reference", "--quiet",
                 "--readings", "none", "--out", str(out)]) == 0
    report = (out / "report.md").read_text()
    card = report[report.index("## Scorecard"):report.index("\n## ", report.index("## Scorecard") + 1)]
    assert "real-world error" in card and "determinism" in card
    assert "**A** 2/2; tol at 2 ms/s" in card
    assert "0.25, rank 2/2" in card and "**D** 1/2 repeat" in card
    html = (out / "report.html").read_text()
    assert "0.25, rank 2/2" in html


def test_the_worst_of_a_zero_tolerance_check_is_its_value_not_infinity():
    """A count or a yes/no allows no error (tolerance 0, error in tolerances infinite): the
    cell names the check's value against the one asked instead of 'inf tol'."""
    part = _checks(("pass", 0.5), ("deviation", math.inf), ("deviation", 40.0)).assign(
        metric=["v1_after", "slides", "v1_after"], measured=[1.0, 1.0, 2.0], expected=[1.0, 0.0, 1.0])
    assert scorecard.worst_of(part) == "worst slides 1 for 0"
    assert scorecard.worst_of(part.iloc[[0, 2]]) == "worst 40 tol"


def test_a_run_whose_every_job_failed_still_gets_its_report(tmp_path):
    """Every job of a release raised (no check has an error to rank): the report is written and
    its scorecard counts the failures (it once stopped at the worst of no errors at all)."""
    rows = _checks(("error", math.nan), ("error", math.nan)).assign(metric=["v1_after", "v2_after"])
    assert scorecard.worst_of(rows) == ""
    card = scorecard.measure(rows.assign(variant="v", expected=1.0, measured=math.nan), scorecard.Companions())
    assert (card[card.effect == "contact"].failures == 2).all()


def test_determinism_counts_only_the_scenes_an_engine_ran():
    """A 2D engine cannot run the 3D stress scenes: they are no repeat it missed, so an
    engine that repeats every scene it ran is graded A (was C, '2/4 repeat'); one that
    repeats 1 of 2 gets the letter of a 50 % share, D."""
    det = pd.DataFrame([{"engine": "pymunk", "scene": "a,2D", "status": "deterministic"},
                        {"engine": "pymunk", "scene": "b,3D", "status": "unsupported"},
                        {"engine": "dart", "scene": "a,2D", "status": "deterministic"},
                        {"engine": "dart", "scene": "b,3D", "status": "differs"}])
    pymunk, dart = (scorecard._determinism(e, det) for e in ("pymunk", "dart"))
    assert (pymunk["grade"], pymunk["text"]) == ("A", "1/1 repeat")
    assert (dart["grade"], dart["text"]) == ("D", "1/2 repeat")


EMPTY, FOREIGN, BINARY = "", "a,b\n1,2\n", "\x00\xff junk"


@pytest.mark.parametrize("path, content", [
    ("sweep/sweep_summary.csv", EMPTY), ("sweep/sweep_summary.csv", FOREIGN), ("stress/determinism.csv", EMPTY),
    ("real/real_summary.csv", FOREIGN), ("real/real_summary.csv", BINARY),
    ("parity/mujoco-mujoco-warp/parity.csv", FOREIGN), ("parity/mujoco-mujoco-warp/parting.csv", EMPTY),
])
def test_a_damaged_file_beside_a_run_costs_its_column_not_the_report(tmp_path, capsys, path, content):
    """An empty, foreign or binary companion file under --out: skipped with one line naming
    it, the report written with the others (before: a traceback after every job, and the
    same on every rerun, since the file stays)."""
    from physval.cli import main
    out = tmp_path / "out"
    _beside(out)
    if path.startswith("parity/"):  # a good parity reading, then the damaged file in it
        pair = out / "parity" / "mujoco-mujoco-warp"
        pair.mkdir(parents=True)
        pd.DataFrame([{"case": "central_impact", "engine_a": "mujoco", "engine_b": "mujoco-warp",
                       "engine_version_a": "4.0.0", "engine_version_b": "4.0.0", "difference": 0.1,
                       "verdicts_differ": False, "one_engine_only": False}]).to_csv(pair / "parity.csv", index=False)
    (out / path).parent.mkdir(parents=True, exist_ok=True)
    (out / path).write_bytes(content.encode("latin-1"))
    argv = ["run", "--cases", "central_impact[drop,e=0.5]", "--engines", "reference", "--quiet", "--readings", "none",
            "--workers", "1", "--out", str(out)]
    assert main(argv) == 0
    (line,) = capsys.readouterr().err.strip().splitlines()
    assert line.startswith(f"physval: left out {out / path}: ") and "`physval " in line, line
    assert "## Scorecard" in (out / "report.md").read_text()
