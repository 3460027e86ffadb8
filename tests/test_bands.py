"""Known-deviation bands are measured, not proportional: a band is what repeating the
measurement shows plus a rounding floor, at most one tolerance of its check unless its entry
says why (`# band: WHY`), so that a move of the engine or of its mapping by more than a
tolerance is `fail` however large the deviation is."""
from __future__ import annotations

import csv
import math
import re
from pathlib import Path

import pytest

from cases.family import Check
from cases.relations import METRIC_PREFIX as INVARIANCE
from physval.cli import main
from physval.core import deviations
from physval.core.verdicts import judge

ROOT = Path(__file__).resolve().parent.parent
HISTORY = ["--adapter", f"{ROOT / 'tests' / 'fakes.py'}:HistoryFake"]  # engine fake-history
CASES = ["central_impact[e=0.5,m=1:3]", "central_impact[e=0.5,m=1:1]"]  # ballistic: the spheres pass through
QUIET = ["--workers", "1", "--quiet"]

# a check with a large known deviation: expected 1.0, the engine gives 1.5 (50 tolerances off)
CHECK = Check("v", "m/s", 1.0, 0.01, "abs", "a tolerance")


def _entry(bands=(), band_reason="", source="k.txt"):
    return deviations.Deviation(source, "fam", "*", "v", "the engine is slow", 1, tuple(bands),
                                band_reason=band_reason)


def test_a_band_is_the_repeats_spread_plus_a_floor_far_below_a_tolerance():
    value, width = deviations.band_of([1.5, 1.5], CHECK.tolerance)
    assert value == 1.5 and width == pytest.approx(deviations.FLOOR_OF_TOLERANCE * CHECK.tolerance)
    value, width = deviations.band_of([1.5, 1.503, 1.501], CHECK.tolerance)  # a spread of 0.3 tolerances
    assert value == pytest.approx(1.5015) and width >= 0.0015 + 1e-4 and width == pytest.approx(0.0016, rel=1e-2)
    # the floor survives rounding where the tolerance is tiny beside the value: 1e-9 of it
    assert deviations.rounding_floor(1e3, 1e-12) == pytest.approx(1e-6)
    for w in (0.0012345, 0.00999999, 3.0, 1e-17):  # written to 3 digits, never narrower than measured
        assert deviations.round_up(w) >= w and float(f"{deviations.round_up(w):.3g}") == deviations.round_up(w)


def test_a_move_of_two_tolerances_of_a_recorded_check_is_a_fail():
    """The 5 %-of-the-deviation band this rule replaces was 0.025 wide here: it hid 2.5 tolerances."""
    value, width = deviations.band_of([1.5, 1.5], CHECK.tolerance)
    entry = _entry([deviations.Band("eng", "a", "v", value, width)])
    assert judge(CHECK, 1.5, "eng", "a", entry)["status"] == "deviation"
    moved = judge(CHECK, 1.5 + 2 * CHECK.tolerance, "eng", "a", entry)
    assert moved["status"] == "fail" and moved["reason"].startswith("known deviation changed: recorded 1.5 +- ")


def test_a_band_wider_than_a_tolerance_needs_a_written_reason(tmp_path):
    path = tmp_path / "eng.txt"
    path.write_text("fam[*]:v  # the engine is slow\n    eng [a]:v = 1.5 +- 0.03\n")
    (entry,) = deviations.parse(path)
    row = judge(CHECK, 1.51, "eng", "a", entry)
    assert row["status"] == "fail" and "eng.txt:2) is 3 tolerances wide" in row["reason"]
    assert "fam[*]:v (eng.txt:1) gives no reason" in row["reason"] and "# band: WHY" in row["reason"]
    assert judge(CHECK, 1.6, "eng", "a", entry)["reason"].startswith("known deviation changed")

    path.write_text("fam[*]:v  # the engine is slow\n    # band: the engine's history: a world built where the last "
                    "was freed\n    eng [a]:v = 1.5 +- 0.03\n")
    (entry,) = deviations.parse(path)
    assert entry.band_reason == "the engine's history: a world built where the last was freed"
    assert judge(CHECK, 1.51, "eng", "a", entry)["status"] == "deviation"
    # at one tolerance (within the rounding of a width written to 3 digits) no reason is needed
    assert judge(CHECK, 1.51, "eng", "a", _entry([deviations.Band("eng", "a", "v", 1.5, 0.0101)]))["status"] \
        == "deviation"


