"""Bad input gets a one-line error naming the field and its allowed range: in scenes, in
user cases, and on the command line (exit code 2)."""
from __future__ import annotations

import math
import re
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
    (lambda: Body("b", Sphere(0.1), mass=1.0, rotates=False, angular_velocity=(0, 0, 1), **BALL),
     r"angular_velocity = \(0, 0, 1\): a body held from rotating \(rotates=False\) cannot spin"),
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
    (Material(rolling_resistance=-0.001), r"material.rolling_resistance = -0.001: a lever arm in m, must be >= 0"),
    (Material(torsional_friction=math.inf), r"material.torsional_friction = inf: must be finite"),
    (Material(torsional_friction="0.002"), r"material.torsional_friction = '0.002': must be a number \(a lever arm in m, >= 0\)"),
])
def test_material_fields(material, message):
    with pytest.raises(SceneError, match=message):
        Scene(bodies=(ground(), Body("b", Sphere(0.1), mass=1.0, **BALL)), material=material)


def test_a_2d_scene_lies_in_the_x_z_plane():
    from cases.scene import Circle, Plane, Rect
    with pytest.raises(SceneError, match=r"orientation = .*: a 2D body turns about y only"):
        Scene(bodies=(ground(), Body("b", Rect((0.1, 0.1)), mass=1.0, position=(0, 0, 1),
                                     orientation=(0.0, 0.0, 0.0, 1.0))), dimension=2)
    with pytest.raises(SceneError, match=r"shape.normal = .*: a 2D scene's plane is a line in the x-z plane"):
        Scene(bodies=(Body("wall", Plane((0.0, 1.0, 0.0)), static=True),
                      Body("b", Circle(0.1), mass=1.0, position=(0, 0, 1))), dimension=2)


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
    with pytest.raises(SceneError, match=r"static = False: must be True for a plane"):
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


def _physval(*args):
    """physval's command line, in this process (as a subprocess would see it: exit code,
    stdout, stderr)."""
    import contextlib
    import io
    from types import SimpleNamespace
    from physval.cli import main
    out, err = io.StringIO(), io.StringIO()
    with contextlib.redirect_stdout(out), contextlib.redirect_stderr(err):
        try:
            code = main(list(args))
        except SystemExit as exc:  # argparse's own errors
            code = exc.code
    return SimpleNamespace(returncode=code, stdout=out.getvalue(), stderr=err.getvalue())


@pytest.mark.parametrize("args,message", [
    (["run", "--cases", "no_such_case"], "unknown case 'no_such_case': choose from"),
    (["run", "--cases", "central_impact[nothing*]"], "no variant of central_impact matches"),
    (["run", "--engines", "havok"], "unknown engine 'havok': choose from"),
    (["run", "--dt", "0"], "must be a finite number > 0"),
    (["run", "--dt", "-1"], "must be a finite number > 0"),
    (["run", "--dt", "0.5"], "dt = 0.5: must be <= 0.1"),
    (["run", "--iterations", "0"], "must be >= 1"),
    (["run", "--cases-dir", "/no/such/folder"], "not a folder"),
    (["run", "--cases", ""], "names no case"),
    (["run", "--cases", ","], "names no case"),
    (["run", "--engines", ""], "names no engine"),
    (["run", "--engines", ","], "names no engine"),
    (["run", "--readings", "everything"], "--readings 'everything': choose from"),
    (["run", "--known", "/no/such/file"], "--known '/no/such/file': not a file"),
    (["run", "--adapter", "no_such_module:Engine"], "cannot be imported"),
    (["run", "--adapter", "json:JSONDecoder"], "gives a JSONDecoder, not an adapters.base.Adapter"),
    (["run", "--job-timeout", "-1"], "must be a finite number of seconds >= 0"),
    (["run", "--scheduler", "tcp://127.0.0.1:1"], "cannot reach a Dask scheduler"),
    (["sweep", "--engines", "pymunk", "--cases", "resting_blocks[n=5]"], "has no sweep point"),
    (["stress", "--cases", "robustness_nothing"], "unknown case 'robustness_nothing'"),
    (["known", "no-such-engine"], "unknown engine 'no-such-engine'"),
    (["run", "--cases", "central_impact[drop,e=0.5]", "--engines", "reference", "--save-trajectories", ""],
     "--save-trajectories '': must name a folder"),
])
def test_cli_bad_input_is_one_line_and_exit_2(args, message, tmp_path):
    out = _physval(*args, "--out", str(tmp_path / "out"))
    assert out.returncode == 2, out.stderr
    assert message in out.stderr
    assert len(out.stderr.strip().splitlines()) == 1 and "Traceback" not in out.stderr
    assert not (tmp_path / "out" / "results.csv").exists(), "bad input must stop before any job"


