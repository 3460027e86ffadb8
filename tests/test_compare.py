"""`physval compare A B` on two small result folders written here: what it calls a status
change, a move above and below the threshold, a check in one run only; its exit codes;
bad input in one line; and, with trajectories saved by both runs, the step where they part."""
from __future__ import annotations

import csv
import json

import numpy as np
import pandas as pd
import pytest

from physval.cli import main
from physval.core import COLUMNS
from physval.readings.divergence import PARTED


def _row(variant, metric, measured, status="pass", expected=1.0, tolerance=0.1, kind="abs", engine="mujoco"):
    row = {c: "" for c in COLUMNS}
    row.update(case="fam", variant=variant, params="{}", engine=engine, engine_version="1.0", dt=1e-3, metric=metric,
               unit="m", expected=expected, measured=measured, tolerance=tolerance, tolerance_kind=kind,
               status=status, reason="" if status == "pass" else "outside")
    return row


def _folder(path, rows):
    path.mkdir(parents=True, exist_ok=True)
    with open(path / "results.csv", "w", newline="") as fh:
        writer = csv.DictWriter(fh, COLUMNS)
        writer.writeheader()
        writer.writerows(rows)
    return path


# tolerance 0.1 (absolute): a move of 0.005 m is 0.05 tolerances (above the default 0.01), of
# 0.0005 m is 0.005 (below it)
A = [_row("v", "same", 1.01), _row("v", "status", 1.05), _row("v", "moved", 1.02), _row("v", "nudged", 1.02),
     _row("v", "relative", 2.0, expected=2.0, tolerance=0.01, kind="rel"), _row("v", "gone", 1.0),
     _row("v", "no_number", float("nan"), status="unsupported")]
B = [_row("v", "same", 1.01), _row("v", "status", 1.25, status="fail"), _row("v", "moved", 1.015),
     _row("v", "nudged", 1.0205), _row("v", "relative", 2.001, expected=2.0, tolerance=0.01, kind="rel"),
     _row("v", "new", 1.0), _row("v", "no_number", float("nan"), status="unsupported")]


@pytest.fixture
def runs(tmp_path):
    return _folder(tmp_path / "a", A), _folder(tmp_path / "b", B), tmp_path / "out"


def _table(out) -> dict:
    return {r["metric"]: r for r in csv.DictReader(open(out / "compare.csv"))}


def test_status_changes_moves_and_one_sided_checks(runs, capsys):
    a, b, out = runs
    assert main(["compare", str(a), str(b), "--out", str(out)]) == 1
    said = capsys.readouterr().out
    assert said.startswith("changed: 1 checks changed status, 2 moved by more than 0.01 tolerances, 1 in A only, "
                           "1 in B only; 1 moved less, 2 identical")
    t = _table(out)
    assert {m: r["change"] for m, r in t.items()} == {
        "same": "same", "status": "status", "moved": "moved", "nudged": "below threshold", "relative": "moved",
        "gone": "only in A", "new": "only in B", "no_number": "same"}
    assert float(t["moved"]["move"]) == pytest.approx(0.05, rel=1e-9)
    assert float(t["nudged"]["move"]) == pytest.approx(0.005, rel=1e-9)
    # a relative tolerance of 0.01 on expected 2 is 0.02 in the check's units: 0.001 is 0.05 of it
    assert float(t["relative"]["move"]) == pytest.approx(0.05, rel=1e-9)
    assert float(t["same"]["move"]) == 0.0 and float(t["no_number"]["move"]) == 0.0
    directions = (t["moved"]["direction"], t["status"]["direction"], t["relative"]["direction"])
    assert directions == ("towards", "away", "away")
    assert (out / "compare.png").stat().st_size > 10_000


def test_the_report_opens_with_the_summary_and_ranks_moves(runs):
    a, b, out = runs
    main(["compare", str(a), str(b), "--out", str(out)])
    text = (out / "compare.md").read_text()
    first_screen = "\n".join(text.splitlines()[:16])
    assert "**Something changed** (exit code 1): 1 checks changed status" in first_screen
    assert "status changes: pass -> fail: 1" in first_screen
    moves = text.split("## Largest moves")[1].split("##")[0]
    assert moves.index("fam[v]:moved") < moves.index("fam[v]:relative")  # 0.05 and 0.05: ties keep both
    assert "fam[v]:gone" in text.split("## In one run only")[1]


