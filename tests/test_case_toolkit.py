"""A case author's tools (issue #13 part 3): `physval check-case` prints every closed form
of a usable family and which engines run or skip each variant and why, and stops a
broken one with one line; `--save-trajectories` writes what each engine did, and
`physval.core.trajectories.load` gives it back as the Trajectory the observer saw."""
from __future__ import annotations

import csv
import math
import re
import textwrap
from pathlib import Path

import numpy as np
import pytest

from adapters import registry
from cases.registry import load_dir
from physval.cli import main
from physval.core.trajectories import file_name, load
from tests.guide import write_example


def test_check_case_prints_each_closed_form_and_who_runs_or_skips_each_variant(tmp_path, capsys):
    path = write_example(tmp_path)
    assert main(["check-case", str(path)]) == 0
    out = capsys.readouterr().out
    fam = load_dir(path.parent)["pair_drop"]
    engines = registry.engine_names()
    installed = {e: registry.get(e) for e in engines if registry.available(e)}
    blocks = out.split("\n  [")[1:]
    assert len(blocks) == len(fam.all_variants)  # the full grid too
    for v, text in zip(fam.all_variants, blocks):
        assert text.startswith(f"{v.id}]  dt 0.001 s, {fam.duration(v.params):g} s, effects contact,gravity,restitution")
        for c in fam.expect(v.params, fam.dt_for(v.params)):
            assert f"    {c.metric} = {c.expected:.6g} {c.unit} +- {c.tolerance:.3g} ({c.kind}): {c.why}" in text
        (runs,) = [line for line in text.splitlines() if line.startswith("    runs on: ")]
        running = runs[len("    runs on: "):].split(", ")
        assert "reference" in running
        scene = fam.scene(v.params)
        for name, adapter in installed.items():
            deferred = adapter.deferred(scene, fam.tags)  # a named run's one other reason (plan.leaves_out)
            why = adapter.capabilities.cannot_run(scene, fam.needs_of(v.params)) or (
                f"waits for --on-demand: {deferred}" if deferred else None)
            if why:
                assert f"    skips {name}: {why}" in text and name not in running
            else:
                assert name in running
        if v.params["dim"] == 3 and "pymunk" in installed:
            assert "    skips pymunk: 3D scene: the engine runs 2D scenes only" in text
    missing = [e for e in engines if e not in installed]
    assert (f"  not installed: {', '.join(missing)}" in out) == bool(missing)


_BROKEN = {
    # the guide's observer without its guard: a run in which the ball never lands raises
    "no_guard": (lambda s: s.replace("free_arc_start(z, k_out, G, traj.dt) if k_out is not None else None",
                                     "free_arc_start(z, k_out, G, traj.dt) if z[k_in + 1] else None"),
                 "pair_drop[e=0.5]: observe() raised TypeError"),
    "no_reason": (lambda s: s.replace('Check("apex_top", "m", e * e * H, tol, "abs", why)',
                                      'Check("apex_top", "m", e * e * H, tol, "abs", "")'),
                  "why is empty: every tolerance needs its reason"),
    "missing_metric": (lambda s: s.replace('return {"apex_bottom": rebound(traj, "bottom", R), ',
                                           'return {'),
                       "observe() gives no apex_bottom (expect() checks it)"),
    "bad_scene": (lambda s: s.replace("mass=M_TOP", "mass=-M_TOP"), "pair_drop[e=0.5]: bodies[2](top).mass = -0.1: must be > 0"),
    "no_family": (lambda s: s.replace("FAMILY = CaseFamily(", "NOT_A_FAMILY = CaseFamily("),
                  "defines no FAMILY"),
    # an observer must give a finite number for every check (before: check-case said usable)
    "nan": (lambda s: s.replace('"apex_top": rebound(traj, "top", 3 * R)}', '"apex_top": float("nan")}'),
            "pair_drop[e=0.5]: observe() gave apex_top = nan on a one-step run (an observer must give every check "
            "a finite number"),
    "string": (lambda s: s.replace('"apex_top": rebound(traj, "top", 3 * R)}', '"apex_top": "high"}'),
               "pair_drop[e=0.5]: observe() gave apex_top = 'high' on a one-step run"),
}


@pytest.mark.parametrize("broken", sorted(_BROKEN))
def test_check_case_stops_a_broken_family_with_one_line(tmp_path, capsys, broken):
    path = write_example(tmp_path)
    edit, message = _BROKEN[broken]
    text = path.read_text()
    assert edit(text) != text, "the edit must apply to the guide's example"
    path.write_text(edit(text))
    assert main(["check-case", str(path)]) == 2
    captured = capsys.readouterr()
    lines = captured.err.strip().splitlines()
    assert len(lines) == 1 and message in lines[0] and str(path) in lines[0], captured.err
    assert "runs on" not in captured.out