@pytest.mark.parametrize("address", ["foo", "tcp://host:port", "http://127.0.0.1:8786"])
def test_a_malformed_scheduler_address_is_one_line(address, tmp_path):
    """In a process of its own: the traceback of a half-made Dask client came at exit."""
    import subprocess
    import sys
    proc = subprocess.run([sys.executable, "-m", "physval", "run", "--cases", "central_impact[drop,e=0.5]",
                           "--engines", "reference", "--scheduler", address, "--out", str(tmp_path)],
                          cwd=ROOT, capture_output=True, text=True, timeout=120)
    (line,) = proc.stderr.strip().splitlines()
    assert proc.returncode == 2 and line.startswith(f"physval: error: --scheduler {address!r}: not a Dask "
                                                    "scheduler address; give tcp://HOST:PORT"), proc.stderr


@pytest.mark.parametrize("command", ["run", "sweep", "stress"])
@pytest.mark.parametrize("removed,replacement", [("--no-effective", "--readings laws"),
                                                 ("--no-laws", "--readings effective")])
def test_a_removed_option_names_its_replacement(command, removed, replacement):
    out = _physval(command, removed)
    assert out.returncode == 2 and len(out.stderr.strip().splitlines()) == 1, out.stderr
    assert f"{removed} was removed: use physval run {replacement}" in out.stderr, out.stderr
    assert "--readings takes effective, laws, all, none or auto" in out.stderr


def test_what_the_removed_options_note_says_readings_takes_is_what_it_takes():
    from physval.commands.options import READINGS_TAKES
    from physval.commands.run import READINGS, readings_of
    named = READINGS_TAKES.split(" takes ", 1)[1].replace(" or ", ", ").split(", ")
    assert set(named) == set(READINGS) | {"all", "none", "auto"}
    for name in named:
        readings_of(name, cases_named=False)  # raises UsageError if it is not taken


def test_bad_output_folders_stop_before_any_work(tmp_path):
    a_file = tmp_path / "file"
    a_file.write_text("x")
    for out, message in ((str(a_file), "exists and is not a folder"), (str(a_file / "sub"), "cannot write there"),
                         ("", "must name a folder"), ("/proc/physval", "cannot write there")):
        got = _physval("run", "--cases", "central_impact[drop,e=0.5]", "--engines", "reference", "--out", out)
        assert got.returncode == 2 and message in got.stderr, (out, got.stderr)
        assert len(got.stderr.strip().splitlines()) == 1
    assert not list(tmp_path.rglob(".physval-write-test*"))


def test_a_reader_that_closes_the_output_early_gets_no_traceback():
    """`physval list | head -1`: the output has nowhere to go; exit 141 as a shell reports
    SIGPIPE, and say nothing on stderr."""
    import subprocess
    import sys
    proc = subprocess.Popen([sys.executable, "-m", "physval", "list"], stdout=subprocess.PIPE,
                            stderr=subprocess.PIPE, cwd=ROOT)
    proc.stdout.close()  # the reader goes away (before physval, still starting, writes anything)
    err = proc.stderr.read().decode()
    assert proc.wait(timeout=60) == 141 and "Traceback" not in err, err


def test_a_sweep_csv_that_is_not_ours_is_refused(tmp_path):
    (tmp_path / "sweep.csv").write_text("a,b\n1,2\n")
    got = _physval("sweep", "--cases", "central_impact[drop,e=0.5]", "--engines", "reference", "--out", str(tmp_path))
    assert got.returncode == 2 and "not a file physval can resume" in got.stderr, got.stderr
    assert (tmp_path / "sweep.csv").read_text() == "a,b\n1,2\n"