def test_a_band_reason_line_belongs_to_an_entry_and_stays_under_it(tmp_path):
    path = tmp_path / "eng.txt"
    path.write_text("# band: nothing above\nfam[*]:v  # cause\n")
    with pytest.raises(deviations.DeviationFileError, match="eng.txt:1: a '# band: WHY' line"):
        deviations.parse(path)
    path.write_text("# head\nfam[*]:v  # cause\n    eng [a]:v = 1 +- 0.1\n    # band: why it is wide\n"
                    "    eng [b]:v = 2 +- 0.1\n")
    (entry,) = deviations.parse(path)
    text = deviations.rewrite(path, {entry.line: [deviations.Band("eng", "a", "v", 1.25, 0.02)]})
    assert text == "# head\nfam[*]:v  # cause\n    # band: why it is wide\n    eng [a]:v = 1.25 +- 0.02\n"


def _row(variant, value, status="fail", metric="v"):
    return {"case": "fam", "variant": variant, "metric": metric, "expected": 1.0, "measured": value,
            "tolerance": CHECK.tolerance, "tolerance_kind": "abs", "status": status}


def test_repeats_that_spread_widen_the_band_and_repeats_that_disagree_on_raising_record_none():
    entries = [_entry()]
    first = ({"j1": [_row("a", 1.5)], "j2": [_row("b", 1.2, "error")]}, {"j2": "RuntimeError"})
    second = ({"j1": [_row("a", 1.54)], "j2": [_row("b", 1.2)]}, {})
    measured = deviations.measured_bands("eng", entries, [first, second])
    (band,) = measured.bands[1]
    assert band.value == pytest.approx(1.52) and band.width == pytest.approx(0.02 + 1e-4, rel=1e-2)
    ((_, wide, why),) = measured.too_wide(entries)  # 2 tolerances, and the entry gives no reason
    assert wide is band and "is 2.01 tolerances wide" in why
    assert len(measured.unsteady) == 1 and "RuntimeError, nothing" in measured.unsteady[0]
    same = ({"j2": [_row("b", math.nan, "error")]}, {"j2": "RuntimeError"})
    (raised,) = deviations.measured_bands("eng", entries, [same, same]).bands[1]
    assert raised.raises == "RuntimeError"


def test_a_repeat_that_gave_no_value_records_no_band_and_says_so():
    """A worker that died (no exception, an error row with no value) in one repeat left MJX's
    check without a band and without a word, and the next run failed on it."""
    died = {"case": "fam", "variant": "c", "metric": "v", "expected": 1.0, "measured": math.nan,
            "tolerance": CHECK.tolerance, "tolerance_kind": "abs", "status": "error",
            "reason": "the worker process running this job died: killed by signal SIGSEGV (11)"}
    first, second = ({"j3": [_row("c", 1.5)]}, {}), ({"j3": [died]}, {})
    measured = deviations.measured_bands("eng", [_entry()], [first, second])
    assert measured.bands[1] == [] and len(measured.unsteady) == 1
    assert "1 of 2 repeats gave no value (error: the worker process running this job died" in measured.unsteady[0]


def _rows(out: Path) -> dict:
    with open(out / "results.csv", newline="") as f:
        return {(r["variant"], r["metric"]): r for r in csv.DictReader(f)}


