"""Tests of the harness itself: tolerance logic, the status taxonomy, known deviations,
the results table contract and the report files. Engines are stand-ins (tests/fakes.py)."""
from __future__ import annotations

import csv
import importlib.util
import math
from pathlib import Path

import pytest

from cases.family import CaseError, CaseFamily, Check, Variant
from cases.scene import Body, Circle, Material, Plane, Scene, Sphere
from physval.core import deviations
from physval.core import COLUMNS, Job
from physval.core.tolerance import errors, within
from physval.core.verdicts import contract_problems
from tests.fakes import FakeAdapter
from tests.helpers import run_job

ROOT = Path(__file__).resolve().parent.parent
G, Z0, T, DT = 9.81, 10.0, 0.5, 1e-3


def _fall_scene(p):
    return Scene(bodies=(Body("ball", Sphere(0.1), mass=1.0, position=(0, 0, Z0), rotates=False),),
                 gravity=(0, 0, -G))


def _fall_observe(traj, p):
    return {"z_end": traj.pos("ball")[-1, 2], "vz_end": traj.vel("ball")[-1, 2]}


def _fall_expect(p, dt):
    n = round(T / dt)
    # symplectic Euler (velocity first): z_n = z0 - g dt^2 n (n+1) / 2, v_n = -g n dt
    return [Check("z_end", "m", Z0 - G * dt**2 * n * (n + 1) / 2 + p.get("offset", 0.0), 1e-9, "abs",
                  "the discrete closed form of symplectic Euler: exact to round-off"),
            Check("vz_end", "m/s", -G * n * dt, 1e-9, "rel", "exact to round-off")]


FALL = CaseFamily(name="free_fall", summary="a ball falls", source="symplectic Euler",
                  grid=({"offset": 0.0}, {"offset": 0.5}), scene=_fall_scene, duration=lambda p: T,
                  observe=_fall_observe, expect=_fall_expect, dt=DT, variant_id=lambda p: f"offset={p['offset']}")


def _job(variant_index=0, engine="fake"):
    return Job("free_fall", FALL.variants[variant_index], engine)


# --- tolerance logic ----------------------------------------------------------------------

def test_errors_are_absolute_and_relative():
    assert errors(2.0, 2.5) == (0.5, 0.25)
    a, r = errors(0.0, 1e-3)
    assert a == 1e-3 and math.isnan(r)
    assert all(math.isnan(x) for x in errors(1.0, math.nan))


@pytest.mark.parametrize("kind,expected,measured,tol,ok", [
    ("abs", 1.0, 1.0 + 1e-4, 1e-4 * 1.0001, True),
    ("abs", 1.0, 1.0 + 2e-4, 1e-4, False),
    ("rel", 100.0, 100.5, 0.01, True),
    ("rel", 100.0, 102.0, 0.01, False),
    ("rel", 0.0, 0.0, 0.01, False),     # a relative error of an expected 0 is undefined: never a pass
    ("abs", 0.0, math.nan, 1.0, False),
])
def test_within_uses_the_checks_own_error_kind(kind, expected, measured, tol, ok):
    c = Check("m", "-", expected, tol, kind, "reason")
    assert within(c, *errors(expected, measured)) is ok


def test_a_check_needs_a_reason_and_a_valid_tolerance():
    with pytest.raises(CaseError, match="reason"):
        Check("m", "-", 1.0, 0.1, "abs", " ")
    with pytest.raises(CaseError, match="tolerance"):
        Check("m", "-", 1.0, -0.1, "abs", "why")
    with pytest.raises(CaseError, match="kind"):
        Check("m", "-", 1.0, 0.1, "percent", "why")


# --- the status taxonomy ------------------------------------------------------------------

