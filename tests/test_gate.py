"""A gate for an engine's CI: `physval run --junitxml FILE --fail-on LIST`, through the
command line. The JUnit report counts every check of results.csv; --fail-on trips (exit 1)
on exactly the categories it names."""
from __future__ import annotations

import csv
import textwrap
import xml.etree.ElementTree as ET
from pathlib import Path

import pytest

from physval.cli import main

FAKE = f"{Path(__file__).with_name('fakes.py')}:FakeAdapter"  # a ballistic engine: no contact at all
DROP = "central_impact[drop,e=0.5]"


def _run(tmp_path, *argv) -> int:
    return main(["run", "--cases", DROP, "--quiet", "--readings", "none", "--workers", "1",
                 "--out", str(tmp_path / "out"), *argv])


def _rows(tmp_path) -> list[dict]:
    return list(csv.DictReader(open(tmp_path / "out" / "results.csv")))


def test_the_junit_report_counts_every_check_and_the_gate_trips_on_fails(tmp_path, capsys):
    xml = tmp_path / "ci" / "physval.xml"
    code = _run(tmp_path, "--engines", "reference", "fake", "--adapter", FAKE, "--junitxml", str(xml),
                "--fail-on", "fail,error")
    rows = _rows(tmp_path)
    fails = [r for r in rows if r["status"] == "fail"]
    assert fails and all(r["engine"] == "fake" for r in fails)  # the ball falls through the ground
    assert code == 1 and f"{len(fails)} fail" in capsys.readouterr().err
    root = ET.parse(xml).getroot()
    cases = root.findall(".//testcase")
    assert len(cases) == len(rows) == int(root.get("tests"))
    assert int(root.get("failures")) == len(fails) == len(root.findall(".//testcase/failure"))
    failure = root.find(".//testcase/failure")
    assert "tolerance" in failure.get("message") and f"physval run --cases '{DROP}' --engines fake" in failure.text
    passing = [c for c in cases if c.get("name").endswith("-reference")]
    assert passing and all(len(c) == 0 for c in passing)


def test_without_fail_on_a_failing_run_exits_0(tmp_path):
    assert _run(tmp_path, "--engines", "fake", "--adapter", FAKE) == 0


def _known(tmp_path, engine: str, value: float) -> str:
    path = tmp_path / "known.txt"
    path.write_text(f"{DROP}:rebound_ratio  # a band recorded for this test\n"
                    f"    {engine} [drop,e=0.5]:rebound_ratio = {value} +- 0.001\n")
    return str(path)


def test_a_deviation_that_vanished_is_named_and_can_gate(tmp_path, capsys):
    """A band recorded where the reference now meets the closed form: the measurement left
    its band, so the row fails (a change of the engine or its mapping shows as a fail,
    whichever way it moved: decision 8), says why in its reason, and --fail-on vanished
    trips; a band that still holds the measurement (it straddles the tolerance) passes."""
    code = _run(tmp_path, "--engines", "reference", "--known", _known(tmp_path, "reference", 0.3),
                "--fail-on", "vanished")
    (row,) = [r for r in _rows(tmp_path) if r["metric"] == "rebound_ratio"]
    assert row["status"] == "fail" and row["reason"].startswith("known deviation vanished")
    assert "outside the band" in row["reason"]
    assert code == 1 and "1 vanished" in capsys.readouterr().err
    assert _run(tmp_path, "--engines", "reference", "--known", _known(tmp_path, "reference", 0.3),
                "--fail-on", "fail") == 1
    assert _run(tmp_path, "--engines", "reference", "--known", _known(tmp_path, "reference", 0.5),
                "--fail-on", "fail") == 0
    (row,) = [r for r in _rows(tmp_path) if r["metric"] == "rebound_ratio"]
    assert row["status"] == "pass" and row["reason"].startswith("known deviation vanished")


def test_a_deviation_that_left_its_band_is_a_changed_fail(tmp_path):
    code = _run(tmp_path, "--engines", "fake", "--adapter", FAKE, "--known", _known(tmp_path, "fake", 0.3),
                "--fail-on", "changed")
    (row,) = [r for r in _rows(tmp_path) if r["metric"] == "rebound_ratio"]
    assert row["status"] == "fail" and row["reason"].startswith("known deviation changed")
    assert code == 1


@pytest.mark.parametrize("argv, message", [
    (("--fail-on", "fails"), "--fail-on 'fails': 'fails' is not one of fail, error"),
    (("--junitxml", ""), "--junitxml '': must name a file"),
    (("--junitxml", "."), "--junitxml .: is a folder"),
])
def test_bad_gate_options_stop_before_any_work(tmp_path, capsys, argv, message):
    assert _run(tmp_path, "--engines", "reference", *argv) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and message in err[0], err
    assert not (tmp_path / "out" / "results.csv").exists()


# --- the JUnit file is for any CI reader; it never replaces the run's own files (issue 33) ------

def test_bad_gate_option_that_names_nothing_stops_before_any_work(tmp_path, capsys):
    """`--fail-on ','` names no category (before: taken as no gate, in silence)."""
    assert _run(tmp_path, "--engines", "reference", "--fail-on", ",") == 2
    (line,) = capsys.readouterr().err.strip().splitlines()
    assert line == "physval: error: --fail-on ',': names no category; choose from " + ", ".join(
        ["fail", "error", "unstable", "deviation", "unsupported", "changed", "vanished"])
    assert not (tmp_path / "out" / "results.csv").exists()


@pytest.mark.parametrize("name", ["results.csv", "report.html", "plots/summary.png"])
def test_a_junit_file_that_would_replace_one_of_the_runs_own_stops_before_any_work(tmp_path, capsys, name):
    """Before: accepted, and written over results.csv (or the report) after the run."""
    xml = tmp_path / "out" / name
    assert _run(tmp_path, "--engines", "reference", "--junitxml", str(xml)) == 2
    (line,) = capsys.readouterr().err.strip().splitlines()
    assert line.startswith(f"physval: error: --junitxml {xml}: inside --out {tmp_path / 'out'}, name a .xml file")
    assert not (tmp_path / "out" / "results.csv").exists()
    assert _run(tmp_path, "--engines", "reference", "--junitxml", str(tmp_path / "out" / "physval.xml")) == 0


def test_control_characters_of_an_engines_message_leave_the_junit_file_well_formed(tmp_path):
    """An engine's message in ANSI colours (ESC, which XML 1.0 forbids even as &#27;) is
    written with its escapes spelled out; a CI reader parses the file (before: not
    well-formed, and the whole file was rejected)."""
    (tmp_path / "coloured.py").write_text(textwrap.dedent("""
        from adapters.reference_engine import ReferenceAdapter

        class Coloured(ReferenceAdapter):
            def __init__(self):
                super().__init__(name="reference-coloured")

            def build(self, scene, settings):
                raise RuntimeError("\\x1b[31mcontact solver failed\\x1b[0m \\x07")
    """))
    xml = tmp_path / "physval.xml"
    assert _run(tmp_path, "--engines", "reference-coloured", "--adapter", f"{tmp_path / 'coloured.py'}:Coloured",
                "--junitxml", str(xml)) == 0
    assert all(r["status"] == "error" and "\x1b[31m" in r["reason"] for r in _rows(tmp_path))
    errors = ET.parse(xml).getroot().findall(".//testcase/error")
    assert errors and all("\\x1b[31mcontact solver failed\\x1b[0m \\x07" in e.get("message") for e in errors)
