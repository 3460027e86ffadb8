"""`physval parity ENGINE PORT`: the same scenes on two engines, each check's difference in
units of its tolerance and the step where each pair of trajectories parts; run through
physval.cli.main on two formulations of the reference (always installed, no compile)."""
from __future__ import annotations

import csv

import pandas as pd
import pytest

from adapters import registry
from physval.cli import main
from physval.readings import parity


def test_parity_runs_both_engines_and_reports_per_family(tmp_path, capsys):
    out = tmp_path / "parity"
    code = main(["parity", "reference", "reference-pgs", "--cases", "central_impact[e=0.5,m=1:3]",
                 "resting_blocks[n=2]", "--workers", "1", "--out", str(out), "--quiet"])
    assert code == 0
    said = capsys.readouterr().out
    assert "checks on both" in said and "trajectory pairs part" in said
    rows = list(csv.DictReader(open(out / "parity.csv")))
    assert {r["case"] for r in rows} == {"central_impact", "resting_blocks"}
    for r in rows:  # both judged: a finite difference in tolerances
        assert r["status_a"] in parity.JUDGED and r["status_b"] in parity.JUDGED
        assert float(r["difference"]) == pytest.approx(
            (float(r["measured_b"]) - float(r["measured_a"])) / float(r["tolerance"]) /
            (abs(float(r["expected"])) if r["tolerance_kind"] == "rel" else 1.0))
    parts = list(csv.DictReader(open(out / "parting.csv")))
    assert len(parts) == 2 and all(p["steps"] for p in parts)
    text = (out / "parity.md").read_text()
    assert "## Per family" in text and "central_impact" in text and "resting_blocks" in text
    assert (out / "trajectories").is_dir() and (out / "results.csv").is_file()


def test_parity_of_an_engine_with_itself_is_bad_input(tmp_path, capsys):
    assert main(["parity", "reference", "reference", "--cases", "central_impact[e=0.5,m=1:3]",
                 "--out", str(tmp_path / "p")]) == 2
    assert "name two engines" in capsys.readouterr().err


def test_a_difference_is_counted_in_the_wider_tolerance_of_the_two():
    def row(engine, metric, measured, status="pass", kind="abs"):
        return {"case": "f", "variant": "v", "engine": engine, "engine_version": "1", "metric": metric, "status": status,
                "measured": measured, "expected": 2.0, "tolerance": 0.1, "tolerance_kind": kind, "reason": ""}
    df = pd.DataFrame([row("a", "x", 2.0), {**row("b", "x", 2.05), "tolerance": 0.05}, row("a", "r", 2.0, kind="rel"),
                       row("b", "r", 2.1, kind="rel"), row("a", "u", 2.0), row("b", "u", float("nan"), "unsupported")])
    t = parity.checks(df, "a", "b").set_index("metric")
    assert t.difference["x"] == pytest.approx(0.5)   # 0.05 m of the wider, 0.1 m, tolerance
    assert t.difference["r"] == pytest.approx(0.5)   # 0.1 of 10 % of |2|
    # a scene one engine cannot represent is no verdict of that engine: counted apart
    assert pd.isna(t.difference["u"]) and t.one_engine_only["u"] and not t.verdicts_differ["u"]
    assert not t.verdicts_differ["x"] and not t.one_engine_only["x"]
    fam = parity.families(t.reset_index(), parity.parting([], parity.PARTED)).iloc[0]
    assert fam["verdicts differ"] == 0 and fam["one engine only"] == 1
    assert fam["largest |diff| (tol)"] == pytest.approx(0.5)


def test_a_verdict_differs_where_both_engines_ran_the_scene():
    rows = [{"case": "f", "variant": "v", "engine": e, "engine_version": "1", "metric": "x", "status": s, "measured": m,
             "expected": 2.0,
             "tolerance": 0.1, "tolerance_kind": "abs", "reason": ""}
            for e, s, m in (("a", "pass", 2.0), ("b", "fail", 2.5))]
    t = parity.checks(pd.DataFrame(rows), "a", "b").iloc[0]
    assert t.verdicts_differ and not t.one_engine_only and t.difference == pytest.approx(5.0)