def test_pass_and_fail_are_judged_per_check():
    rows = run_job(_job(0), FALL, FakeAdapter(), known=[])
    assert [r["status"] for r in rows] == ["pass", "pass"]
    assert rows[0]["steps"] == 500 and rows[0]["sim_s"] == pytest.approx(T) and rows[0]["wall_s"] > 0
    rows = run_job(_job(1), FALL, FakeAdapter(), known=[])  # expects the ball 0.5 m higher
    assert [r["status"] for r in rows] == ["fail", "pass"]
    assert rows[0]["abs_error"] == pytest.approx(0.5) and "> tolerance" in rows[0]["reason"]


def test_a_variants_closed_forms_are_computed_once_per_process():
    """Every engine's job of a variant asks for the same checks: expect() runs once per
    variant and time step (physval.core.jobs.expected), and a family of the same name with
    another expect() gets its own."""
    calls = []

    def expect(p, dt):
        calls.append((p["offset"], dt))
        return _fall_expect(p, dt)
    counted = CaseFamily(name="free_fall", summary="a ball falls", source="symplectic Euler",
                         grid=({"offset": 0.0},), scene=_fall_scene, duration=lambda p: T,
                         observe=_fall_observe, expect=expect, dt=DT, variant_id=lambda p: f"offset={p['offset']}")
    job = Job("free_fall", counted.variants[0], "fake")
    first = run_job(job, counted, FakeAdapter(), known=[])
    again = run_job(Job("free_fall", counted.variants[0], "other"), counted, FakeAdapter(), known=[])
    assert calls == [(0.0, DT)] and [r["status"] for r in first + again] == ["pass"] * 4
    assert run_job(_job(1), FALL, FakeAdapter(), known=[])[0]["status"] == "fail"  # FALL's own expect


def _entry(variant="offset=0.5", metric="z_*", bands=(), reason="the fake engine floats"):
    return deviations.Deviation("fake.txt", "free_fall", variant, metric, reason, 1, tuple(bands))


def _band(value, width=1e-10, variant="offset=0.5", metric="z_end", raises=None):
    return deviations.Band("fake", variant, metric, value, width, raises)


def test_a_known_deviation_is_reported_with_its_measured_size_inside_its_band():
    expected_z = FALL.expect({"offset": 0.5}, DT)[0].expected
    known = [_entry(bands=[_band(expected_z - 0.5)])]
    rows = run_job(_job(1), FALL, FakeAdapter(), known=known)
    assert rows[0]["status"] == "deviation"
    assert "the fake engine floats" in rows[0]["reason"] and "0.5" in rows[0]["reason"]
    assert rows[0]["band"] and "recorded band" in rows[0]["reason"]
    rows = run_job(_job(0), FALL, FakeAdapter(), known=known)
    assert rows[0]["status"] == "pass" and rows[0]["known_deviation"] == ""


def test_a_deviation_that_leaves_its_band_is_a_fail_with_both_sizes():
    expected_z = FALL.expect({"offset": 0.5}, DT)[0].expected
    known = [_entry(bands=[_band(expected_z - 0.4)])]  # recorded 0.4 off; the fake is 0.5 off
    (row, _) = run_job(_job(1), FALL, FakeAdapter(), known=known)
    assert row["status"] == "fail" and row["reason"].startswith("known deviation changed: recorded")
    assert f"{expected_z - 0.4:.6g} +- 1e-10" in row["reason"] and f"{expected_z - 0.5:.6g}" in row["reason"]


def test_a_wildcard_covers_only_the_checks_whose_bands_it_records():
    known = [_entry(bands=[])]  # the pattern matches, but no band: not covered
    (row, _) = run_job(_job(1), FALL, FakeAdapter(), known=known)
    assert row["status"] == "fail" and "no band is recorded for this check on fake" in row["reason"]


def test_bands_hold_only_at_the_settings_they_were_recorded_at():
    expected_z = FALL.expect({"offset": 0.5}, DT)[0].expected
    known = [_entry(bands=[_band(expected_z - 0.5)])]
    job = Job("free_fall", FALL.variants[1], "fake", dt=DT / 2)
    (row, _) = run_job(job, FALL, FakeAdapter(), known=known)
    assert row["status"] == "fail" and "recorded at the family's dt" in row["reason"]


