"""Bad input gets a one-line error naming the field and its allowed range: in scenes, in
user cases, and on the command line (exit code 2)."""
from __future__ import annotations

import math
import subprocess
import sys
import textwrap
from pathlib import Path

import pytest

from adapters.base import Settings, SettingsError
from cases.scene import Body, Box, Compliance, Material, Plane, Scene, SceneError, Sphere, ground

ROOT = Path(__file__).resolve().parent.parent
BALL = dict(position=(0, 0, 1.0))


@pytest.mark.parametrize("make,message", [
    (lambda: Body("b", Sphere(0.1), mass=-1.0, **BALL), r"mass = -1.0: must be > 0"),
    (lambda: Body("b", Sphere(0.1), mass=0.0, **BALL), r"mass = 0.0: must be > 0"),
    (lambda: Body("b", Sphere(0.1), mass=None, **BALL), r"mass = None"),
    (lambda: Body("b", Sphere(0.0), mass=1.0, **BALL), r"shape.radius = 0.0: must be > 0"),
    (lambda: Body("b", Box((0.1, 0.0, 0.1)), mass=1.0, **BALL), r"half_extents.y = 0.0: must be > 0"),
    (lambda: Body("b", Sphere(0.1), mass=math.nan, **BALL), r"mass = nan: must be finite"),
    (lambda: Body("b", Sphere(0.1), mass=1.0, position=(0, math.inf, 1)), r"position = .*must be finite"),
    (lambda: Body("b", Sphere(0.1), mass=1.0, orientation=(1, 1, 0, 0), **BALL), r"orientation.*unit quaternion"),
    (lambda: Body("b", Sphere(0.1), mass=1.0, inertia=(1, -1, 1), **BALL), r"inertia.y = -1: must be > 0"),
])
def test_body_fields(make, message):
    with pytest.raises(SceneError, match=message):
        Scene(bodies=(ground(), make()))


@pytest.mark.parametrize("material,message", [
    (Material(e=1.5), r"material.e = 1.5: coefficient of restitution must lie in \[0, 1\]"),
    (Material(e=-0.1), r"material.e = -0.1: .*\[0, 1\]"),
    (Material(e=math.nan), r"material.e = nan: must be finite"),
    (Material(mu_s=-0.2), r"material.mu_s = -0.2: friction coefficient must be >= 0"),
    (Material(compliance=Compliance("hertz", E=-1.0, nu=0.3)), r"material.compliance.E = -1.0: must be > 0"),
    (Material(compliance=Compliance("hertz", E=2e11, nu=0.5)), r"compliance.nu = 0.5: Poisson's ratio must lie in \[0, 0.5\)"),
    (Material(compliance=Compliance("hertz", E=2e11)), r"compliance: a Hertz contact takes E and nu"),
    (Material(compliance=Compliance("hooke", k=math.nan)), r"compliance.k = nan: must be finite"),
    (Material(compliance=Compliance("spring", k=1.0)), r"compliance.law = 'spring': must be 'hertz' or 'hooke'"),
    (Material(mu_s=0.3, mu_k=0.5), r"material.mu_k = 0.5: must be <= mu_s = 0.3"),
])
def test_material_fields(material, message):
    with pytest.raises(SceneError, match=message):
        Scene(bodies=(ground(), Body("b", Sphere(0.1), mass=1.0, **BALL)), material=material)


def test_interpenetration_beyond_the_stated_tolerance():
    with pytest.raises(SceneError, match=r"'ground' and 'b' start 0.05 m inside each other: allowed_overlap is 1e-06 m"):
        Scene(bodies=(ground(), Body("b", Sphere(0.1), mass=1.0, position=(0, 0, 0.05))))
    with pytest.raises(SceneError, match=r"'a' and 'b' start"):
        Scene(bodies=(Body("a", Box((0.1, 0.1, 0.1)), mass=1.0), Body("b", Box((0.1, 0.1, 0.1)), mass=1.0,
                                                                       position=(0.15, 0.05, 0))), gravity=(0, 0, 0))
    # touching exactly is fine, and a scene may allow more on purpose
    Scene(bodies=(ground(), Body("b", Sphere(0.1), mass=1.0, position=(0, 0, 0.1))))
    Scene(bodies=(ground(), Body("b", Sphere(0.1), mass=1.0, position=(0, 0, 0.075))), allowed_overlap=0.03)