def test_known_measures_twice_in_another_order_and_asks_for_a_reason_where_history_spreads(tmp_path, capsys):
    """An engine with a history (each scene a process builds starts 1e-7 faster): the second
    repeat runs the jobs in the reverse order, each variant's values differ, and the band
    covers both. Momentum, judged to 1e-9, spreads 10 tolerances: its check fails, naming the
    band's line, until a `# band:` line under the entry says why."""
    known = tmp_path / "known.txt"
    known.write_text("fake-history central_impact[e=0.5,m=1:*]:*  # the fake engine lets the spheres pass through\n")
    measure = ["known", "fake-history", "--file", str(known), "--cases", *CASES, *HISTORY, *QUIET,
               "--out", str(tmp_path / "m"), "--write"]
    assert main(measure) == 0
    said = capsys.readouterr().out
    assert "momentum_after = " in said and "tolerances wide over 2 repeats" in said and "# band: WHY" in said
    first, second = (_rows_of(tmp_path / "m" / name) for name in ("known-fake-history.csv",
                                                                    "known-fake-history.repeat1.csv"))
    (entry,) = deviations.parse(known)
    band = entry.band("fake-history", "e=0.5,m=1:3", "v1_after")
    a, b = float(first["e=0.5,m=1:3", "v1_after"]["measured"]), float(second["e=0.5,m=1:3", "v1_after"]["measured"])
    assert a != b and band.value == pytest.approx((a + b) / 2, abs=1e-15) and band.width >= abs(a - b) / 2

    run = ["run", "--engines", "fake-history", "--cases", *CASES, "--known", str(known), *HISTORY, *QUIET,
           "--readings", "none"]
    assert main([*run, "--out", str(tmp_path / "a")]) == 0
    rows = _rows(tmp_path / "a")
    assert rows["e=0.5,m=1:3", "v1_after"]["status"] == "deviation"
    wide = rows["e=0.5,m=1:3", "momentum_after"]
    line = entry.band("fake-history", "e=0.5,m=1:3", "momentum_after").line
    assert wide["status"] == "fail" and f"(known.txt:{line}) is " in wide["reason"] and "gives no reason" in wide["reason"]

    text = known.read_text().splitlines()
    known.write_text("\n".join(text[:1] + ["    # band: the fake engine's history: each scene starts faster"]
                               + text[1:]) + "\n")
    assert main([*run, "--out", str(tmp_path / "b")]) == 0
    assert {r["status"] for r in _rows(tmp_path / "b").values()} <= {"deviation", "pass"}
    assert main(measure) == 0  # measuring again keeps the reason under its entry
    assert known.read_text().splitlines()[1] == "    # band: the fake engine's history: each scene starts faster"
    capsys.readouterr()


def _rows_of(path: Path) -> dict:
    with open(path, newline="") as f:
        return {(r["variant"], r["metric"]): r for r in csv.DictReader(f)}


PLANTED = """
from dataclasses import replace

from adapters.planting import Fault, Planted
from adapters.registry import get


class StrongGravity(Fault):
    name = "strong gravity"

    def scene(self, scene, capabilities):
        return replace(scene, gravity=tuple(1.01 * g for g in scene.gravity))


def renamed():
    return Planted(get("reference-lemke"), StrongGravity(), name="lemke-strong-gravity")
"""


def test_known_will_not_write_a_planted_engines_bands_into_the_file_of_the_engine_it_wraps(tmp_path, capsys):
    """A planted engine is judged by the bands of the engine it wraps: `known --write` would
    put the planted engine's bands into that engine's shipped file. It stops first, one line
    naming --file, and the shipped file is untouched; with --file the bands go there."""
    (tmp_path / "my_faults.py").write_text(PLANTED)
    from adapters import registry
    shipped = Path(registry.get("reference-lemke").deviations_file())
    before = shipped.read_bytes()
    args = ["known", "--adapter", f"{tmp_path / 'my_faults.py'}:renamed", "lemke-strong-gravity",
            "--cases", "conformance", "--out", str(tmp_path / "m"), "--quiet", "--write"]
    assert main(args) == 2
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1 and "judged by the bands of reference-lemke" in err and "--file" in err
    assert shipped.read_bytes() == before and not (tmp_path / "m").exists()


def test_known_rewrites_bands_where_they_stand_in_the_file(tmp_path):
    """Measured again, an entry's bands keep the order the file gives them (a re-measured
    file differs only where a band does), whatever order the measurement found them in."""
    known = tmp_path / "known.txt"
    known.write_text("fake-history central_impact[e=0.5,m=1:*]:*  # the fake engine lets the spheres pass through\n"
                     "    # band: the fake engine's history: each scene starts faster\n")
    measure = ["known", "fake-history", "--file", str(known), "--cases", *CASES, *HISTORY, *QUIET, "--write"]
    assert main([*measure, "--out", str(tmp_path / "m1")]) == 0
    head, *bands = known.read_text().splitlines()[:1], *known.read_text().splitlines()[1:]
    reason, bands = bands[0], bands[1:]
    assert len(bands) > 2
    shuffled = bands[::-1]
    known.write_text("\n".join([*head, reason, *shuffled]) + "\n")
    assert main([*measure, "--out", str(tmp_path / "m2")]) == 0
    again = known.read_text().splitlines()[2:]
    key = lambda line: line.rsplit(" = ", 1)[0]
    assert [key(b) for b in again] == [key(b) for b in shuffled]


