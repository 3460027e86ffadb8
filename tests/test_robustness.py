"""The robustness battery: its families, the invariant readings, the stability map, the
determinism check and the `stress` command. Fast (small engines, short runs); the long
ones are marked slow (pytest -m slow)."""
from __future__ import annotations

import dataclasses
import math
import sys

import numpy as np
import pytest

from cases.robustness import stacks as robustness_stacks
from cases.observables import deepest_overlap, drift, energy_rise, mechanical_energy, momentum, time_to_collapse
from cases.registry import builtin_families
from cases.scene import Body, Box, Material, Scene, Sphere, ground
from cases.trajectory import Trajectory
from physval.core import Context, Job, execute
from physval.core.context import Resolver
from physval.core.session import Execution
from physval.core.selection import SelectionError, select_variants
from physval.readings import robustness as stress
from tests.fakes import FakeAdapter

FAMILIES = {n: f for n, f in builtin_families().items() if n.startswith("robustness_")}


def _traj(t, **states) -> Trajectory:
    t = np.asarray(t, float)
    return Trajectory(dt=float(t[1] - t[0]), t=t, states={k: np.asarray(v, float) for k, v in states.items()})


def _rows(n, pos=(0, 0, 0), quat=(1, 0, 0, 0), vel=(0, 0, 0), omega=(0, 0, 0)) -> np.ndarray:
    return np.tile(np.concatenate([pos, quat, vel, omega]).astype(float), (n, 1))


# --- the families ------------------------------------------------------------------------------

def test_every_robustness_family_says_why_it_is_hard_and_validates():
    assert len(FAMILIES) >= 9
    for name, fam in FAMILIES.items():
        assert "Why hard" in sys.modules[fam.scene.__module__].__doc__, f"{name}: say why its scenes are hard"
        fam.validate()


@pytest.mark.slow
def test_every_full_grid_validates():  # 40 s: the 210-box pyramids' pairs are checked for overlap
    for fam in FAMILIES.values():
        full = getattr(sys.modules[fam.scene.__module__], "FULL_GRID", None)
        if full:
            dataclasses.replace(fam, grid=tuple(full)).validate()


def test_long_variants_run_only_in_the_stress_command():
    short = select_variants(FAMILIES, None)
    long = select_variants(FAMILIES, None, full=True)
    assert {n: [v.id for v in vs] for n, vs in short.items()} == \
           {n: [v.id for v in f.variants] for n, f in FAMILIES.items()}
    stacks = {v.id for v in long["robustness_stacks"]}
    assert "stack,n=20,3D,T=3" in stacks and "stack,n=3,3D,T=60" in stacks
    assert not any(v.id.startswith("6^3") for v in short["robustness_pile"])
    assert any(v.id.startswith("6^3") for v in long["robustness_pile"])
    # the default grids stay small: no default variant runs a long scene
    for fam in FAMILIES.values():
        for v in fam.variants:
            assert fam.duration(v.params) <= 5.0, v.test_id
            assert len(fam.scene(v.params).dynamic_bodies) <= 12, v.test_id


def test_select_takes_families_and_variant_globs_and_refuses_what_matches_nothing():
    chosen = select_variants(FAMILIES, ["robustness_tunnelling"])
    assert list(chosen) == ["robustness_tunnelling"] and len(chosen["robustness_tunnelling"]) == \
        len(FAMILIES["robustness_tunnelling"].variants)
    chosen = select_variants(FAMILIES, ["robustness_overlap[box_in_*,2D]"])
    assert [v.test_id for v in chosen["robustness_overlap"]] == \
        ["robustness_overlap[box_in_ground,2D]", "robustness_overlap[box_in_box,2D]"]
    with pytest.raises(SelectionError, match="unknown case 'robustness_nothing\\*'"):
        select_variants(FAMILIES, ["robustness_nothing*"])


# --- the readings --------------------------------------------------------------------------------

def test_mechanical_energy_adds_translation_rotation_and_height():
    box = Body("b", Box((0.1, 0.2, 0.3)), mass=2.0, position=(0, 0, 1.0))
    scene = Scene(bodies=(ground(), box), gravity=(0, 0, -9.81))
    # turned 90 deg about x: body y is world z; spinning about world z = about body y
    q = (math.cos(math.pi / 4), math.sin(math.pi / 4), 0, 0)
    traj = _traj([0, 0.1], b=_rows(2, pos=(0, 0, 1.5), quat=q, vel=(1, 2, 0), omega=(0, 0, 3)))
    Iy = 2.0 * (0.1 ** 2 + 0.3 ** 2) / 3.0  # m (a^2 + c^2) / 3 for half-extents a, c
    expected = 0.5 * 2.0 * 5.0 + 0.5 * Iy * 9.0 + 2.0 * 9.81 * 1.5
    assert mechanical_energy(traj, scene) == pytest.approx([expected, expected], rel=1e-12)