def test_a_known_engine_failure_is_a_deviation_and_an_unknown_one_an_error():
    raises = [_band(None, variant="offset=0.0", metric=m, raises="RuntimeError") for m in ("z_end", "vz_end")]
    known = [_entry("offset=0.0", "*", raises, "the solver gives up on this LCP")]
    rows = run_job(_job(0), FALL, FakeAdapter(crash_at=3), known=known)
    assert {r["status"] for r in rows} == {"deviation"}
    assert "gives up" in rows[0]["reason"] and "RuntimeError: engine crashed" in rows[0]["reason"]
    partial = [_entry("offset=0.0", "*", raises[:1], "only one metric")]
    rows = run_job(_job(0), FALL, FakeAdapter(crash_at=3), known=partial)
    assert {r["status"] for r in rows} == {"error"}
    other = [_entry("offset=0.0", "*", [_band(None, variant="offset=0.0", metric=m, raises="ValueError")
                                        for m in ("z_end", "vz_end")])]
    rows = run_job(_job(0), FALL, FakeAdapter(crash_at=3), known=other)
    assert {r["status"] for r in rows} == {"error"}


def test_nan_is_unstable_and_the_engine_is_closed():
    adapter = FakeAdapter(blow_up_at=10)
    rows = run_job(_job(0), FALL, adapter, known=[])
    assert {r["status"] for r in rows} == {"unstable"}
    assert "NaN" in rows[0]["reason"] and "t = 0.01" in rows[0]["reason"]
    assert adapter.built[0].closed == 1


def test_an_engine_crash_is_an_error_row_and_not_an_exception():
    rows = run_job(_job(0), FALL, FakeAdapter(crash_at=3), known=[])
    assert {r["status"] for r in rows} == {"error"}
    assert "RuntimeError: engine crashed" in rows[0]["reason"]
    rows = run_job(_job(0), FALL, FakeAdapter(crash_on_build=True), known=[])
    assert {r["status"] for r in rows} == {"error"} and "MemoryError" in rows[0]["reason"]


def test_unsupported_carries_the_reason():
    rows = run_job(_job(0), FALL, FakeAdapter(unsupported="no spheres today"), known=[])
    assert {r["status"] for r in rows} == {"unsupported"} and rows[0]["reason"] == "no spheres today"
    rows = run_job(_job(0), FALL, FakeAdapter(dimensions=frozenset({2})), known=[])
    assert rows[0]["status"] == "unsupported" and "3D scene" in rows[0]["reason"]


def test_a_case_needing_contact_forces_is_unsupported_without_them():
    from cases.resting_blocks import FAMILY
    job = Job(FAMILY.name, FAMILY.variants[0], "fake")
    rows = run_job(job, FAMILY, FakeAdapter(contact_forces=False), known=[])
    assert rows[0]["status"] == "unsupported" and "contact forces" in rows[0]["reason"]


def test_unknown_engine_is_unsupported_in_a_row():
    rows = run_job(_job(0, engine="no-such-engine"), FALL)
    assert rows[0]["status"] == "unsupported" and "unknown engine" in rows[0]["reason"]


def test_rows_record_effects_and_knobs():
    rows = run_job(_job(0), FALL, FakeAdapter(), known=[])
    assert rows[0]["effects"] == "gravity" and rows[0]["effects_simulated"] == "gravity"
    assert '"integrator"' in rows[0]["knobs"]


# --- known-deviation files ----------------------------------------------------------------