def test_known_writes_nothing_into_a_file_edited_while_it_measured(tmp_path, monkeypatch, capsys):
    """`known --write` puts each entry's bands under the line it read the entry at: a line
    added above while the jobs ran would put them under another entry (13 lines off, seen on
    MJX's file). It writes nothing then, says so on one line with exit 1, and the same
    command again writes from the stored rows, under the entry."""
    from physval.commands import known as command
    known = tmp_path / "known.txt"
    entry = ("fake-history central_impact[e=0.5,m=1:*]:*  # the fake engine lets the spheres pass through\n"
             "    # band: the fake engine's history: each scene starts faster\n")
    known.write_text(entry)
    measured = command.run_stored

    def edited_beside(*args, **kwargs):
        out = measured(*args, **kwargs)
        if not known.read_text().startswith("#"):
            known.write_text("# a line added while the jobs ran\n" + known.read_text())
        return out
    monkeypatch.setattr(command, "run_stored", edited_beside)
    measure = ["known", "fake-history", "--file", str(known), "--cases", *CASES, *HISTORY, *QUIET, "--write",
               "--out", str(tmp_path / "m")]
    assert main(measure) == 1
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "changed while fake-history was measured: nothing written" in err[0]
    assert known.read_text() == "# a line added while the jobs ran\n" + entry
    monkeypatch.undo()
    assert main(measure) == 0
    lines = known.read_text().splitlines()
    assert lines[:3] == ["# a line added while the jobs ran", *entry.splitlines()]
    assert len(lines) > 3 and all(b.startswith("    fake-history [") for b in lines[3:])


# --- the release a file's bands were measured on ------------------------------------------

def test_every_engine_file_but_the_references_names_the_release_it_was_measured_on():
    for path in sorted((ROOT / "adapters" / "xfails").glob("*.txt")):
        recorded = deviations.measured_on(path)
        assert (recorded is None) == path.stem.startswith("reference"), f"{path.name}: {recorded}"


@pytest.mark.parametrize("name", ["drake", "dart", "mujoco", "pymunk", "box2d"])
def test_the_recorded_releases_are_of_the_adapters_package_and_in_its_supported_range(name):
    from packaging.specifiers import SpecifierSet

    from adapters import registry
    try:
        adapter = registry.get(name)
    except registry.EngineError as exc:
        pytest.skip(str(exc))
    package, releases = deviations.measured_releases(adapter.deviations_file())
    assert package == adapter.package and all(r in SpecifierSet(adapter.supported) for r in releases), releases


def test_a_run_on_another_release_is_named_and_the_same_release_is_not():
    drake = ("drake", "1.51.1")
    assert deviations.other_release(drake, "1.58.0") == "bands measured on drake 1.51.1, this run 1.58.0"
    assert deviations.other_release(drake, "1.51.1") is None
    assert deviations.other_release(drake, "1.51.10") is not None  # a release, not a prefix of one
    # version strings that carry more than the release (Box2D's, Pymunk's) still name it
    assert deviations.other_release(("pyb2d3", "0.11.1"), "pyb2d3 0.11.1") is None
    assert deviations.other_release(("pymunk", "7.3.1"), "7.3.1 (Munk2D 2.0.1-ade7ed7)") is None
    assert deviations.other_release(None, "1.58.0") is None and deviations.other_release(drake, "unknown") is None


def test_the_measured_on_line_is_replaced_or_put_first_and_parses_as_a_comment(tmp_path):
    path = tmp_path / "eng.txt"
    body = "# what the file holds\nfam[*]:v  # the engine is slow\n    eng [a]:v = 1.5 +- 0.01\n"
    path.write_text(deviations.with_measured_on(body, "eng", "1.0"))
    assert path.read_text().splitlines()[0] == "# measured-on: eng 1.0"
    path.write_text(deviations.with_measured_on(path.read_text(), "eng", "2.0"))
    assert path.read_text().count("measured-on") == 1 and deviations.measured_on(path) == ("eng", "2.0")
    (entry,) = deviations.parse(path)
    assert len(entry.bands) == 1 and deviations.rewrite(path, {}) == path.read_text()