def test_check_case_names_the_file_and_line_where_the_observer_raised(tmp_path, capsys):
    """The line of the user's own file, not the innermost frame (here numpy's)."""
    path = write_example(tmp_path)
    call = "np.linalg.inv(np.zeros((2, 2)))"
    text = path.read_text().replace("def observe(traj, p):\n",
                                    f"def observe(traj, p):\n    import numpy as np\n    {call}\n")
    path.write_text(text)
    line = text.splitlines().index(f"    {call}") + 1
    assert main(["check-case", str(path)]) == 2
    err = capsys.readouterr().err.strip()
    assert "observe() raised LinAlgError" in err and err.endswith(f", at {path}:{line}") and err.count("\n") == 0, err


def test_a_run_s_error_row_names_the_file_and_line_where_the_observer_raised(tmp_path):
    """`physval run`'s error row for a user's family names the user's own line, with the
    innermost frame (numpy's) beside it; an observer raising on its own line names that."""
    from physval.core import Context, Job, execute
    from physval.core.context import Resolver
    path = write_example(tmp_path)
    text = path.read_text()
    for call, inner in (("np.linalg.inv(np.zeros((2, 2)))", True), ("int('x')", False)):
        path.write_text(text.replace("def observe(traj, p):\n",
                                     f"def observe(traj, p):\n    import numpy as np\n    {call}\n"))
        line = path.read_text().splitlines().index(f"    {call}") + 1
        resolver = Resolver(Context(cases_dirs=(str(tmp_path / "my_cases"),)))
        family = resolver.family("pair_drop")
        rows = execute(Job("pair_drop", family.variants[0], "reference"), resolver).rows
        reasons = {r["reason"] for r in rows}
        assert {r["status"] for r in rows} == {"error"} and len(reasons) == 1, rows
        (reason,) = reasons
        assert f"(at {path}:{line}, in " in reason if inner else reason.endswith(f"(at {path}:{line})"), reason


def test_user_code_names_the_users_line_past_physvals_own_frames(tmp_path):
    """An observer asking physval's Trajectory for a body it does not have: the TrajectoryError is
    raised in cases/trajectory.py, the line named is the observer's."""
    import importlib.util

    from cases.family import CaseError, user_code
    path = tmp_path / "observer.py"
    path.write_text("def observe(traj):\n    return traj.pos('nobody')\n")
    spec = importlib.util.spec_from_file_location("observer_under_test", path)
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    traj = falling_box_trajectory()
    with pytest.raises(CaseError) as exc:
        with user_code("mine.py: fam[v]", "observe() raised", "the rule"):
            module.observe(traj)
    assert str(exc.value).startswith("mine.py: fam[v]: observe() raised TrajectoryError")
    assert str(exc.value).endswith(f"(the rule), at {path}:2")


def falling_box_trajectory():
    from cases.trajectory import Trajectory
    states = np.zeros((2, 13))
    states[:, 3] = 1.0
    return Trajectory(dt=1e-3, t=np.array([0.0, 1e-3]), states={"box": states})


def test_check_case_of_a_file_that_is_not_python_is_one_line(tmp_path, capsys):
    (tmp_path / "notes.txt").write_text("x")
    assert main(["check-case", str(tmp_path / "notes.txt")]) == 2
    assert capsys.readouterr().err.strip().count("\n") == 0


def test_saved_trajectories_load_as_what_the_observer_saw(tmp_path):
    """Every job's file holds the states and contact forces of the run; its observer gives
    back exactly the values the run measured."""
    path = write_example(tmp_path)
    out, saved = tmp_path / "out", tmp_path / "traj"
    assert main(["run", "--cases-dir", str(path.parent), "--cases", "pair_drop[e=0.5*]", "--engines", "reference",
                 "--workers", "1", "--quiet", "--out", str(out), "--save-trajectories", str(saved)]) == 0
    fam = load_dir(path.parent)["pair_drop"]
    with open(out / "results.csv", newline="") as f:
        measured = {(r["variant"], r["metric"]): float(r["measured"]) for r in csv.DictReader(f)}
    variants = [v for v in fam.variants if v.id in ("e=0.5", "e=0.5,2D")]
    assert {v for v, _ in measured} == {v.id for v in variants}
    assert sorted(p.name for p in saved.iterdir()) == sorted(f"pair_drop[{v.id}]-reference.npz" for v in variants)
    for v in variants:
        traj, meta = load(saved / f"pair_drop[{v.id}]-reference.npz")
        assert (meta["family"], meta["variant"], meta["engine"], meta["params"]) == ("pair_drop", v.id, "reference",
                                                                                    v.params)
        assert meta["dt"] == 1e-3 and meta["bodies"] == ["bottom", "ground", "top"] and meta["knobs"]
        steps = round(fam.duration(v.params) / meta["dt"])
        assert traj.t.shape == (steps + 1,) and traj.pos("top").shape == (steps + 1, 3)
        assert np.allclose(traj.pos("bottom")[0], fam.scene(v.params).body("bottom").position)
        landing = traj.force("ground", "bottom")
        assert landing.shape == traj.t.shape and landing.max() > 0  # the forces of every pair are saved
        again = fam.observe(traj, meta["params"])
        for metric, value in again.items():
            assert math.isclose(value, measured[v.id, metric], rel_tol=1e-12, abs_tol=0), (v.id, metric)