def test_an_exact_variant_id_with_commas_selects_that_variant():
    from cases.registry import builtin_families
    from physval.core.selection import select_variants, split
    fams = builtin_families()
    assert split(["central_impact[e=0.5,m=1:3],incline_threshold[mu=0.5,theta=atan(mu_s)+1deg]"]) == \
        ["central_impact[e=0.5,m=1:3]", "incline_threshold[mu=0.5,theta=atan(mu_s)+1deg]"]
    every = [v.test_id for f in fams.values() for v in f.variants if "[" not in v.id]
    for test_id in every:
        chosen = select_variants(fams, [test_id])
        assert [v.test_id for vs in chosen.values() for v in vs] == [test_id]


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


def _user_case(name="my_bounce", grid='({"e": 0.5},)', scene=None, observe="lambda t, p: {'x': 0.0}",
               expect='lambda p, dt: [Check("x", "m", 0.0, 0.1, "abs", "why")]', extra=""):
    scene = scene or ('lambda p: Scene(bodies=(ground(), Body("ball", Sphere(0.1), mass=1.0, position=(0, 0, 1))), '
                      'material=Material(e=p["e"]))')
    return textwrap.dedent(f"""
        import sys
        from cases.family import CaseFamily, Check
        from cases.scene import Body, Material, Scene, Sphere, ground
        FAMILY = CaseFamily(name={name!r}, summary="", source="", grid={grid}, scene={scene},
                            duration=lambda p: 0.1, observe={observe}, expect={expect}{extra})
    """)


@pytest.mark.parametrize("files,message", [
    ({"mine.py": USER_CASE_BAD_E}, r"my_bounce[e=1.5]: material.e = 1.5: coefficient of restitution must lie in [0, 1]"),
    ({"mine.py": "import nonexistent_module\n"}, "cannot be loaded: ModuleNotFoundError"),
    ({"mine.py": "x = 1\n"}, "defines no FAMILY"),
    ({"mine.py": "FAMILY = 3\n"}, "FAMILY is a int, not a CaseFamily"),
    ({"mine.py": "import sys\nsys.exit(0)\n"},
     "cannot be loaded: SystemExit(0) (a case file must import without error and define FAMILY)"),
    ({"mine.py": _user_case(scene="lambda p: 1 / 0")}, "its code raised ZeroDivisionError"),
    ({"mine.py": _user_case(expect="lambda p, dt: [][1]")}, "its code raised IndexError"),
    ({"mine.py": _user_case(scene='lambda p: Scene(bodies=(ground(), Body("ball", None, mass=1.0)))')},
     "shape = None: must be a shape of cases.scene"),
    ({"a.py": _user_case(), "b.py": _user_case()}, "family 'my_bounce' is already defined in"),
    ({"mine.py": _user_case(name="conformance")}, "family 'conformance' is already a built-in family"),
    ({"mine.py": _user_case(extra=", dt=0.5")}, "dt = 0.5: must lie in (0, 0.1] s"),
    ({"mine.py": _user_case(extra=', needs=frozenset({"contact_force"})')}, "needs ['contact_force']: unknown"),
    ({"mine.py": _user_case(expect='lambda p, dt: [Check("x", "m", 0.0, -1, "abs", "why")]')},
     "my_bounce[e=0.5]: expect(): check 'x': tolerance = -1"),
    ({"mine.py": _user_case(observe="lambda t, p: t.pos('ball')[5, 2]")}, "observe() raised IndexError"),
    ({"mine.py": _user_case(observe="lambda t, p: {}")}, "observe() gives no x"),
    ({"mine.py": _user_case(observe="lambda t, p: {'x': t.force('ground', 'ball')[-1]}")},
     "the family must declare needs={'contact_forces'}"),
])
def test_cli_invalid_user_case(files, message, tmp_path):
    cases = tmp_path / "cases"
    cases.mkdir()
    for name, source in files.items():
        (cases / name).write_text(source)
    out = _physval("run", "--cases-dir", str(cases), "--out", str(tmp_path / "out"), "--engines", "reference")
    assert out.returncode == 2, out.stderr
    assert message in out.stderr and "Traceback" not in out.stderr
    assert len(out.stderr.strip().splitlines()) == 1
    assert str(cases) in out.stderr, "the message names the file"
    assert not (tmp_path / "out" / "results.csv").exists()