def test_a_further_release_has_band_lines_of_its_own_where_it_differs(tmp_path):
    """`# measured-on: eng 1.0, 2.0`: plain band lines hold for 1.0; 2.0 was measured too, and
    its lines (`eng@2.0`) replace the plain band of their check on 2.0, or remove it where the
    check `passes` there. A release the header does not list judges by the plain bands, with
    the note that says so; a line naming an unlisted release, or `passes` on a plain line,
    does not parse."""
    path = tmp_path / "eng.txt"
    path.write_text("# measured-on: eng 1.0, 2.0\nfam[*]:v  # the engine is slow\n"
                    "    eng [a]:v = 1.5 +- 0.01\n    eng [b]:v = 1.6 +- 0.013323\n    eng [c]:v = 1.7 +- 0.01\n"
                    "    eng@2.0 [a]:v = 1.4 +- 0.01\n    eng@2.0 [c]:v = passes\n")
    assert deviations.measured_releases(path) == ("eng", ("1.0", "2.0"))
    assert deviations.measured_on(path) == ("eng", "1.0")
    (entry,) = deviations.parse(path)
    values = lambda e: {b.variant: b.value for b in e.bands}
    assert values(entry.on_release("1.0")) == values(entry.on_release(None)) == {"a": 1.5, "b": 1.6, "c": 1.7}
    assert values(entry.on_release("2.0")) == {"a": 1.4, "b": 1.6}
    # what 1.0 leaves out is 2.0's (an entry of 2.0's checks alone is not stale on 1.0)
    assert entry.on_release("1.0").other_releases == ("2.0",) and entry.on_release("2.0").other_releases == ()
    note = deviations.other_release(("eng", ("1.0", "2.0")), "3.0")
    assert note == "bands measured on eng 1.0 and 2.0, this run 3.0"
    assert deviations.other_release(("eng", ("1.0", "2.0")), "2.0") is None
    on_3 = entry.on_release("3.0", note)
    assert values(on_3) == {"a": 1.5, "b": 1.6, "c": 1.7}
    moved = judge(CHECK, 1.55, "eng", "a", on_3)
    assert moved["status"] == "fail" and moved["reason"].startswith(deviations.CHANGED) and note in moved["reason"]
    assert judge(CHECK, 1.5, "eng", "a", on_3)["status"] == "deviation"
    assert judge(CHECK, 1.0, "eng", "c", entry.on_release("2.0"))["status"] == "pass"
    # written back as they were: release lines, and a width of more digits than `known` writes
    assert deviations.rewrite(path, {}) == deviations.rewrite(path, {2: list(entry.bands)}) == path.read_text()
    for header, line in (("# measured-on: eng 1.0", "    eng@2.0 [a]:v = 1.4 +- 0.01"),
                         ("# measured-on: eng 1.0, 2.0", "    eng@1.0 [a]:v = 1.4 +- 0.01"),
                         ("# measured-on: eng 1.0, 2.0", "    eng [a]:v = passes")):
        path.write_text(f"{header}\nfam[*]:v  # the engine is slow\n{line}\n")
        with pytest.raises(deviations.DeviationFileError, match="eng.txt:3"):
            deviations.parse(path)


RELEASED = """
import numpy

from tests.fakes import FakeAdapter


class ReleaseFake(FakeAdapter):
    package, supported = "numpy", ">=1"  # a package installed everywhere stands for the engine's

    def __init__(self):
        super().__init__("fake-release")

    def version(self):
        return numpy.__version__
"""