def test_deviation_file_format(tmp_path):
    (tmp_path / "eng.txt").write_text(
        "# comment\n\ncentral_impact[e=0.5,*]:v*_after  # soft contact\n"
        "    eng [e=0.5,m=1:3]:v1_after = 0.125 +- 0.002\n"
        "    eng [e=0.5,m=1:3]:v2_after = raises LemkeFailure\n")
    (d,) = deviations.parse(tmp_path / "eng.txt")
    assert d.matches("central_impact", "e=0.5,m=1:3", "v1_after")
    assert not d.matches("central_impact", "e=0.9,m=1:3", "v1_after")
    band = d.band("eng", "e=0.5,m=1:3", "v1_after")
    assert band.holds(0.1265) and not band.holds(0.128) and not band.holds(None, "LemkeFailure")
    assert d.band("eng", "e=0.5,m=1:3", "v2_after").holds(exception="LemkeFailure")
    assert d.band("other", "e=0.5,m=1:3", "v1_after") is None
    for bad, where in (("central_impact v1_after no reason\n", "bad.txt:1"),
                       ("central_impact[*]:v  # x\n    eng [e=1]:v = 0.1\n", "bad.txt:2"),
                       ("central_impact[e=0.5]:v  # x\n    eng [e=0.9]:v = 1 +- 0.1\n", "not matched by its entry")):
        (tmp_path / "bad.txt").write_text(bad)
        with pytest.raises(deviations.DeviationFileError, match=where):
            deviations.parse(tmp_path / "bad.txt")


def test_rewriting_bands_keeps_causes_and_comments(tmp_path):
    path = tmp_path / "eng.txt"
    path.write_text("# head\nfree_fall[*]:z_end  # cause one\n    eng [a]:z_end = 1 +- 0.1\n"
                    "# between\nfree_fall[b*]:vz_end  # cause two\n")
    entries = deviations.parse(path)
    text = deviations.rewrite(path, {entries[0].line: [], entries[1].line: [
        deviations.Band("eng", "b1", "vz_end", 2.5, 0.01)]})
    assert text == ("# head\nfree_fall[*]:z_end  # cause one\n# between\nfree_fall[b*]:vz_end  # cause two\n"
                    "    eng [b1]:vz_end = 2.5 +- 0.01\n")


def test_every_deviation_entry_matches_a_check_of_a_builtin_case():
    """The deviation files cannot rot: each entry names a family, variant and metric that
    exist, and each band line a check its entry matches."""
    from adapters.registry import engine_names, get, EngineError
    from cases.registry import builtin_families
    fams = builtin_families()
    from cases.relations import RELATIONS
    # the families' closed forms, and the invariance battery's verdicts (any variant, with --relations)
    checks_of = {name: {(v.id, c.metric) for v in fam.all_variants for c in fam.expect(v.params, fam.dt_for(v.params))}
                 | {(v.id, r.metric) for v in fam.all_variants for r in RELATIONS}
                 for name, fam in fams.items()}
    for eng in engine_names():
        try:
            path = get(eng).deviations_file()
        except EngineError:
            continue
        for d in deviations.load([path]):
            assert d.family in fams, f"{eng}.txt:{d.line}: no family {d.family!r}"
            fam = fams[d.family]
            checks = checks_of[d.family]
            hits = [k for k in checks if d.matches(fam.name, *k)]
            assert hits, f"adapters/xfails/{eng}.txt:{d.line}: {d.pattern} matches no check"
            for b in d.bands:
                assert (b.variant, b.metric) in checks, f"{eng}.txt:{b.line}: no check [{b.variant}]:{b.metric}"