def test_the_threshold_decides_what_moved(runs, capsys):
    a, b, out = runs
    main(["compare", str(a), str(b), "--out", str(out), "--threshold", "0.001"])
    assert _table(out)["nudged"]["change"] == "moved"
    main(["compare", str(a), str(b), "--out", str(out), "--threshold", "0.1"])
    t = _table(out)
    assert t["moved"]["change"] == t["relative"]["change"] == "below threshold"


def test_nothing_changed_is_exit_code_0(tmp_path, capsys):
    a = _folder(tmp_path / "a", A)
    nudged = [dict(r, measured=r["measured"] + 1e-4) if r["metric"] == "moved" else r for r in A]
    b = _folder(tmp_path / "b", nudged)  # 0.001 tolerances: below the threshold
    assert main(["compare", str(a), str(a), "--out", str(tmp_path / "o1")]) == 0
    assert main(["compare", str(a), str(b), "--out", str(tmp_path / "o2")]) == 0
    assert "nothing changed: 0 checks changed status, 0 moved" in capsys.readouterr().out
    assert "**Nothing changed** (exit code 0)" in (tmp_path / "o2" / "compare.md").read_text()


def _bad(tmp_path, name: str, text: str | bytes | None):
    folder = tmp_path / name
    folder.mkdir()
    if text is not None:
        (folder / "results.csv").write_bytes(text if isinstance(text, bytes) else text.encode())
    return folder