def test_known_writes_a_further_releases_own_lines_and_a_run_on_it_judges_by_them(tmp_path, capsys):
    """A plug-in engine whose file lists its installed release after another: `known --write`
    writes that release's own lines only where its measurement leaves the plain band (here
    one plain band moved by hand, as another release would have measured it), a run on it
    gives deviations, no fail; with the release left out of the header the moved check
    fails, and its reason says which releases the bands were measured on."""
    from importlib import metadata
    release = metadata.version("numpy")
    (tmp_path / "xfails").mkdir()
    (tmp_path / "release_fake.py").write_text(RELEASED)
    adapter = ["--adapter", f"{tmp_path / 'release_fake.py'}:ReleaseFake"]
    known = tmp_path / "xfails" / "fake-release.txt"
    entry = "central_impact[e=0.5,m=1:*]:*  # the fake engine lets the spheres pass through\n"
    known.write_text(f"# measured-on: numpy 0.1\n{entry}")
    measure = ["known", "fake-release", "--cases", *CASES, *adapter, *QUIET, "--write"]
    assert main([*measure, "--out", str(tmp_path / "m1")]) == 0  # only --cases: the plain lines, the header stays
    assert "keeps its '# measured-on:' line" in capsys.readouterr().out
    header, families, cause, *plain = known.read_text().splitlines()
    assert header == "# measured-on: numpy 0.1" and families == "# families-measured: central_impact"
    assert len(plain) > 2 and "@" not in "".join(plain)
    first = plain[0].split(" = ")
    moved = f"{first[0]} = {float(first[1].split()[0]) + 1.0!r} +- {first[1].split('+- ')[1]}"
    known.write_text("\n".join([f"# measured-on: numpy 0.1, {release}", families, cause, moved, *plain[1:]]) + "\n")
    assert main([*measure, "--out", str(tmp_path / "m2")]) == 0
    lines = known.read_text().splitlines()
    assert lines[:len(plain) + 3] == [f"# measured-on: numpy 0.1, {release}", families, cause, moved, *plain[1:]]
    assert lines[len(plain) + 3:] == [plain[0].replace("fake-release ", f"fake-release@{release} ", 1)]

    run = ["run", "--engines", "fake-release", "--cases", *CASES, *adapter, *QUIET, "--readings", "none"]
    assert main([*run, "--out", str(tmp_path / "a")]) == 0
    assert {r["status"] for r in _rows(tmp_path / "a").values()} <= {"deviation", "pass"}
    known.write_text("\n".join(["# measured-on: numpy 0.1", families, cause, moved, *plain[1:]]) + "\n")
    assert main([*run, "--out", str(tmp_path / "b")]) == 0
    failed = [r for r in _rows(tmp_path / "b").values() if r["status"] == "fail"]
    assert len(failed) == 1 and failed[0]["reason"].startswith(deviations.CHANGED)
    assert failed[0]["reason"].endswith(f"; bands measured on numpy 0.1, this run {release}")
    capsys.readouterr()


def test_the_report_says_which_engines_ran_another_release_than_their_bands(tmp_path):
    from physval.readings.site import engine_page
    from tests.test_harness import _rows, _write_report
    note = "bands measured on fake 0.9, this run 1.0"
    flagged, same = tmp_path / "flagged", tmp_path / "same"
    for out in (flagged, same):
        out.mkdir()
    _write_report(_rows(), flagged, releases={"fake": note})
    report = (flagged / "report.md").read_text()
    assert f"fake ({note})" in report.split("## ")[0]  # under the opening count
    assert f"- fake: {note}" in report  # in Known deviations
    assert note in (flagged / engine_page("fake")).read_text()
    _write_report(_rows(), same)
    assert "another release" not in (same / "report.md").read_text()
    assert "bands measured on" not in (same / engine_page("fake")).read_text()


def test_known_writes_the_release_of_the_engines_package_and_none_for_the_reference():
    from importlib import metadata

    from adapters.registry import installed_release as _release
    from tests.fakes import FakeAdapter
    adapter = FakeAdapter()
    adapter.package, adapter.supported = "numpy", ">=1"
    assert _release(adapter) == metadata.version("numpy")
    adapter.package = "no-such-engine-package"
    assert _release(adapter) is None
    adapter.package, adapter.supported = "physval", None  # the reference: part of physval
    assert _release(adapter) is None


# --- a configuration that inherits its engine's entries (`inherit: ENGINE`) ------------------