def test_scene_structure():
    with pytest.raises(SceneError, match="must be unique"):
        Scene(bodies=(Body("b", Sphere(0.1), mass=1.0), Body("b", Sphere(0.1), mass=1.0, position=(1, 0, 0))))
    with pytest.raises(SceneError, match="at least one dynamic body"):
        Scene(bodies=(ground(),))
    with pytest.raises(SceneError, match="a plane must be static"):
        Scene(bodies=(Body("p", Plane(), mass=1.0), Body("b", Sphere(0.1), mass=1.0, **BALL)))
    with pytest.raises(SceneError, match=r"pairs\[0\] names body 'x'"):
        Scene(bodies=(ground(), Body("b", Sphere(0.1), mass=1.0, **BALL)), pairs=(("x", "b", Material()),))
    with pytest.raises(SceneError, match=r"gravity = .*must be finite"):
        Scene(bodies=(Body("b", Sphere(0.1), mass=1.0),), gravity=(0, 0, math.nan))


@pytest.mark.parametrize("kwargs,message", [
    ({"dt": 0.0}, "dt = 0.0: must be a finite number > 0"),
    ({"dt": -1e-3}, "dt = -0.001"),
    ({"dt": math.nan}, "dt = nan"),
    ({"dt": 1.0}, "dt = 1.0: must be <= 0.1"),
    ({"dt": 1e-3, "iterations": 0}, "iterations = 0: must be a whole number >= 1"),
])
def test_settings(kwargs, message):
    with pytest.raises(SettingsError, match=message):
        Settings(**kwargs)


def _physval(*args, cwd=ROOT):
    return subprocess.run([sys.executable, "-m", "physval", *args], capture_output=True, text=True, cwd=cwd)


@pytest.mark.parametrize("args,message", [
    (["run", "--cases", "no_such_case"], "unknown case 'no_such_case': choose from"),
    (["run", "--cases", "central_impact[nothing*]"], "no variant of central_impact matches"),
    (["run", "--engines", "havok"], "unknown engine 'havok': choose from"),
    (["run", "--dt", "0"], "must be a finite number > 0"),
    (["run", "--dt", "-1"], "must be a finite number > 0"),
    (["run", "--dt", "0.5"], "dt = 0.5: must be <= 0.1"),
    (["run", "--iterations", "0"], "must be >= 1"),
    (["run", "--cases-dir", "/no/such/folder"], "not a folder"),
])
def test_cli_bad_input_is_one_line_and_exit_2(args, message, tmp_path):
    out = _physval(*args, "--out", str(tmp_path))
    assert out.returncode == 2, out.stderr
    assert message in out.stderr
    assert len(out.stderr.strip().splitlines()) == 1 and "Traceback" not in out.stderr


USER_CASE_BAD_E = textwrap.dedent("""
    from cases.family import CaseFamily, Check
    from cases.scene import Body, Material, Scene, Sphere, ground
    FAMILY = CaseFamily(
        name="my_bounce", summary="", source="", grid=({"e": 1.5},),
        scene=lambda p: Scene(bodies=(ground(), Body("ball", Sphere(0.1), mass=1.0, position=(0, 0, 1))),
                              material=Material(e=p["e"])),
        duration=lambda p: 1.0, observe=lambda t, p: {},
        expect=lambda p, dt: [Check("x", "m", 0.0, 0.1, "abs", "why")])
""")


@pytest.mark.parametrize("source,message", [
    (USER_CASE_BAD_E, r"my_bounce[e=1.5]: material.e = 1.5: coefficient of restitution must lie in [0, 1]"),
    ("import nonexistent_module\n", "cannot be loaded: ModuleNotFoundError"),
    ("x = 1\n", "defines no FAMILY"),
    ("FAMILY = 3\n", "FAMILY is a int, not a CaseFamily"),
])
def test_cli_invalid_user_case(source, message, tmp_path):
    cases = tmp_path / "cases"
    cases.mkdir()
    (cases / "mine.py").write_text(source)
    out = _physval("run", "--cases-dir", str(cases), "--out", str(tmp_path / "out"))
    assert out.returncode == 2, out.stderr
    assert message in out.stderr and "Traceback" not in out.stderr