@pytest.mark.parametrize("content, message", [
    (None, "no results.csv in this folder"),
    ("case,variant,engine,metric,status\nfam,v,mujoco,x,pass\n",
     "no column expected, measured, tolerance, tolerance_kind: not a physval results.csv"),
    (b"\x89PNG\r\n\x1a\n\x00\x00\xff\xfe", "not a CSV table"),
    ("", "not a CSV table"),
])
def test_bad_input_is_one_line_and_exit_2(tmp_path, capsys, content, message):
    good = _folder(tmp_path / "good", A)
    bad = _bad(tmp_path, "bad", content)
    out = tmp_path / "out"
    assert main(["compare", str(good), str(bad), "--out", str(out)]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and message in err[0], err
    assert not out.exists()  # stopped before writing anything


def test_a_run_that_repeats_a_check_and_a_missing_folder_are_bad_input(tmp_path, capsys):
    good = _folder(tmp_path / "good", A)
    twice = _folder(tmp_path / "twice", A + A[:1])
    assert main(["compare", str(good), str(twice), "--out", str(tmp_path / "o")]) == 2
    assert main(["compare", str(tmp_path / "nowhere"), str(good), "--out", str(tmp_path / "o")]) == 2
    assert main(["compare", str(good), str(good), "--threshold", "-1"]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert "2 rows repeat a check (e.g. fam[v]:same on mujoco)" in err[0]
    assert "nowhere: no such folder or file" in err[1]
    assert "'-1': must be a finite number >= 0" in err[2]


# --- trajectories -----------------------------------------------------------------------------

def _trajectory(folder, job, z, spin=0.0):
    """A saved trajectory (the format of physval.core.trajectories) of one ball whose height is
    z, falling at g t (whatever z is: only the position differs between runs), turning at `spin`."""
    folder.mkdir(parents=True, exist_ok=True)
    n = len(z)
    state = np.zeros((n, 13))
    state[:, 2], state[:, 3], state[:, 10] = z, 1.0, spin
    state[:, 9] = -9.81 * np.arange(n) * 1e-3
    meta = {"family": "fam", "variant": "v", "params": {}, "engine": "mujoco", "dt": 1e-3, "effects": [],
            "bodies": ["ball"], "knobs": {}}
    np.savez_compressed(folder / f"{job}.npz", t=np.arange(n) * 1e-3, meta=np.array(json.dumps(meta)),
                        **{"state:ball": state})


def test_where_two_runs_part(runs, capsys):
    a, b, out = runs
    z = 1.0 - 0.5 * 9.81 * (np.arange(1001) * 1e-3) ** 2
    late = z.copy()
    late[600:] += 1e-6 * np.arange(1, 402)  # parts at step 600 (1e-6 m of a 1 m scale)
    rounding = z * (1 + 1e-13)               # below PARTED everywhere
    for folder, traj in ((a, {"same": z, "late": z, "rounding": z, "only_a": z}),
                         (b, {"same": z, "late": late, "rounding": rounding})):
        for job, zz in traj.items():
            _trajectory(folder / "trajectories", job, zz)
    # at rest, turning at rounding's rate (1e-13 rad/s) in one run: rounding of the job's scale of
    # turning (sqrt(g L) / L = 4.4 rad/s here), though all of the body's own
    _trajectory(a / "trajectories", "resting", np.full(1001, 0.5))
    _trajectory(b / "trajectories", "resting", np.full(1001, 0.5), spin=1e-13)
    assert main(["compare", str(a), str(b), "--out", str(out)]) == 1
    parts = pd.read_csv(out / "trajectories.csv").set_index("job")
    assert parts.loc["late", "parted_step"] == 600 and parts.loc["late", "first_to_part"] == "ball position[2]"
    assert np.isnan(parts.loc["same", "parted_step"]) and parts.loc["same", "largest"] == 0
    assert np.isnan(parts.loc["rounding", "parted_step"]) and 0 < parts.loc["rounding", "largest"] < PARTED
    assert np.isnan(parts.loc["resting", "parted_step"]) and 0 < parts.loc["resting", "largest"] < 1e-13
    assert parts.loc["only_a", "note"] == "saved in A only"
    assert list(parts.index[:1]) == ["late"]  # the worst first
    text = (out / "compare.md").read_text()
    assert "4 jobs saved by both runs compared step by step: 1 part" in text
    assert "![the trajectories that part the most, side by side](trajectories.png)" in text
    assert (out / "trajectories.png").stat().st_size > 10_000


# --- damaged input and nothing in common (issue 33) -------------------------------------------

def test_two_runs_with_no_check_in_common_compare_without_a_warning(tmp_path, capsys):
    """Before: matplotlib's "No artists with labels found to put in legend" on stderr."""
    import warnings
    a = _folder(tmp_path / "a", [r for r in A if r["metric"] == "gone"])
    b = _folder(tmp_path / "b", [r for r in B if r["metric"] == "new"])
    with warnings.catch_warnings(record=True) as seen:
        warnings.simplefilter("always")
        assert main(["compare", str(a), str(b), "--out", str(tmp_path / "out")]) == 1
    assert not [str(w.message) for w in seen], [str(w.message) for w in seen]
    assert capsys.readouterr().out.startswith("changed: 0 checks changed status, 0 moved by more than 0.01 "
                                              "tolerances, 1 in A only, 1 in B only")


def test_a_last_row_cut_short_is_no_check(tmp_path, capsys):
    """A results.csv whose last row a kill cut in two (every whole row ends with a newline):
    that row is no check, so its check is in A only (before: read as a check of B, with its
    numbers missing)."""
    a = _folder(tmp_path / "a", A)
    b = _folder(tmp_path / "b", A)
    text = (b / "results.csv").read_text()
    (b / "results.csv").write_text(text[:text.rstrip("\n").rfind("\n") + 30])  # the last row: 29 characters of it
    assert main(["compare", str(a), str(b), "--out", str(tmp_path / "out")]) == 1
    assert capsys.readouterr().out.startswith("changed: 0 checks changed status, 0 moved by more than 0.01 "
                                              "tolerances, 1 in A only, 0 in B only")
    assert _table(tmp_path / "out")[A[-1]["metric"]]["change"] == "only in A"


@pytest.mark.parametrize("content", [b"", b"not a zip file", b"PK\x03\x04 a zip cut short"], ids=["empty", "text", "torn"])
def test_a_trajectory_file_that_cannot_be_read_costs_its_job_only(runs, capsys, content):
    """Before: a traceback (numpy's ValueError, zipfile's BadZipFile)."""
    a, b, out = runs
    z = 1.0 - 0.5 * 9.81 * (np.arange(101) * 1e-3) ** 2
    for folder in (a, b):
        _trajectory(folder / "trajectories", "good", z)
        _trajectory(folder / "trajectories", "bad", z)
    (b / "trajectories" / "bad.npz").write_bytes(content)
    assert main(["compare", str(a), str(b), "--trajectories", str(a / "trajectories"), str(b / "trajectories"),
                 "--out", str(out)]) == 1
    (line,) = capsys.readouterr().err.strip().splitlines()
    assert line.startswith("physval: 1 jobs left out of the trajectories' comparison: a saved file cannot be read "
                           "(first: bad, cannot be read: "), line
    parts = pd.read_csv(out / "trajectories.csv").set_index("job")
    assert parts.loc["good", "largest"] == 0 and parts.loc["bad", "note"].startswith("cannot be read: ")