def test_a_configuration_inherits_its_engines_entries_and_bands_off_its_default_families(tmp_path):
    """`inherit: eng` in eng-ccd.txt: eng's entries that apply to eng, with eng's bands as
    eng-ccd's, on the families `outside` accepts, after eng-ccd's own; their cause says
    whose they are and their re-measuring command names eng. The line parses as no entry,
    stays where it is when bands are rewritten, and names one file beside it that does not
    inherit in turn."""
    (tmp_path / "eng.txt").write_text(
        "fam[*]:v  # the engine is slow\n    eng [a]:v = 1.5 +- 0.01\n    other [a]:v = 1.4 +- 0.01\n"
        "swept[*]:v  # it tunnels\n    eng [a]:v = 1.0 +- 0.01\n"
        "other fam[*]:w  # another engine's\n    other [a]:w = 2.0 +- 0.01\n")
    mine = tmp_path / "eng-ccd.txt"
    mine.write_text("# header\ninherit: eng  # the same values off the swept families\n"
                    "swept[*]:v  # its own\n    eng-ccd [a]:v = 0.5 +- 0.01\n")
    assert deviations.inherits(mine) == "eng" and deviations.inherits(tmp_path / "eng.txt") is None
    assert [d.pattern for d in deviations.parse(mine)] == ["swept[*]:v"]
    (entry,) = deviations.inherited(mine, "eng-ccd", lambda family: family != "swept")
    assert entry.pattern == "eng-ccd fam[*]:v" and entry.where == "eng.txt:1"
    assert [(b.engine, b.variant, b.value) for b in entry.bands] == [("eng-ccd", "a", 1.5)]
    assert entry.cause == "as eng (inherit): the engine is slow"
    assert entry.remeasure("eng-ccd") == "physval known eng --write"
    assert judge(CHECK, 1.5, "eng-ccd", "a", entry)["status"] == "deviation"
    assert deviations.rewrite(mine, {3: []}).splitlines()[:3] == [
        "# header", "inherit: eng  # the same values off the swept families", "swept[*]:v  # its own"]
    for text, says in (("inherit: eng\ninherit: eng\n", "one 'inherit: ENGINE' line"),
                       ("inherit:\n", "one 'inherit: ENGINE' line"),
                       ("inherit: nothing\n", "names no file beside it (nothing.txt)")):
        mine.write_text(text)
        with pytest.raises(deviations.DeviationFileError, match=re.escape(says)):
            deviations.parse(mine)
            deviations.inherited(mine, "eng-ccd", lambda family: True)
    (tmp_path / "eng.txt").write_text("inherit: eng-ccd\n")
    mine.write_text("inherit: eng\n")
    with pytest.raises(deviations.DeviationFileError, match="eng.txt inherits in turn"):
        deviations.inherited(mine, "eng-ccd", lambda family: True)


def _inheriting() -> list[str]:
    """The registry's configurations whose deviation file has an `inherit:` line."""
    from adapters import registry
    out = []
    for name in registry.engine_names():
        try:
            path = registry.get(name).deviations_file()
        except registry.EngineError:
            continue
        if deviations.inherits(path):
            out.append(name)
    return out


@pytest.mark.parametrize("engine", _inheriting())
def test_an_inheriting_configuration_gives_its_engines_values_on_a_sample_of_the_inherited_checks(engine):
    """`inherit:` is valid only where the configuration computes what its engine does: on a
    sample of the checks it inherits (the first band of each of the first entries off its
    default families, where its option never engages), both configurations' rows measure
    the same values, bit for bit; and its default families inherit nothing."""
    from physval.core import Context, Job
    from tests.helpers import shared_rows
    resolver = Context().resolver()
    adapter = resolver.adapter(engine)
    source = deviations.inherits(adapter.deviations_file())
    inherited = [d for d in resolver.known(engine) if d.inherited_from == source]
    assert inherited and source in resolver.deviation_files(engine)[1].stem
    assert not any(resolver.family(d.family).tags & adapter.default_tags for d in inherited)
    sample = []
    for d in inherited:
        band = next((b for b in d.bands if not b.metric.startswith(INVARIANCE)), None)
        if band is not None and (d.family, band.variant) not in sample:
            sample.append((d.family, band.variant))
        if len(sample) == 3:
            break
    assert sample, f"{engine}: no inherited band of a family check"
    for family, variant in sample:
        v = next(v for v in resolver.family(family).variants if v.id == variant)
        mine, theirs = (shared_rows(Job(family, v, e)) for e in (engine, source))
        values = lambda rows: {r["metric"]: str(r["measured"]) for r in rows}  # noqa: E731 (nan as nan)
        assert values(mine) == values(theirs), f"{family}[{variant}]: {engine} and {source} measure differently"


