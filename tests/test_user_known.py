"""A user's `--known FILE`: an entry may be limited to engines (an engine glob before the
pattern), names that do not exist and files that are not text stop the run with one line
(exit 2), and the report's hint for an entry without bands is the command that measures
them into the file the entry came from."""
from __future__ import annotations

import csv
import shlex
from pathlib import Path

import pytest

from physval.cli import main

ROOT = Path(__file__).resolve().parent.parent
FAKES = f"{ROOT / 'tests' / 'fakes.py'}"
ADAPTERS = ["--adapter", f"{FAKES}:FakeAdapter", "--adapter", f"{FAKES}:OtherFake"]  # engines fake and fake-2
CASE = "central_impact[e=0.5,m=1:3]"  # ballistic fakes let the bodies pass through: v1_after fails on both
QUIET = ["--workers", "1", "--quiet"]


def _rows(out: Path) -> dict:
    with open(out / "results.csv", newline="") as f:
        return {(r["engine"], r["metric"]): r for r in csv.DictReader(f)}


def _stale_notes(out: Path) -> list[str]:
    report = (out / "report.md").read_text()
    if "Entries that no longer deviate or match nothing:" not in report:
        return []
    section = report.split("Entries that no longer deviate or match nothing:", 1)[1].split("\n## ", 1)[0]
    return [line[2:] for line in section.splitlines() if line.startswith("- ")]


def test_an_entry_for_one_engine_covers_that_engine_only_and_its_hint_writes_its_own_file(tmp_path, capsys):
    known = tmp_path / "my_known.txt"
    known.write_text("fake central_impact[e=0.5,m=1:*]:v1_after  # the fake engine lets bodies pass through\n")
    run = ["run", *ADAPTERS, "--engines", "fake", "fake-2", "--cases", CASE, "--known", str(known), *QUIET]

    assert main([*run, "--out", str(tmp_path / "a")]) == 0
    rows = _rows(tmp_path / "a")
    assert rows["fake-2", "v1_after"]["status"] == "fail" and rows["fake-2", "v1_after"]["known_deviation"] == ""
    assert "known deviation" not in rows["fake-2", "v1_after"]["reason"]
    mine = rows["fake", "v1_after"]
    assert mine["status"] == "fail" and "no band is recorded for this check on fake" in mine["reason"]
    (note,) = _stale_notes(tmp_path / "a")  # none for fake-2: the entry is not fake-2's
    hint = note.split("`")[-2]
    assert note.startswith("fake: `fake central_impact") and hint == mine["reason"].split("`")[-2]
    words = shlex.split(hint)
    assert words[:5] == ["physval", "known", "fake", "--file", str(known)] and words[-1] == "--write"

    assert main([*words[1:], *QUIET, "--out", str(tmp_path / "measured")]) == 0  # the hint, as given
    assert f"    fake [{CASE[15:-1]}]:v1_after = " in known.read_text()  # written into the user's own file

    assert main([*run, "--out", str(tmp_path / "b")]) == 0
    rows = _rows(tmp_path / "b")
    assert rows["fake", "v1_after"]["status"] == "deviation"
    assert rows["fake-2", "v1_after"]["status"] == "fail" and rows["fake-2", "v1_after"]["known_deviation"] == ""
    assert _stale_notes(tmp_path / "b") == []
    capsys.readouterr()


@pytest.mark.parametrize("text,message", [
    (b"central_impakt[*]:v1_after  # a cause\n", ":1: no family 'central_impakt' (families: bounce_series, "),
    (b"havok central_impact[*]:v1_after  # a cause\n",
     ":1: engine 'havok' matches no engine (engines: reference, "),
    (b"central_impact[*]:v1_after  # a cause\n    havok [e=0.5,m=1:3]:v1_after = 1.0 +- 0.1\n",
     ":2: no engine 'havok' (engines: reference, "),
    (b"mujoco central_impact[*]:v1_after  # a cause\n    pybullet [e=0.5,m=1:3]:v1_after = 1.0 +- 0.1\n",
     ":2: engine 'pybullet' is not one of its entry's engines 'mujoco'"),
    (b"central_impact[*]:v1_after  # caf\xe9 au lait\n",
     ": not UTF-8 text (byte 0xe9 at offset 33); a known-deviation file is UTF-8 text"),
])
def test_a_known_file_naming_what_does_not_exist_or_not_text_is_one_line(text, message, tmp_path, capsys):
    known = tmp_path / "k.txt"
    known.write_bytes(text)
    code = main(["run", "--cases", CASE, "--engines", "reference", "--known", str(known), *QUIET,
                 "--out", str(tmp_path / "out")])
    err = capsys.readouterr().err
    assert code == 2 and err.startswith(f"physval: error: --known {known}{message}"), err
    assert len(err.strip().splitlines()) == 1 and "Traceback" not in err
    assert not (tmp_path / "out" / "results.csv").exists()