def test_the_findings_group_differing_verdicts_by_the_recorded_cause():
    """Each verdict that differs is told once under the cause the deviating engine's deviation
    file records (its measured suffix dropped), with the engine that passes; the parting
    sentence names the first pair to part."""
    def row(engine, variant, status, measured, reason=""):
        return {"case": "f", "variant": variant, "engine": engine, "engine_version": "1", "metric": "x",
                "status": status, "measured": measured, "expected": 1.0, "tolerance": 0.1, "tolerance_kind": "abs",
                "reason": reason}
    cause = "float32 heights: no arc is found [measured 0.3 m in the recorded band 0.2-0.4]"
    rows = [row("a", v, "pass", 1.0) for v in ("v1", "v2", "v3")] + [row("a", "v4", "deviation", 1.2, "slow")]
    rows += [row("b", "v1", "deviation", 0.3, cause), row("b", "v2", "deviation", 0.35, cause), row("b", "v3", "pass", 1.0),
             row("b", "v4", "fail", 1.5)]
    table = parity.checks(pd.DataFrame(rows), "a", "b")
    parts = pd.DataFrame([{"case": "f", "variant": "v2", "steps": 100, "parted_step": 7, "parted_time": 0.007,
                           "first_to_part": "ball velocity[2]"},
                          {"case": "f", "variant": "v1", "steps": 100, "parted_step": 3, "parted_time": 0.003,
                           "first_to_part": "ball velocity[0]"},
                          {"case": "f", "variant": "v3", "steps": 100}]).assign(parted_at=1e-3)
    text, causes = parity.findings(table, parts)
    assert "3 verdicts differ" in text and "3 checks differ by more than one tolerance" in text
    assert "f[v1]:x, -7 tolerances" in text  # the largest move: 0.7 of a 0.1 tolerance
    assert "2 of 3 trajectory pairs part" in text and "the first is f[v1], at step 3" in text
    assert causes == ["f: 2 checks pass on a and deviate (known) on b; recorded cause: float32 heights: no arc is found",
                      "f: 1 check deviates (known) on a and fails on b; recorded cause: no recorded cause"]


def test_a_run_reports_the_parity_pairs_found_beside_it(tmp_path, monkeypatch):
    """`physval parity` writes into reports/parity/ENGINE-PORT by default, and `physval run`
    into reports/ reads every pair there into report.md and report.html."""
    monkeypatch.chdir(tmp_path)
    assert main(["parity", "reference", "reference-pgs", "--cases", "central_impact[e=0.5,m=1:3]", "--workers", "1",
                 "--quiet"]) == 0
    assert (tmp_path / "reports/parity/reference-reference-pgs/parity.csv").is_file()
    assert main(["run", "--engines", "reference", "--cases", "central_impact[e=0.5,m=1:3]", "--workers", "1",
                 "--quiet"]) == 0
    report = (tmp_path / "reports/report.md").read_text()
    assert "## Implementation parity" in report and "**reference-pgs against reference.** Of " in report
    assert "(parity/reference-reference-pgs/parity.md)" in report and (tmp_path / "reports/plots/parity.png").is_file()
    assert "reference-pgs against reference" in (tmp_path / "reports/report.html").read_text()


def test_the_harness_keeps_warps_kernel_cache_in_its_own_folder(monkeypatch, tmp_path):
    """Engines' own caches (store.ENGINE_CACHES) go into physval's cache folder before any
    engine starts, unless the user set them."""
    import os

    from physval.core.context import Context, Resolver
    monkeypatch.setenv("WARP_CACHE_PATH", "")  # restored (or removed) after the test
    monkeypatch.delenv("WARP_CACHE_PATH")
    monkeypatch.setenv("PHYSVAL_CACHE_DIR", str(tmp_path))
    Resolver(Context()).adapter("reference")
    assert os.environ["WARP_CACHE_PATH"] == str(tmp_path / "warp")
    monkeypatch.setenv("WARP_CACHE_PATH", "/elsewhere")  # a value the user set stays
    Resolver(Context()).adapter("reference")
    assert os.environ["WARP_CACHE_PATH"] == "/elsewhere"


# --- what can be told before any job (issue 33) ------------------------------------------------

def _parity(tmp_path, *argv) -> tuple[int, list[str]]:
    import contextlib
    import io
    err = io.StringIO()
    with contextlib.redirect_stderr(err):
        code = main(["parity", *argv, "--workers", "1", "--quiet", "--out", str(tmp_path / "out")])
    return code, err.getvalue().strip().splitlines()


def test_a_port_that_is_not_installed_stops_before_any_job(tmp_path):
    """Before: every job of ENGINE ran first, then exit 2."""
    missing = [e for e in registry.engine_names() if not registry.available(e)]
    if not missing:
        pytest.skip("every engine is installed here")
    code, err = _parity(tmp_path, "reference", missing[0], "--cases", "central_impact[drop,e=0.5]")
    assert code == 2 and len(err) == 1 and f"engine {missing[0]!r} is not installed" in err[0], err
    assert not (tmp_path / "out" / "results.csv").exists()


def test_two_engines_with_no_scene_in_common_stop_before_any_job(tmp_path):
    """A 3D scene for a 2D engine: nothing to compare, said in one line (before: every job
    ran and the report's table of the largest differences was rows of NaN)."""
    if not registry.available("pymunk"):
        pytest.skip("Pymunk (2D only) is not installed")
    code, err = _parity(tmp_path, "reference", "pymunk", "--cases", "central_impact[drop,e=0.5]")
    assert code == 2 and err == ["physval: error: reference and pymunk share no scene among the selected cases: "
                                 "every variant is one that at most one of them can represent (`physval list` "
                                 "shows which engines run each variant)"], err
    assert not (tmp_path / "out" / "results.csv").exists()