def test_an_observer_giving_no_number_is_an_error_row_naming_the_metric_and_file(tmp_path):
    cases = tmp_path / "cases"
    cases.mkdir()
    (cases / "mine.py").write_text(_user_case(observe="lambda t, p: {'x': None if len(t.t) > 2 else 0.0}"))
    out = _physval("run", "--cases-dir", str(cases), "--cases", "my_bounce", "--out", str(tmp_path / "out"),
                   "--engines", "reference", "--workers", "1", "--quiet")
    assert out.returncode == 0, out.stderr
    import csv
    (row,) = list(csv.DictReader(open(tmp_path / "out" / "results.csv")))
    assert row["status"] == "error" and "x = None: not a finite number" in row["reason"]
    assert str(cases / "mine.py") in row["reason"]


# --- user code never takes physval down (issue 20) ---------------------------------------------

def _physval_process(*args, timeout=120):
    """`python3 -m physval ARGS` in its own process: a crash that got through would end
    that process, not the test's."""
    import subprocess
    import sys
    return subprocess.run([sys.executable, "-m", "physval", *args], cwd=ROOT, capture_output=True, text=True,
                          timeout=timeout)


# Several command lines, one after the other, in one process of its own (the lines a test
# reads together): one interpreter start, one import of physval and the families, one fork
# server, instead of one each. Each line's outcome is printed as it ends, so a crash that got
# through ends this process, not the test's, and the lines it did not reach say so.
_EACH_IN_TURN = """
import contextlib, io, json, sys
from physval.cli import main
for argv in json.loads(sys.argv[1]):
    out, err = io.StringIO(), io.StringIO()
    with contextlib.redirect_stdout(out), contextlib.redirect_stderr(err):
        try:
            code = main(argv)
        except SystemExit as exc:
            code = exc.code
    print(json.dumps([code, out.getvalue(), err.getvalue()]), flush=True)
"""


def _physval_in_turn(*argvs, timeout=300, prefix=()) -> list:
    """`physval ARGV` for each of `argvs`, in one process of its own (_EACH_IN_TURN; started
    through `prefix`, e.g. _as_a_user's): each as _physval_process gives it (exit code,
    stdout, stderr). A line the process did not reach (an earlier one ended it) has no exit
    code and says so in its stderr."""
    import json
    import subprocess
    import sys
    from types import SimpleNamespace
    proc = subprocess.run([*prefix, sys.executable, "-c", _EACH_IN_TURN, json.dumps([list(a) for a in argvs])],
                          cwd=ROOT, capture_output=True, text=True, timeout=timeout)
    done = [SimpleNamespace(returncode=c, stdout=o, stderr=e)
            for c, o, e in (json.loads(line) for line in proc.stdout.splitlines())]
    ended = f"not reached: the process ended with exit {proc.returncode} before it\n{proc.stderr[-3000:]}"
    return done + [SimpleNamespace(returncode=None, stdout="", stderr=ended)] * (len(argvs) - len(done))


SEGFAULT, EXIT, OS_EXIT = "__import__('ctypes').string_at(0)", "__import__('sys').exit(0)", "__import__('os')._exit(0)"
HANG = "[0 for _ in iter(int, 1)]"  # an endless loop, as an expression
ENDS = "never end the process, and finish within the time limit"  # the rule those lines state
ENDS_FULLY = "a family's code must return or raise, " + ENDS
LOAD_ENDS = "a case file must import without ending the process, within the time limit"