def test_energy_rise_is_the_largest_excess_over_the_start_and_momentum_sums_bodies():
    a = Body("a", Sphere(0.1), mass=1.0)
    b = Body("b", Sphere(0.1), mass=3.0, position=(1, 0, 0))
    scene = Scene(bodies=(a, b), gravity=(0, 0, 0))
    va = np.zeros((3, 13)); va[:, 3] = 1; va[:, 7] = [2.0, 2.1, 1.0]
    vb = np.zeros((3, 13)); vb[:, 3] = 1; vb[:, 0] = 1; vb[:, 7] = [0.0, 0.0, 0.5]
    traj = _traj([0, 1, 2], a=va, b=vb)
    assert energy_rise(traj, scene) == pytest.approx(0.5 * (2.1 ** 2 - 2.0 ** 2))
    assert momentum(traj, scene)[:, 0] == pytest.approx([2.0, 2.1, 2.5])


def test_drift_and_time_to_collapse_read_displacements():
    x = _rows(5, pos=(0, 0, 0.1))
    x[:, 0] = [0, 0, 0.001, 0.003, 0.05]   # slides, then falls off sideways
    x[:, 2] = [0.1, 0.099, 0.099, 0.099, 0.099]
    traj = _traj([0, 1, 2, 3, 4], b=x)
    assert drift(traj, ["b"], 1.0) == pytest.approx(0.05)
    assert time_to_collapse(traj, ["b"], sideways=0.02, down=0.2) == 4.0
    assert time_to_collapse(traj, ["b"], sideways=0.1, down=0.2) == 4.0  # never: the end of the run
    assert time_to_collapse(traj, ["b"], sideways=0.1, down=0.0005) == 1.0  # sank 1 mm


def test_deepest_overlap_measures_pairs_and_the_ground():
    a = Body("a", Box((0.1, 0.1, 0.1)), mass=1.0, position=(0, 0, 0.1))
    b = Body("b", Box((0.1, 0.1, 0.1)), mass=1.0, position=(0, 0, 0.3))
    c = Body("c", Sphere(0.1), mass=1.0, position=(5, 0, 0.1))
    scene = Scene(bodies=(ground(), a, b, c), material=Material())
    traj = _traj([0, 1], a=_rows(2, pos=(0, 0, 0.098)), b=_rows(2, pos=(0, 0, 0.293)), c=_rows(2, pos=(5, 0, 0.1)))
    assert deepest_overlap(traj, scene, 0.0) == pytest.approx(0.005)  # a's top 0.198 into b's bottom 0.193


# --- stability map -----------------------------------------------------------------------------

def _trial(engine, n, dt, iterations, duration):
    dim = 2 if engine == "pymunk" else 3
    job = stress.stack_job(engine, dim, n, dt, iterations, duration)
    return stress.trial_row(job, execute(job, Context().resolver()).rows)


def test_a_short_stack_stands_and_a_two_d_engine_gets_the_two_d_stack():
    row = _trial("pymunk", 2, 1 / 60, 10, duration=1.0)
    assert row["status"] == "stands" and row["dim"] == 2 and row["standing_time"] == pytest.approx(1.0, abs=1e-9)
    assert row["drift"] < 1e-3 and row["us_per_step"] > 0


def test_an_unknown_engine_is_a_row_not_an_exception():
    row = _trial("no-such-engine", 2, 1 / 60, 10, duration=1.0)
    assert row["status"] == "unsupported" and "unknown engine" in row["reason"]


def test_map_summary_plot_and_section(tmp_path):
    smap = stress.stability_map(["pymunk"], Context(), tmp_path, heights=(2, 40), dts=(1 / 60,), iterations=(2,),
                                duration=1.0, execution=Execution(progress=False))
    assert list(smap.n) == [2, 40] and list(smap.status) == ["stands", "collapsed"]
    summary = stress.map_summary(smap)
    assert summary["tallest standing"].tolist() == [2] and summary["next height"].tolist() == [40]
    assert 0 < summary["next: time to collapse (s)"].iloc[0] < 1.0
    stress.plot_stability_map(smap, tmp_path / "map.png")
    assert (tmp_path / "map.png").stat().st_size > 1000
    section = stress.stability_section(smap, "map.png")
    assert section.startswith("## Stability") and "![stability map](map.png)" in section