# --- a configuration that runs some families unless named: measured on every family -----------

def _named_only():
    """Installed configurations whose default run leaves families out (Adapter.default_tags)
    and whose own file records their deviations (not `inherit:`): a run that names them meets
    the other families, judged only by their own file."""
    from adapters import registry
    out = []
    for name in registry.engine_names():
        try:
            adapter = registry.get(name)
            path = adapter.deviations_file()
        except registry.EngineError:
            continue
        if adapter.default_tags is not None and path is not None and not deviations.inherits(path):
            out.append(name)
    return out


@pytest.mark.parametrize("engine", _named_only())
def test_a_configuration_run_by_name_was_measured_on_every_family_it_can_represent(engine):
    """A default run gives such a configuration its default families only, so a family added
    since its bands were measured meets it first in a named run (`physval run --engines
    drake-sap`, with --on-demand for a configuration whose every run waits for it, as MJX's),
    where a check that misses without an entry is an unexplained `fail`. Its file's
    `# families-measured:` line (written by `physval known ENGINE --write`) names the families
    it was measured on: every family it can represent in a named run must be there."""
    from cases.registry import builtin_families
    from physval.core.plan import leaves_out
    from adapters import registry
    adapter = registry.get(engine)
    path = adapter.deviations_file()
    listed = deviations.families_measured(path)
    runs = {name for name, fam in builtin_families().items()
            if any(adapter.capabilities.cannot_run(scene := fam.scene(v.params), fam.needs_of(v.params)) is None
                   and leaves_out(adapter, fam.tags, scene, named=True, on_demand=True) is None
                   for v in fam.variants)}
    missing = sorted(runs - (listed or set()))
    assert listed is not None, (f"{path.name} has no '# families-measured:' line: `physval known {engine} "
                                "--on-demand --write` measures the families and records them")
    assert not missing, (f"{path.name}: a run naming {engine} takes {', '.join(missing)}, never measured on it: "
                         f"physval known {engine} --on-demand --write --cases {' '.join(missing)}")


def test_the_families_measured_line_joins_what_known_ran_and_parses_as_a_comment(tmp_path):
    path = tmp_path / "eng.txt"
    body = "# measured-on: eng 1.0\nfam[*]:v  # the engine is slow\n    eng [a]:v = 1.5 +- 0.01\n"
    path.write_text(deviations.with_families_measured(body, {"fam", "alpha"}))
    assert path.read_text().splitlines()[1] == "# families-measured: alpha fam"
    assert deviations.families_measured(path) == {"alpha", "fam"}
    path.write_text(deviations.with_families_measured(path.read_text(), {"alpha", "fam", "beta"}))
    assert path.read_text().count("families-measured") == 1 and deviations.families_measured(path) == {
        "alpha", "beta", "fam"}
    assert [d.pattern for d in deviations.parse(path)] == ["fam[*]:v"] and deviations.measured_on(path) == ("eng", "1.0")
    assert deviations.families_measured(tmp_path / "none.txt") is None


def test_known_leaves_out_a_configuration_a_glob_matched_that_cannot_be_made_and_stops_on_a_named_one(
        capsys, tmp_path):
    """`physval known 'drake-*' --write` on Python 3.12 (Drake 1.58, which has no TAMSI) stopped
    with exit 2 on drake-tamsi, which only the glob had matched: such a configuration is left
    out with one line, as a release outside its range is; named by its name, it still stops
    the command before any work. Genesis' configurations stand in (not installed here)."""
    from adapters import registry
    if registry.available("genesis"):
        pytest.skip("Genesis is installed here: no configuration to leave out")
    assert main(["known", "genesis*", "--out", str(tmp_path / "glob")]) == 0
    err = capsys.readouterr().err
    assert "physval: genesis left out: engine 'genesis' is not installed" in err
    assert "physval: genesis-defaults left out:" in err
    assert main(["known", "genesis", "--out", str(tmp_path / "named")]) == 2
    assert "physval: error: engine 'genesis' is not installed" in capsys.readouterr().err