# id -> (a family file's source, the family[variant] or "cannot be loaded", what the line says)
CRASHES = {
    "observe-segfault": (_user_case(observe=f"lambda t, p: {SEGFAULT}"), "my_bounce[e=0.5]",
                         "killed by signal SIGSEGV (11) (" + ENDS_FULLY),
    "observe-os_exit": (_user_case(observe=f"lambda t, p: {OS_EXIT}"), "my_bounce[e=0.5]",
                        "it exited with code 0 (" + ENDS_FULLY),
    "observe-sys_exit": (_user_case(observe=f"lambda t, p: {EXIT}"), "my_bounce[e=0.5]",
                         "observe() raised SystemExit(0) (an observer must give every check a finite number"),
    "observe-hang": (_user_case(observe=f"lambda t, p: {HANG}"), "my_bounce[e=0.5]",
                     "longer than the per-job time limit of 2 s"),
    "scene-segfault": (_user_case(scene=f"lambda p: {SEGFAULT}"), "my_bounce[e=0.5]", "killed by signal SIGSEGV"),
    "expect-os_exit": (_user_case(expect=f"lambda p, dt: {OS_EXIT}"), "my_bounce[e=0.5]", "it exited with code 0"),
    "expect-sys_exit": (_user_case(expect=f"lambda p, dt: {EXIT}"), "my_bounce[e=0.5]",
                        "its code raised SystemExit(0) (scene, duration"),
    "import-os_exit": ("import os\nos._exit(3)\n" + _user_case(), "cannot be loaded",
                       "it exited with code 3 (" + LOAD_ENDS),
    "import-sys_exit": ("import sys\nsys.exit(3)\n" + _user_case(), "cannot be loaded",
                        "SystemExit(3) (a case file must import"),
}


@pytest.fixture(scope="module")
def checked_crashes(tmp_path_factory) -> dict:
    """id -> (the file, what `physval check-case` said of it) for every family of CRASHES,
    each file in a folder of its own, checked one after the other in one process of its own."""
    base = tmp_path_factory.mktemp("crashes")
    files, argvs = {}, []
    for name, (source, _, message) in CRASHES.items():
        (base / name).mkdir()
        files[name] = base / name / "mine.py"
        files[name].write_text(source)
        # 2 s for the endless loop; the others end at once, after the reference's first step,
        # which on an empty numba cache compiles for tens of seconds: a limit no load reaches
        limit = "2" if "time limit of 2 s" in message else "900"
        argvs.append(("check-case", "--job-timeout", limit, str(files[name])))
    return dict(zip(CRASHES, zip(files.values(), _physval_in_turn(*argvs, timeout=900))))


@pytest.mark.parametrize("crash", list(CRASHES))
def test_check_case_survives_a_family_that_crashes_exits_or_hangs(checked_crashes, crash):
    """Every way a family's code can end a process, in each place physval calls it, is one
    line and exit 2: the file, the family[variant] (or that it cannot be loaded) and what is
    allowed (before: exit 139 and nothing said for a segfault, exit 0, 'usable', for an exit)."""
    _, names, message = CRASHES[crash]
    path, got = checked_crashes[crash]
    lines = got.stderr.strip().splitlines()
    assert got.returncode == 2, (got.returncode, got.stderr)
    assert len(lines) == 1 and lines[0].startswith(f"physval: error: {path}: {names}"), got.stderr
    assert message in lines[0], lines[0]
    assert "runs on" not in got.stdout


@pytest.mark.parametrize("source", [_user_case(observe=f"lambda t, p: {SEGFAULT}"), "import os\nos._exit(3)\n"],
                         ids=["observe-segfault", "import-os_exit"])
def test_a_run_survives_a_family_that_crashes(source, tmp_path):
    """`physval run --cases-dir` dry-runs the folder's families in workers: a family that
    crashes stops the run that selects it with one line, before any job."""
    (tmp_path / "cases").mkdir()
    (tmp_path / "cases" / "mine.py").write_text(source)
    got = _physval_process("run", "--cases-dir", str(tmp_path / "cases"), "--engines", "reference", "--quiet",
                           "--out", str(tmp_path / "out"))
    lines = got.stderr.strip().splitlines()
    assert got.returncode == 2 and len(lines) == 1 and str(tmp_path / "cases" / "mine.py") in lines[0], got.stderr
    assert ENDS in lines[0] or LOAD_ENDS in lines[0], lines[0]
    assert not (tmp_path / "out" / "results.csv").exists()