def test_every_shipped_band_is_at_most_one_tolerance_unless_its_entry_says_why():
    """Bands are measured (physval/core/deviations.py): a band wider than one tolerance of its
    check needs a `# band:` reason under its entry; a run would fail its check, this says so
    without running an engine."""
    from adapters.registry import engine_names, get, EngineError
    from cases.registry import builtin_families
    from physval.core.tolerance import tolerance_units
    from cases.relations import METRIC_PREFIX, by_name as relation_named
    from physval.core import invariance
    fams = builtin_families()
    checks = {(name, v.id): fam.expect(v.params, fam.dt_for(v.params)) for name, fam in fams.items()
              for v in fam.all_variants}
    wide = []
    for eng in engine_names():
        try:
            adapter = get(eng)
            path = adapter.deviations_file()
        except EngineError:
            continue
        # each check as the engine is judged: its round-off share at the engine's float width
        tolerance = {(name, variant, c.metric): tolerance_units(c.expected, c.tolerance, c.kind)
                     for (name, variant), cs in checks.items() for c in adapter.capabilities.judged(cs)}

        def of(family, variant, metric):  # an invariance verdict's: the promise at the engine's float width,
            if metric.startswith(METRIC_PREFIX):  # one sub-step (the smallest it takes)
                fam = fams[family]
                v = next(v for v in fam.all_variants if v.id == variant)
                steps = max(1, round(fam.duration(v.params) / fam.dt_for(v.params)))
                return invariance.check(relation_named(metric[len(METRIC_PREFIX):]), fam.scene(v.params), steps,
                                        adapter.capabilities.float_bits).tolerance
            return tolerance[family, variant, metric]
        for d in deviations.load([path]):
            wide += [f"{eng}.txt:{b.line}: {why}" for b in d.bands
                     if (why := d.too_wide(b, of(d.family, b.variant, b.metric))) is not None]
    assert not wide, f"{len(wide)} bands wider than a tolerance without a reason, e.g. {wide[:3]}"


# --- the results table and the report -----------------------------------------------------

def _rows():
    rows = []
    for adapter in (FakeAdapter(), FakeAdapter(blow_up_at=5), FakeAdapter(unsupported="not today")):
        for i in (0, 1):
            rows += run_job(_job(i), FALL, adapter, known=[])
    return rows


def _write_report(rows, out, **kw):
    import pandas as pd
    from physval.readings.results import write_run_report
    pd.DataFrame(rows, columns=COLUMNS).to_csv(out / "results.csv", index=False)
    write_run_report(rows, out, {"free_fall": FALL}, **kw)


def test_results_csv_meets_the_agreed_contract(tmp_path):
    _write_report(_rows(), tmp_path)
    with open(tmp_path / "results.csv", newline="") as fh:
        reader = csv.DictReader(fh)
        assert reader.fieldnames == COLUMNS
        rows = list(reader)
    assert {r["status"] for r in rows} == {"pass", "fail", "unstable", "unsupported"}
    assert contract_problems(tmp_path / "results.csv") == []


def test_the_contract_check_finds_each_kind_of_breach(tmp_path):
    _write_report(_rows(), tmp_path)
    path = tmp_path / "results.csv"
    with open(path, newline="") as fh:
        rows = list(csv.DictReader(fh))
    passed = next(i for i, r in enumerate(rows) if r["status"] == "pass")
    unstable = next(i for i, r in enumerate(rows) if r["status"] == "unstable")
    rows[passed][f"{rows[passed]['tolerance_kind']}_error"] = str(10 * float(rows[passed]["tolerance"]) + 1)
    rows[unstable]["reason"] = ""
    rows[0]["params"] = "not json"
    rows[-1]["status"] = "ok"
    with open(path, "w", newline="") as fh:
        w = csv.DictWriter(fh, COLUMNS)
        w.writeheader()
        w.writerows(rows)
    found = "\n".join(contract_problems(path))
    for breach in ("pass with", "unstable without a reason", "is not a JSON object", "status 'ok'"):
        assert breach in found