# --- determinism ---------------------------------------------------------------------------------

def test_state_hash_is_stable_and_sensitive_to_the_last_bit():
    s = {"a": np.arange(13, dtype=float), "b": np.ones(13)}
    assert stress.state_hash(s) == stress.state_hash({"b": np.ones(13), "a": np.arange(13, dtype=float)})
    t = {"a": np.arange(13, dtype=float), "b": np.ones(13)}
    t["b"][5] = np.nextafter(1.0, 2.0)
    assert stress.state_hash(s) != stress.state_hash(t)


def test_determinism_runs_twice_and_names_the_deterministic_engines(tmp_path):
    df = stress.determinism(["pymunk"], Context(), tmp_path, execution=Execution(workers=2, progress=False),
                            variants=("robustness_degenerate[edge-on,2D]", "robustness_degenerate[edge-on,3D]"))
    assert list(df.status) == ["deterministic", "unsupported"]
    assert stress.deterministic_engines(df) == ["pymunk"]


class _AlternatingAdapter(FakeAdapter):
    """Every other scene it builds starts 1e-12 m off: a result that depends on what the
    process built before (as DART's does on the heap addresses it reuses)."""

    def build(self, scene, settings):
        sim = super().build(scene, settings)
        if len(self.built) % 2 == 0:
            sim.x = {n: x + 1e-12 for n, x in sim.x.items()}
        return sim


@pytest.mark.parametrize("adapter, distinct", [(FakeAdapter("steady"), 1), (_AlternatingAdapter("alternating"), 2)])
def test_the_determinism_probe_runs_its_scene_again_in_its_own_process(adapter, distinct):
    fam = Context().resolver().family("robustness_degenerate")
    variant = next(v for v in fam.all_variants if v.id == "edge-on,2D")
    job = Job(fam.name, variant, adapter.name, probe="physval.readings.robustness:FinalHash")
    out = execute(job, Resolver(Context()).provide(adapter.name, adapter))
    hashes = out.extra["state_hash"].split()
    assert len(hashes) == 3 and len(set(hashes)) == distinct
    assert len(adapter.built) == 3


# --- the command ---------------------------------------------------------------------------------

def _stress(*argv):
    from physval.cli import main
    return main(["stress", *argv])


def test_stress_help_names_its_options(capsys):
    assert _stress("--help") == 0
    text = capsys.readouterr().out
    for option in ("--engines", "--cases", "--out", "--long", "--quiet", "reports/stress", "--scheduler"):
        assert option in text


def test_stress_writes_results_report_and_sections(tmp_path, capsys):
    assert _stress("--engines", "pymunk", "--cases", "robustness_degenerate[edge-on,2D]", "--quiet",
                   "--out", str(tmp_path), "--no-map") == 0
    import pandas as pd
    from physval.core import COLUMNS
    df = pd.read_csv(tmp_path / "stress_results.csv")
    assert list(df.columns) == COLUMNS and set(df.status) == {"pass"}
    report = (tmp_path / "stress_report.md").read_text()
    for heading in ("## Scorecard", "## Summary", "## Cost per scene", "## Stability", "## Determinism"):
        assert heading in report
    assert report.index("## Scorecard") < report.index("## Summary")  # one screen before the detail
    assert "no stability map in this run" in report
    assert "wrote" in capsys.readouterr().out


@pytest.mark.parametrize("argv, message", [
    (["--engines", "nope"], "unknown engine 'nope'"),
    (["--cases", "robustness_nothing"], "unknown case 'robustness_nothing'"),
])
def test_stress_bad_input_is_one_line_and_exit_code_2(argv, message, tmp_path, capsys):
    assert _stress("--quiet", "--out", str(tmp_path), *argv) == 2
    err = capsys.readouterr().err.strip()
    assert message in err and len(err.splitlines()) == 1


# --- the done criterion for the reference ------------------------------------------------------

@pytest.mark.slow
def test_reference_holds_a_ten_box_stack_for_ten_seconds_at_60_hz_with_ten_iterations():
    """The battery's done criterion (about 10 s CPU): warm-started sequential impulses keep
    a ten-box stack standing at 60 Hz with 10 iterations, drift under 1 % of a box."""
    row = _trial("reference", 10, 1 / 60, 10, duration=10.0)
    assert row["status"] == "stands", row
    assert row["drift"] < 0.01 * robustness_stacks.SIZE, row