# id -> (an --adapter file's source, what the line says)
BAD_ADAPTERS = {
    "import-sys_exit": ("import sys\nsys.exit(0)\n",
                        "cannot be imported: SystemExit(0) (an adapter's module must import"),
    "import-os_exit": ("import os\nos._exit(0)\n",
                       "it exited with code 0 (an adapter's module must import, and its class be made, "
                       "without ending the process)"),
    "constructor-segfault": ("import os\nfrom adapters.reference_engine import ReferenceAdapter\n"
                             "class Engine(ReferenceAdapter):\n    def __init__(self):\n"
                             "        os.kill(os.getpid(), 11)\n",
                             "killed by signal SIGSEGV"),
    "version-raises": ("from adapters.reference_engine import ReferenceAdapter\n"
                       "class Engine(ReferenceAdapter):\n    def __init__(self):\n"
                       "        super().__init__(name='reference-mine')\n"
                       "    def version(self):\n        raise RuntimeError('no release here')\n",
                       "version() raised RuntimeError: no release here (an adapter's version() must return its "
                       "engine's release as a string)"),
}
ADAPTER_COMMANDS = {"list": ["list", "--engines"], "run": ["run", "--engines", "reference", "--quiet"]}


@pytest.fixture(scope="module")
def bad_adapters(tmp_path_factory) -> dict:
    """(adapter id, command id) -> (the --adapter target, its folder, what the command said)
    for every file of BAD_ADAPTERS under every command of ADAPTER_COMMANDS, each in a
    folder of its own, one after the other in one process of its own."""
    base = tmp_path_factory.mktemp("adapters")
    runs = {}
    for name, (source, _) in BAD_ADAPTERS.items():
        for command, argv in ADAPTER_COMMANDS.items():
            folder = base / f"{name}-{command}"
            folder.mkdir()
            (folder / "engine.py").write_text(source)
            target = f"{folder / 'engine.py'}:Engine"
            out = ["--out", str(folder / "out")] if argv[0] == "run" else []
            runs[name, command] = (target, folder, (*argv, "--adapter", target, *out))
    said = _physval_in_turn(*(argv for _, _, argv in runs.values()), timeout=600)
    return {key: (target, folder, got) for (key, (target, folder, _)), got in zip(runs.items(), said)}


@pytest.mark.parametrize("adapter", list(BAD_ADAPTERS))
@pytest.mark.parametrize("command", list(ADAPTER_COMMANDS))
def test_an_adapter_file_that_exits_or_crashes_is_one_line(bad_adapters, adapter, command):
    """An --adapter file is imported and made, and gives its version, in a worker first
    (before: exit 0 and no word; a version() that raised: a traceback after the dry run)."""
    target, folder, got = bad_adapters[adapter, command]
    lines = got.stderr.strip().splitlines()
    assert got.returncode == 2 and len(lines) == 1, (got.returncode, got.stderr)
    assert lines[0].startswith(f"physval: error: adapter {target!r}: ") and BAD_ADAPTERS[adapter][1] in lines[0], \
        lines[0]
    assert not (folder / "out" / "results.csv").exists()


def test_an_observer_that_exits_in_a_real_run_is_an_error_row(tmp_path):
    """Past the one-step dry run, an exit in an observer costs its job's rows, which say so;
    the worker goes on."""
    cases = tmp_path / "cases"
    cases.mkdir()
    (cases / "mine.py").write_text(_user_case(observe=f"lambda t, p: {{'x': 0.0}} if len(t.t) <= 2 else {EXIT}"))
    out = _physval("run", "--cases-dir", str(cases), "--cases", "my_bounce", "--out", str(tmp_path / "out"),
                   "--engines", "reference", "--workers", "1", "--quiet")
    assert out.returncode == 0, out.stderr
    import csv
    (row,) = list(csv.DictReader(open(tmp_path / "out" / "results.csv")))
    # the user's own file by its path (relative to the working directory where inside it)
    assert row["status"] == "error" and re.fullmatch(r"SystemExit: 0 \(at (\S+/)?mine\.py:\d+\)", row["reason"]), \
        row["reason"]