def test_report_has_its_sections_and_no_temporary_files(tmp_path):
    _write_report(_rows(), tmp_path, command="physval run")
    md = (tmp_path / "report.md").read_text()
    for heading in ("## Scorecard", "## Contents", "## Summary", "## Known deviations",
                    "## Failures, blow-ups and errors", "## Families", "## Engine settings", "## Environment"):
        assert heading in md
    assert "- [Families](#families)" in md and "[free_fall](families/free_fall.md)" in md
    page = (tmp_path / "families" / "free_fall.md").read_text()  # the family's detail, one click away
    assert page.startswith("# free_fall") and "Closed form: symplectic Euler." in page
    assert "the discrete closed form of symplectic Euler: exact to round-off" in page  # each tolerance's reason
    assert (tmp_path / "plots" / "free_fall.png").stat().st_size > 1000
    assert not (tmp_path / "plots" / "summary.png").exists()  # one family: its own heat map is the summary
    assert not [p for p in tmp_path.rglob(".*") if p.is_file()], "temporary files left behind"


def test_plots_drawn_beside_the_report_are_all_there_once_it_waits(tmp_path):
    """physval run draws the heat maps in processes of their own while the sections render
    (results.draw_beside): waiting returns once every drawing is done, and raises what one
    raised."""
    import os
    from physval.readings.results import draw_beside
    made = [tmp_path / f"{k}.txt" for k in range(2)]
    wait = draw_beside([(Path.write_text, (path, "drawn")) for path in made] + [(os.remove, (tmp_path / "none",))],
                       processes=2)
    with pytest.raises(FileNotFoundError):
        wait()
    assert [p.read_text() for p in made] == ["drawn"] * 2


def test_an_interrupted_write_leaves_the_old_file_whole(tmp_path, monkeypatch):
    from physval import files
    target = tmp_path / "report.md"
    target.write_text("old and complete")

    def broken_replace(src, dst):
        raise KeyboardInterrupt

    monkeypatch.setattr(files.os, "replace", broken_replace)
    with pytest.raises(KeyboardInterrupt):
        files.write_atomic(target, "new")
    assert target.read_text() == "old and complete"
    assert list(tmp_path.iterdir()) == [target]


# --- scene and case validation ------------------------------------------------------------

def test_variant_ids_are_readable():
    from cases.central_impact import FAMILY
    ids = [Variant.test_id.fget(v) for v in FAMILY.variants]
    assert "central_impact[e=0.5,m=1:3]" in ids


def test_a_family_with_a_bad_scene_names_the_variant():
    bad = CaseFamily(name="bad", summary="", source="", grid=({"m": -1.0},),
                     scene=lambda p: Scene(bodies=(Body("b", Sphere(0.1), mass=p["m"]),)),
                     duration=lambda p: 1.0, observe=lambda t, p: {}, expect=lambda p, dt: [])
    with pytest.raises(CaseError, match=r"bad\[m=-1.0\].*mass = -1.0: must be > 0"):
        bad.validate()


def test_2d_scene_rejects_3d_shapes():
    from cases.scene import SceneError
    with pytest.raises(SceneError, match="3D shape in a 2D scene"):
        Scene(bodies=(Body("b", Sphere(0.1), mass=1.0),), dimension=2)
    Scene(bodies=(Body("g", Plane(), static=True), Body("c", Circle(0.1), mass=1.0, position=(0, 0, 0.1))),
          dimension=2, material=Material(e=0.5))


def test_a_partial_bench_run_keeps_the_other_sections_and_says_so(tmp_path):
    import pandas as pd
    from physval.readings import bench
    bench.write(tmp_path, {"pgs": pd.DataFrame({"contacts": [1, 2], "ms per sweep": [0.1, 0.2]})})
    bench.write(tmp_path, {"overhead": pd.DataFrame({"engine": ["x"], "recorded / bare": [1.2]})})
    md = (tmp_path / "bench.md").read_text()
    assert "## overhead" in md and "## pgs" in md
    assert "From an earlier `physval bench pgs`" in md and "From an earlier `physval bench overhead`" not in md


