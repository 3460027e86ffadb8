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


def test_the_guides_helper_table_names_every_helper_of_cases_observables():
    """Every public function of cases.observables has its row in the guide's table (rotations
    once had none), and the table names no helper that is not there."""
    import inspect
    import re

    import cases.observables as obs
    from tests.guide import section
    rows = [line for line in section("## Observables: `cases.observables`").splitlines() if line.startswith("| `")]
    named = {name for row in rows for name in re.findall(r"`(\w+)", row.split(" | ")[0])}
    public = {n for n, f in vars(obs).items() if inspect.isfunction(f) and f.__module__ == obs.__name__
              and not n.startswith("_")}
    assert named == public, f"without a row: {sorted(public - named)}; not helpers: {sorted(named - public)}"


def test_the_guide_says_how_each_engine_without_per_contact_forces_gets_them():
    """Every installed engine whose adapter computes contact forces from the bodies' momenta
    (its knob `contact_force`) is named where the guide says how, with the module that does it."""
    from pathlib import Path

    from adapters import registry
    from adapters.base import Settings
    from cases.scene import Body, Material, Scene, ball, ground
    from tests.guide import ROOT, section
    text = section("### Where the contact forces come from").lower()
    assert "adapters/impulse_split.py" in text and (ROOT / "adapters" / "impulse_split.py").is_file()
    computed = []
    for name in registry.engine_names():
        if not registry.available(name) or not registry.get(name).capabilities.contact_forces:
            continue
        adapter = registry.get(name)
        dim = 3 if 3 in adapter.capabilities.dimensions else 2
        scene = Scene(bodies=(ground(), Body("ball", ball(0.1, dim), mass=1.0, position=(0, 0, 0.1))),
                      material=Material(mu_s=0.5), dimension=dim)
        try:
            with adapter.build(scene, Settings(dt=1e-3)) as sim:
                how = str(sim.knobs.get("contact_force", ""))
        except Exception:
            continue
        if how.startswith("momentum"):
            computed.append(name)
            assert name in text, f"the guide does not say how {name} gets its contact forces"
    assert computed or not any(registry.available(n) for n in ("box2d", "box3d"))