def test_a_broken_file_leaves_the_other_families_of_its_folder_runnable(tmp_path):
    """One file that does not load (it even ends the process), one whose observer gives NaN
    and one whose family takes a built-in name: a run naming the good family runs it and
    says in one line per file what was left out; naming a broken family, or every family,
    stops with its line."""
    cases, out = tmp_path / "cases", tmp_path / "out"
    cases.mkdir()
    (cases / "good.py").write_text(_user_case(name="good"))
    (cases / "exits.py").write_text("import os\nos._exit(3)\n")
    (cases / "nan.py").write_text(_user_case(name="nan_family", observe="lambda t, p: {'x': float('nan')}"))
    (cases / "clash.py").write_text(_user_case(name="conformance"))
    broken = {"exits.py": "cannot be loaded", "nan.py": "observe() gave x = nan",
              "clash.py": "family 'conformance' is already a built-in family"}
    run = ("run", "--cases-dir", str(cases), "--engines", "reference", "--workers", "1", "--quiet")
    stops = ("nan_family", "nan.py"), ("conformance", "clash.py"), ("exits_family", "exits.py"), (None, "")
    # the run of the good family, then each run that must stop (each into a folder of its own),
    # one after the other in one process
    got, *stopped = _physval_in_turn((*run, "--out", str(out), "--cases", "good"),
                                     *((*run, "--out", str(tmp_path / f"stop{i}"), *(["--cases", spec] if spec else []))
                                       for i, (spec, _) in enumerate(stops)))
    assert got.returncode == 0, got.stderr
    lines = got.stderr.strip().splitlines()
    assert len(lines) == len(broken), lines
    for f, message in broken.items():
        (line,) = [x for x in lines if str(cases / f) in x]
        assert line.startswith(f"physval: left out {cases / f}: ") and message in line, line
    import csv
    rows = list(csv.DictReader(open(out / "results.csv")))
    assert {r["case"] for r in rows} == {"good"} and {r["status"] for r in rows} == {"pass"}, rows
    for i, ((spec, f), got) in enumerate(zip(stops, stopped)):
        lines = got.stderr.strip().splitlines()
        assert got.returncode == 2 and len(lines) == 1 and str(cases / f) in lines[0], (spec, got.stderr)
        assert not (tmp_path / f"stop{i}" / "results.csv").exists()


# --- paths the file system refuses (issue 33) ------------------------------------------------

R = ["--cases", "central_impact[drop,e=0.5]", "--engines", "reference", "--readings", "none", "--workers", "1",
     "--quiet"]


def _as_a_user(*args, timeout=300):
    """`python3 -m physval ARGS` as a user whom file permissions bind (A_USER)."""
    import subprocess
    import sys
    return subprocess.run([*A_USER(), sys.executable, "-m", "physval", *args], cwd=ROOT, capture_output=True,
                          text=True, timeout=timeout)


def A_USER() -> list[str]:
    """The prefix that runs a process as a user whom file permissions bind: root reads
    whatever the permissions say, so as root the process runs without the capabilities that
    let it (setpriv drops CAP_DAC_OVERRIDE and CAP_DAC_READ_SEARCH from its bounding set)."""
    import os
    import shutil
    if os.geteuid() != 0:
        return []
    if shutil.which("setpriv") is None:
        pytest.skip("as root, a file cannot be made unreadable without setpriv (util-linux)")
    return ["setpriv", "--bounding-set", "-dac_override,-dac_read_search"]


# id -> (the command line, given the unreadable folder and a folder of the test's own; its one line)
REFUSED = {
    "out-inside": (lambda u, t: ["run", *R, "--out", str(u / "out")],
                   "--out {u}/out: cannot write there (Permission denied)"),
    "compare": (lambda u, t: ["compare", str(u), str(u), "--out", str(t / "cmp")],
                "{u}: cannot be read (Permission denied)"),
    "cases-dir-inside": (lambda u, t: ["run", *R, "--cases-dir", str(u), "--out", str(t / "out")],
                         "--cases-dir '{u}': cannot be read (Permission denied)"),
    "known-inside": (lambda u, t: ["run", *R, "--known", str(u / "known.txt"), "--out", str(t / "out")],
                     "--known '{u}/known.txt': cannot be read (Permission denied)"),
}