def test_an_entry_for_variants_this_run_left_out_is_not_stale(tmp_path):
    """The report lists an entry as matching nothing only when no variant of its family
    could match it, not when its variants lie in a full grid this run did not run."""
    from physval.cli import main
    known = tmp_path / "known.txt"
    known.write_text("central_impact[drop,e=0.9,2D]:rebound_ratio  # a variant of the default grid, not run here\n"
                     "central_impact[no such variant]:rebound_ratio  # matches no variant at all\n")
    out = tmp_path / "out"
    assert main(["run", "--cases", "central_impact[drop,e=0.5]", "--engines", "reference", "--known", str(known),
                 "--quiet", "--readings", "none", "--out", str(out)]) == 0
    section = (out / "report.md").read_text().split("## Known deviations", 1)[1].split("\n## ", 1)[0]
    assert "`central_impact[no such variant]:rebound_ratio` (known.txt:2) matched no check" in section
    assert "e=0.9,2D" not in section


def test_a_known_deviation_that_vanished_has_its_own_listing_in_the_report(tmp_path):
    """A band recorded where the reference meets the closed form: the report names the vanished
    deviation under the run's summary line, links its section, and lists the check there."""
    known = tmp_path / "known.txt"
    known.write_text("central_impact[drop,e=0.5]:rebound_ratio  # a band planted for this test\n"
                     "    reference [drop,e=0.5]:rebound_ratio = 0.3 +- 0.001\n")
    out = tmp_path / "out"
    assert main(["run", "--cases", "central_impact[drop,e=0.5]", "--engines", "reference", "--known", str(known),
                 "--quiet", "--readings", "none", "--out", str(out)]) == 0
    report = (out / "report.md").read_text()
    head, rest = report.split("## Contents", 1)
    assert "**Known deviations that vanished: 1** (their checks are back within tolerance: the engine or its " \
           "mapping changed): [known deviations that vanished](#known-deviations-that-vanished)" in head
    assert "- [Known deviations that vanished](#known-deviations-that-vanished)" in rest
    section = rest.split("\n## Known deviations that vanished\n", 1)[1].split("\n## ", 1)[0]
    assert rest.index("## Known deviations that vanished") < rest.index("\n## Summary")  # right after the scorecard
    (line,) = [x for x in section.splitlines() if x.startswith("| reference ")]
    assert "central_impact[drop,e=0.5]:rebound_ratio" in line and "0.3 +- 0.001" in line and "(known.txt:1)" in line


def _runs_now(out: str) -> tuple[int, int]:
    """(runs now, reused) from physval run's closing line."""
    line = next(x for x in out.splitlines() if " runs now, " in x)
    now, reused = line.split(" runs now, ")[0].rsplit("(", 1)[1], line.split(" runs now, ")[1].split(" reused")[0]
    return int(now), int(reused)


def test_an_edited_band_judges_the_stored_rows_again_and_steps_nothing(tmp_path, capsys, monkeypatch):
    """A known-deviation band changes verdicts, not trajectories: an edit of the file moves
    the verdict of the stored row without a job run again; a change of the code still runs
    them again (nothing stale is reported)."""
    known = tmp_path / "known.txt"
    known.write_text("")
    out = tmp_path / "out"
    run = ["run", *ADAPTERS, "--engines", "fake", "--cases", CASE, "--known", str(known), "--readings", "none",
           "--workers", "1", "--out", str(out)]
    assert main(run) == 0
    first = _rows(out)[("fake", "v1_after")]
    assert first["status"] == "fail" and _runs_now(capsys.readouterr().out)[0] > 0
    measured = float(first["measured"])
    band = f"    fake [{CASE[15:-1]}]:v1_after = {measured:.6g} +- 1e-06\n"
    known.write_text("central_impact[e=0.5,m=1:3]:v1_after  # a band planted for this test\n" + band)
    assert main(run) == 0
    now, reused = _runs_now(capsys.readouterr().out)
    moved = _rows(out)[("fake", "v1_after")]
    assert (now, moved["status"]) == (0, "deviation") and reused > 0, (now, moved["status"], moved["reason"])
    assert moved["known_deviation"].endswith("a band planted for this test") and moved["measured"] == first["measured"]
    assert moved["job_s"] == first["job_s"]  # the stored run's, not a new one's
    fresh = tmp_path / "fresh"  # the same verdicts as a run from nothing
    assert main(run[:-1] + [str(fresh)]) == 0
    capsys.readouterr()
    verdict = ("status", "reason", "known_deviation", "band", "measured", "abs_error", "rel_error", "tolerance")
    again, anew = _rows(out), _rows(fresh)
    assert {k: [r[c] for c in verdict] for k, r in again.items()} == {k: [r[c] for c in verdict] for k, r in anew.items()}

    known.write_text(known.read_text().replace(f"= {measured:.6g} +-", f"= {measured + 1:.6g} +-"))
    assert main(run) == 0
    assert _runs_now(capsys.readouterr().out)[0] == 0
    changed = _rows(out)[("fake", "v1_after")]
    assert changed["status"] == "fail" and changed["reason"].startswith("known deviation changed"), changed["reason"]

    from physval.core import store
    monkeypatch.setattr(store, "fingerprint", lambda extra=(): "0123456789abcdef")  # the code changed
    assert main(run) == 0
    now, reused = _runs_now(capsys.readouterr().out)
    assert now > 0 and reused == 0