def test_bench_md_prints_a_missing_figure_as_an_empty_cell_and_a_long_note_by_its_first_clauses(tmp_path):
    """bench.md (bench.write): an engine with no time on a scene has empty cells there, not
    "nan", in the section written now and in one kept from an earlier run's CSV; a long
    reason (first_clause) is cut after whole clauses, never inside a word."""
    import math
    import re

    import pandas as pd
    from physval.readings import bench
    from physval.report import first_clause
    reason = ("formulation 'acceleration_lcp': friction asked: the acceleration-level LCP of note 001 gives normal "
              "forces only (the slides compute friction separately)")
    assert first_clause(reason) == "formulation 'acceleration_lcp': friction asked …"
    assert first_clause("the case reads contact forces, which this engine does not report") == \
        "the case reads contact forces, which this engine does not report", "short: whole"
    assert first_clause("x" * 120) == "x" * 120, "no clause to cut at: whole"
    step = pd.DataFrame({"engine": ["mujoco", "reference-force"], "5-box stack us/step": [14.35391, math.nan],
                         "5-box stack / mujoco": [1.0, math.nan],
                         "no time because": [math.nan, f"5-box stack: unsupported: {first_clause(reason)}"]})
    bench.write(tmp_path, {"step": step})
    for written in ("now", "kept from the CSV"):
        md = (tmp_path / "bench.md").read_text()
        row = next(line for line in md.splitlines() if line.startswith("| reference-force"))
        assert not re.search(r"\bnan\b", md), written
        assert [c.strip() for c in row.strip("|").split("|")][1:3] == ["", ""], written
        assert "14.3539" in md and "friction asked …" in row, written
        bench.write(tmp_path, {"pgs": pd.DataFrame({"contacts": [1], "ms per sweep": [0.1]})})


def test_bench_narrow_times_every_catalogue_pair_on_every_routine(tmp_path):
    """`physval bench narrow`: a row per pair of the narrow-phase catalogue, a rate for the
    reference and each routine it names, and each routine's depth the pair's exact one (it
    did the query's work); the ratio to the fastest is 1 for the fastest."""
    import csv

    from cases.narrow_phase import CATALOGUE
    from physval.cli import main
    from physval.readings import bench
    engines = [e for e in ("pybullet", "mujoco") if importlib.util.find_spec(e)]
    old = bench.NARROW_QUERIES, bench.NARROW_ROUNDS
    bench.NARROW_QUERIES, bench.NARROW_ROUNDS = 3, 1  # the shape of the table, not a timing
    try:
        assert main(["bench", "narrow", "--engines", "reference", *engines, "--out", str(tmp_path), "--quiet"]) == 0
    finally:
        bench.NARROW_QUERIES, bench.NARROW_ROUNDS = old
    rows = {r["pair"]: r for r in csv.DictReader(open(tmp_path / "bench_narrow.csv"))}
    assert set(rows) == set(CATALOGUE)
    for name, row in rows.items():
        for routine in ("reference", *engines):
            assert float(row[f"{routine} queries/s"]) > 0
            assert float(row[f"{routine} depth m"]) == pytest.approx(CATALOGUE[name].depth, abs=1e-6), (name, routine)
        assert float(row["reference / fastest"]) >= 1.0 and row["within 20x"] in ("yes", "no")
    assert "## narrow" in (tmp_path / "bench.md").read_text()


def test_bench_step_says_why_an_engine_has_no_time(tmp_path):
    """An engine that cannot run a bench scene (the force formulation has no friction, which
    the stacks ask for) gets no time, and its row says why, from the run's own verdict."""
    import csv

    from physval.cli import main
    assert main(["bench", "step", "--engines", "reference", "reference-force", "--out", str(tmp_path),
                 "--quiet"]) == 0
    rows = {r["engine"]: r for r in csv.DictReader(open(tmp_path / "bench_step.csv"))}
    assert rows["reference"]["no time because"] == "" and float(rows["reference"]["5-box stack us/step"]) > 0
    assert rows["reference-force"]["5-box stack us/step"] == ""
    assert rows["reference-force"]["no time because"].startswith("5-box stack: unsupported: ")