def test_saved_file_names_read_like_test_ids():
    from cases.family import Variant
    from physval.core.jobs import Job
    job = Job("central_impact", Variant("central_impact", "e=0.5,m=1:3", {}), "mujoco")
    assert file_name(job) == "central_impact[e=0.5,m=1:3]-mujoco.npz"


# --- the case folder: families and libraries, told apart by what a module defines -------------

def test_every_module_of_the_cases_package_is_a_family_or_a_library():
    """No list kept by hand: a module defining FAMILY is a family (found in subpackages too),
    any other a library. The robustness families live in the package cases/robustness with
    what they share (its __init__, a library); no robustness family lives outside it."""
    import importlib
    import pkgutil

    import cases
    from cases.registry import builtin_families
    modules = {i.name: importlib.import_module(i.name) for i in pkgutil.walk_packages(cases.__path__, "cases.")}
    families = {m.FAMILY.name: name for name, m in modules.items() if hasattr(m, "FAMILY")}
    assert families == {n: f.scene.__module__ for n, f in builtin_families().items()}
    libraries = {name for name, m in modules.items() if not hasattr(m, "FAMILY")}
    assert {"cases.scene", "cases.family", "cases.observables", "cases.overlap", "cases.robustness"} <= libraries
    robust = {n: m for n, m in families.items() if "robustness" in builtin_families()[n].tags}
    assert robust and all(m.startswith("cases.robustness.") for m in robust.values()), robust
    assert all(n.startswith("robustness_") for n in robust)
    assert not [n for n in libraries if n.startswith("cases.robustness.")], "a library among the robustness families"


def test_overlap_and_scene_do_not_import_each_other():
    """cases.scene validates start overlaps with cases.overlap, which reads shapes by kind
    and size and imports nothing from cases.scene."""
    import subprocess
    import sys
    code = "import sys, cases.overlap; print('cases.scene' in sys.modules)"
    root = str(Path(__file__).resolve().parent.parent)
    out = subprocess.run([sys.executable, "-c", code], cwd=root, capture_output=True, text=True, timeout=60)
    assert out.stdout.strip() == "False", out.stdout + out.stderr


def test_an_observer_built_from_the_window_helpers_passes_the_dry_run(tmp_path, capsys):
    """Readings from a settling time on (window_mean, drift, rate) on check-case's one-step
    run: the windows lie past its end, and each helper still gives a finite number (before:
    drift raised IndexError, window_mean gave NaN, rate raised)."""
    (tmp_path / "settle.py").write_text(textwrap.dedent("""
        from cases.family import CaseFamily, Check
        from cases.observables import drift, rate, window_mean
        from cases.scene import Body, Material, Scene, Sphere, ground

        def observe(traj, p):
            vz = traj.vel("ball")[:, 2]
            return {"rest_speed": window_mean(traj, vz, 0.5), "drift": drift(traj, ["ball"], 0.5),
                    "deceleration": rate(traj, vz, 0.5)}

        def expect(p, dt):
            return [Check(m, "-", 0.0, 1.0, "abs", "a resting ball") for m in ("rest_speed", "drift", "deceleration")]

        FAMILY = CaseFamily(
            name="settle", summary="a ball at rest stays", source="statics", grid=({"e": 0.0},),
            scene=lambda p: Scene(bodies=(ground(), Body("ball", Sphere(0.1), mass=1.0, position=(0, 0, 0.1))),
                                  material=Material(e=p["e"])),
            duration=lambda p: 1.0, observe=observe, expect=expect)
    """))
    assert main(["check-case", str(tmp_path / "settle.py")]) == 0, capsys.readouterr().err
    out = capsys.readouterr().out
    steps = re.findall(r"\[one reference step: (.*)\]", out)
    assert len(steps) == 3 and all(math.isfinite(float(x)) for x in steps), out