@pytest.fixture(scope="module")
def refused(tmp_path_factory):
    """(a folder nobody may list or enter, with a results.csv and a family file in it;
    id -> what each command line of REFUSED gave), the lines run one after the other in one
    process of their own, as a user whom file permissions bind."""
    base = tmp_path_factory.mktemp("refused")
    folder = base / "unreadable"
    folder.mkdir()
    (folder / "results.csv").write_text("case\n")
    (folder / "mine.py").write_text(_user_case())
    folder.chmod(0)
    try:
        said = _physval_in_turn(*(args(folder, base / name) for name, (args, _) in REFUSED.items()), prefix=A_USER())
    finally:
        folder.chmod(0o755)
    return folder, dict(zip(REFUSED, said))


@pytest.mark.parametrize("refusal", list(REFUSED))
def test_a_path_the_system_refuses_is_one_line_and_exit_2(refused, refusal):
    """Before: a traceback (PermissionError from a check that only asked whether it exists)."""
    unreadable, said = refused
    got = said[refusal]
    (line,) = got.stderr.strip().splitlines()
    assert got.returncode == 2 and line == f"physval: error: {REFUSED[refusal][1].format(u=unreadable)}", got.stderr


def test_an_out_folder_name_too_long_is_one_line_and_exit_2(tmp_path):
    out = tmp_path / ("x" * 300)
    got = _physval("run", *R, "--out", str(out))
    (line,) = got.stderr.strip().splitlines()
    assert got.returncode == 2 and line == f"physval: error: --out {out}: cannot write there (File name too long)"


def test_an_unreadable_family_file_is_left_out_and_the_good_families_run(tmp_path):
    """Before: the resume key read every file of the folder, a traceback after the dry run
    had left the file out."""
    cases = tmp_path / "cases"
    cases.mkdir()
    (cases / "good.py").write_text(_user_case(name="good"))
    (cases / "secret.py").write_text(_user_case(name="secret"))
    (cases / "secret.py").chmod(0)
    # MuJoCo, compiled ahead: the reference would compile its step with numba on a cold cache,
    # minutes at a high load, against this subprocess's 300 s (tests/test_execution.py R_COMPILED)
    run = ["run", "--cases-dir", str(cases), "--engines", "mujoco", "--readings", "none", "--workers", "1", "--quiet"]
    # the good family, then every family (into a folder of its own), one after the other in one process
    got, every = _physval_in_turn((*run, "--out", str(tmp_path / "out"), "--cases", "good"),
                                  (*run, "--out", str(tmp_path / "every")), prefix=A_USER())
    (line,) = got.stderr.strip().splitlines()
    assert got.returncode == 0 and line.startswith(f"physval: left out {cases / 'secret.py'}: cannot be loaded: "
                                                   "PermissionError"), got.stderr
    import csv
    assert {r["case"] for r in csv.DictReader(open(tmp_path / "out" / "results.csv"))} == {"good"}
    (line,) = every.stderr.strip().splitlines()  # every family: the one that cannot be read stops it
    assert every.returncode == 2 and str(cases / "secret.py") in line and "Permission denied" in line, every.stderr
    assert not (tmp_path / "every" / "results.csv").exists()


@pytest.mark.parametrize("folder, message", [("missing", "no such folder"),
                                             ("empty", "no results.csv in this folder")])
def test_the_report_rebuilt_from_a_folder_without_results_is_one_line(tmp_path, folder, message):
    """`python3 -m physval.readings.results FOLDER` (docs: reading the report): exit 2 and one line (before: a
    traceback, FileNotFoundError)."""
    import subprocess
    import sys
    (tmp_path / "empty").mkdir()
    got = subprocess.run([sys.executable, "-m", "physval.readings.results", str(tmp_path / folder)], cwd=ROOT,
                         capture_output=True, text=True, timeout=120)
    (line,) = got.stderr.strip().splitlines()
    assert got.returncode == 2 and line.startswith(f"python -m physval.readings.results: error: {tmp_path / folder}: "
                                                   f"{message}"), got.stderr
