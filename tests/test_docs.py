"""docs/extend/writing_cases.md does what it says: its worked family passes `physval check-case`
and runs on the reference with every check passing, and its `--known` walk-through turns
the model difference a user records for MuJoCo into `deviation`, listed in the report as
the user's own."""
from __future__ import annotations

import csv

import pytest

from physval.core import deviations
from physval.cli import main
from tests.guide import write_example, write_known


def _rows(path) -> list[dict]:
    with open(path, newline="") as f:
        return list(csv.DictReader(f))


def test_the_guides_family_passes_check_case_and_every_check_on_the_reference(tmp_path, capsys):
    family = write_example(tmp_path)
    assert main(["check-case", str(family)]) == 0
    assert "family pair_drop: 4 variants (+1 with --full)" in capsys.readouterr().out
    out = tmp_path / "out"
    assert main(["run", "--cases-dir", str(family.parent), "--cases", "pair_drop", "--full", "--engines",
                 "reference", "--workers", "1", "--quiet", "--out", str(out)]) == 0
    rows = _rows(out / "results.csv")
    assert {r["variant"] for r in rows} == {"e=0.5", "e=0.9", "e=0.5,2D", "e=0.9,2D", "e=1.0"}
    assert {r["status"] for r in rows} == {"pass"}, [(r["variant"], r["metric"], r["measured"]) for r in rows]


def test_known_turns_a_users_recorded_model_difference_into_a_deviation(tmp_path):
    """MuJoCo's compliant contacts launch the light top ball higher than the simultaneous
    model's e^2 h: a difference the user expects, recorded with `physval known --file`."""
    pytest.importorskip("mujoco")
    family = write_example(tmp_path)
    cases_dir = ["--cases-dir", str(family.parent)]
    cases = [*cases_dir, "--cases", "pair_drop"]
    run = ["--workers", "1", "--quiet"]
    plain = tmp_path / "plain"
    assert main(["run", *cases, "--engines", "mujoco", *run, "--out", str(plain)]) == 0
    top = {r["variant"]: r for r in _rows(plain / "results.csv") if r["metric"] == "apex_top"}
    assert {r["status"] for r in top.values()} == {"fail"}, "without --known the difference is a failure"

    known = write_known(tmp_path)
    assert main(["known", "mujoco", "--file", str(known), *cases_dir, "--write", *run]) == 0
    (entry,) = deviations.parse(known)
    assert {(b.engine, b.variant, b.metric) for b in entry.bands} == {("mujoco", v, "apex_top") for v in top}
    for b in entry.bands:  # each band is centred on what MuJoCo measures
        assert abs(b.value - float(top[b.variant]["measured"])) <= b.width

    out = tmp_path / "known"
    assert main(["run", *cases, "--engines", "reference", "mujoco", "--known", str(known), *run,
                 "--out", str(out)]) == 0
    rows = _rows(out / "results.csv")
    assert {r["status"] for r in rows if r["engine"] == "reference"} == {"pass"}
    recorded = [r for r in rows if r["engine"] == "mujoco" and r["metric"] == "apex_top"]
    assert len(recorded) == 4 and {r["status"] for r in recorded} == {"deviation"}
    label = "expected by the user (--known my_known.txt): " + entry.reason
    assert {r["known_deviation"] for r in recorded} == {label}
    section = (out / "report.md").read_text().split("## Known deviations", 1)[1].split("\n## ", 1)[0]
    assert "[deviations.md](deviations.md)" in section  # the report counts them and links the listing
    listing = (out / "deviations.md").read_text()
    assert label in listing
    for r in recorded:  # every recorded check with its band and today's measurement
        assert f"pair_drop[{r['variant']}]:apex_top" in listing and r["band"] in listing
