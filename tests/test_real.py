"""The real-world tier (`physval real`, cases/cube_toss.py) on a small slice of the data: the
data's conventions, the start state and its scene, the error metrics, the fitter against
parameters it must recover, the fit on a Dask LocalCluster, and the command end to end.
Every simulation here is a few tosses over short horizons."""
from __future__ import annotations

import json
import math
from pathlib import Path

import numpy as np
import pandas as pd
import pytest
from scipy.spatial.transform import Rotation

from adapters import registry
from adapters.base import Settings
from cases import cube_toss as ct
from physval.cli import main
from physval.readings import real
from tests.helpers import skip_if_not_installed

pytestmark = pytest.mark.skipif(not registry.available("mujoco"), reason="the slice runs on MuJoCo")


@pytest.fixture(scope="module")
def tosses():
    return ct.load()


# --- the data ----------------------------------------------------------------------------------

def test_the_packaged_data_has_400_tosses_in_si_units(tosses):
    assert len(tosses) == 400
    # a cube resting on a face has its centre a half-width above the surface (SI: ~5 cm)
    assert np.median([tr.pos[-1, 2] for tr in tosses.values()]) == pytest.approx(ct.HALF, abs=2e-3)
    # samples every 1/148 s
    steps = np.concatenate([np.diff(tr.t) for tr in tosses.values()])
    assert np.median(steps) == pytest.approx(ct.SAMPLE_PERIOD, rel=1e-3)


def test_only_the_toss_a_hand_moved_after_rest_is_cut(tosses):
    raw = pd.read_csv(ct.DATA).groupby("toss").size()
    cut = {i: (len(tr), int(raw[i])) for i, tr in tosses.items() if len(tr) != raw[i]}
    assert cut == {127: (308, 442)}  # rests from sample 111 (0.75 s), moved from sample 308 on


def test_stored_angular_velocity_is_in_the_body_frame(tosses):
    """dq/dt = q (0, w) / 2 with body-frame w fits the quaternions' finite differences to the
    few per cent that finite-difference velocities carry; the world-frame reading of the same
    numbers, dq/dt = (0, w) q / 2, does not fit at all."""
    for toss_id in (0, 3, 101, 301):
        res = ct.omega_convention_residuals(tosses[toss_id])
        assert res["body"] < 0.15, res  # finite differences over 1/148 s: a few per cent off
        assert res["world"] > 5 * res["body"], res


def test_the_surface_constant_is_the_training_splits_resting_height(tosses):
    train, _ = ct.split(tosses)
    assert ct.rest_height(tosses, train) == pytest.approx(ct.SURFACE_Z, abs=1e-5)  # the constant's 2 digits


def test_the_split_is_fixed_by_parity_and_disjoint(tosses):
    train, test = ct.split(tosses)
    assert len(train) + len(test) == 400 and not set(train) & set(test)
    assert all(i % 2 == 0 for i in train) and all(i % 2 == 1 for i in test)
    assert (len(train), len(test)) == (209, 191)


# --- the start state and its scene -----------------------------------------------------------

@pytest.mark.parametrize("toss_id", [0, 3, 75])
def test_the_flight_fit_starts_before_contact_and_matches_the_measurement(tosses, toss_id):
    tr = tosses[toss_id]
    fit = ct.fit_flight(tr)
    assert fit.k0 < fit.contact
    # the fitted start is the measured one to the capture's noise (sub-millimetre; < 1 deg)
    assert np.linalg.norm(fit.p0 - tr.pos[fit.k0]) < 1e-3
    assert math.degrees(ct.angle_between(fit.q0, tr.quat[fit.k0])) < 1.0
    assert fit.residual_pos.max() < 2e-3  # a free flight: the worst toss departs 1.7 mm
    # the fitted world-frame spin is the stored body-frame one turned into the world frame
    w_world = ct.world_omega(tr)[:fit.contact - 1]
    assert np.linalg.norm(np.median(w_world, axis=0) - fit.w) < 0.1 * np.linalg.norm(fit.w) + 0.1


def test_the_scene_reproduces_the_start_state_in_an_engine(tosses):
    tr = tosses[3]
    fit = ct.fit_flight(tr)
    scene = ct.scene(tr, mu=0.3, e=0.2, fit=fit)
    cube = scene.body("cube")
    assert scene.material.mu_s == 0.3 and scene.material.e == 0.2
    assert cube.principal_inertia == (ct.INERTIA,) * 3 and cube.mass == ct.MASS
    with registry.get("mujoco").build(scene, Settings(dt=real.DT)) as sim:
        state = sim.states()["cube"]
    np.testing.assert_allclose(state[0:3], fit.p0, atol=1e-12)
    assert math.degrees(ct.angle_between(state[3:7], fit.q0)) < 1e-6
    np.testing.assert_allclose(state[7:10], fit.v0, atol=1e-12)
    np.testing.assert_allclose(state[10:13], fit.w, atol=1e-9)  # world-frame spin, read back


def test_the_ground_lies_at_the_measured_surface(tosses):
    scene = ct.scene(tosses[0])
    assert scene.body("ground").shape.offset == ct.SURFACE_Z


# --- metrics ------------------------------------------------------------------------------------

def _score(tr, pos, quat):
    fit = ct.fit_flight(tr)
    k = np.arange(fit.k0, len(tr))
    return real.score(tr, fit, tr.t[k] - fit.t0, np.column_stack([pos, quat])[k])


def test_an_identical_trajectory_scores_zero(tosses):
    tr = tosses[5]
    s = _score(tr, tr.pos, tr.quat)
    for m in real.metric_names():
        assert s[m] == pytest.approx(0.0, abs=1e-12), m  # rounding only
    assert s["same_face"] is True


@pytest.mark.parametrize("angle", [5.0, 30.0, 90.0])
def test_a_known_rotation_scores_its_angle(tosses, angle):
    tr = tosses[5]
    turn = Rotation.from_rotvec(np.radians(angle) * np.array([0.0, 0.0, 1.0]))  # about world z
    q = Rotation.from_quat(tr.quat[:, [1, 2, 3, 0]])
    turned = (turn * q).as_quat()[:, [3, 0, 1, 2]]
    s = _score(tr, tr.pos, turned)
    assert s["rot_final"] == pytest.approx(angle, abs=1e-6)
    assert s["pos_final"] == 0.0
    # corners of a cube turned by theta move by sqrt(2) sin(theta/2) widths, RMS
    assert s["corner_mean"] == pytest.approx(math.sqrt(2) * math.sin(math.radians(angle) / 2), rel=1e-9)
    assert s["same_face"] is True  # a turn about the vertical keeps the face down


def test_a_translation_scores_its_distance_in_widths(tosses):
    tr = tosses[5]
    s = _score(tr, tr.pos + [0.03, -0.04, 0.0], tr.quat)
    assert s["pos_final"] == pytest.approx(0.05 / ct.WIDTH, rel=1e-12)
    assert s["corner_mean"] == pytest.approx(0.05 / ct.WIDTH, rel=1e-12)


def test_a_quarter_turn_about_a_horizontal_axis_changes_the_face(tosses):
    tr = tosses[5]
    q = Rotation.from_quat(tr.quat[:, [1, 2, 3, 0]])
    tipped = (Rotation.from_rotvec([math.pi / 2, 0.0, 0.0]) * q).as_quat()[:, [3, 0, 1, 2]]
    assert _score(tr, tr.pos, tipped)["same_face"] is False


def test_a_start_state_drawn_from_its_uncertainty_is_near_and_clear_of_the_ground(tosses):
    for toss_id in (0, 3, 75):
        fit = ct.fit_flight(tosses[toss_id])
        a, b = fit.perturbed(7), fit.perturbed(7)
        np.testing.assert_array_equal(a.p0, b.p0)  # a seed gives one draw
        # within five standard deviations of the fit's own least-squares uncertainty
        sigma_p = np.sqrt(np.mean(fit.residual_pos ** 2) / 3 * fit.cov_unit[0, 0])
        assert 0 < np.abs(a.p0 - fit.p0).max() < 5 * sigma_p + 1e-6  # + a lift clear of the ground
        assert ct.lowest_corner(a.p0[None], a.q0[None])[0] > ct.SURFACE_Z


def test_an_engine_against_itself_from_the_same_start_scores_zero():
    rows = real.simulate_many("mujoco", real.nominal("mujoco"), [3, 5], keep=True, horizon=0.2)
    for r in rows:
        r["t_contact"] = 0.05
    for row in real.sensitivity(rows, rows, None):
        assert row["corner_mean"] == pytest.approx(0.0, abs=1e-12) and row["same_face"] is not False


def test_paired_difference_is_the_median_of_per_toss_differences():
    scores = pd.DataFrame({"engine": ["a"] * 5 + ["b"] * 5, "param_set": "fitted", "status": "ok",
                           "toss": list(range(5)) * 2, "corner_mean": [1, 2, 3, 4, 5, 0, 0, 0, 0, 10]})
    med, lo, hi, n = real.paired_difference(scores, ("a", "fitted"), ("b", "fitted"))
    assert (med, n) == (2.0, 5) and lo <= med <= hi  # differences 1, 2, 3, 4, -5


def test_the_noise_floor_is_small_but_not_zero(tosses):
    nf = ct.noise_floor(tosses[0])
    # the capture's noise: tens of micrometres and hundredths of a degree, not zero
    assert 0 < np.median(nf["pos_err"]) < 1e-2 and 0 < np.median(nf["rot_err"]) < 0.5


# --- simulation, row store, fit ---------------------------------------------------------------------

def test_a_tosss_job_is_kept_in_the_row_store_and_read_back_the_same(tmp_path):
    """Each batch of tosses is a job of the core whose rows (scores, and the poses of a batch
    that keeps them) stream to the engine's row store: a second runner reads them back as
    they were, and runs only the jobs the store lacks (what an interrupted run resumes)."""
    params = real.nominal("mujoco")
    with real.Runner(folder=tmp_path) as runner:
        first = real.simulate_many("mujoco", params, [3], runner=runner, keep=True, horizon=0.1)
    assert first[0]["status"] == "ok" and first[0]["cached"] is False
    store = tmp_path / "mujoco.csv"
    assert len(pd.read_csv(store)) == 1
    with real.Runner(folder=tmp_path) as runner:
        again = real.simulate_many("mujoco", params, [3, 5], runner=runner, keep=True, horizon=0.1, batch=1)
        other = real.simulate_many("mujoco", {**params, "mu": 0.3}, [3], runner=runner, keep=True, horizon=0.1)
    assert [r["cached"] for r in again] == [True, False] and other[0]["cached"] is False
    a, b = first[0], again[0]
    for k in ("poses", "corner_err"):
        np.testing.assert_array_equal(a["trajectory"][k], b["trajectory"][k])
    np.testing.assert_array_equal([a[k] for k in real.metric_names()], [b[k] for k in real.metric_names()])
    assert math.isfinite(a["corner_mean"])
    assert len(pd.read_csv(store)) == 3  # other parameters, another job


def test_the_mujoco_tunable_reaches_the_engine():
    p = real.nominal("mujoco")
    soft = real.simulate_toss("mujoco", 3, {**p, "contact_steps": 40.0}, horizon=0.1)
    stiff = real.simulate_toss("mujoco", 3, {**p, "contact_steps": 4.0}, horizon=0.1)
    assert np.abs(soft["poses"][:, :3] - stiff["poses"][:, :3]).max() > 1e-3  # millimetres apart after an impact


@pytest.mark.parametrize("params, message", [
    ({"pybullet": {"mu": 0.2, "contact_steps": 3}}, "not a parameter of pybullet"),
    ({"pybullet": {"mu": -0.1}}, "must be a number in"),
    ({"pybullet": {"e": 1.5}}, "must be a number in"),
    ({"pybullet": {"mu": "0.2"}}, "must be a number in"),
    ({"nope": {"mu": 0.2}}, "'nope' is not an engine"),
])
def test_bad_parameter_files_stop_before_any_work(params, message, tmp_path, capsys):
    """Each bad value gives one line naming engine, parameter and the allowed range, exit 2
    (on an installed PyBullet: `all` leaves it out on Python 3.12 and later, and the command
    then stops first at the missing engine)."""
    skip_if_not_installed("pybullet")
    path = tmp_path / "params.json"
    path.write_text(json.dumps(params))
    assert _cli("--engines", "pybullet", "--params", str(path), "--out", str(tmp_path / "out")) == 2
    err = capsys.readouterr().err
    assert message in err and len(err.strip().splitlines()) == 1
    assert not (tmp_path / "out" / "real_report.md").exists()


SYNTH_IDS = (0, 2, 4, 10)
SYNTH_HORIZON = 0.25  # s: past the first impacts, short of the chaotic tumbling that follows
TRUTH = {"mu": 0.35, "e": 0.3}


@pytest.fixture(scope="module")
def synthetic_file(tmp_path_factory):
    """Tosses 'measured' by MuJoCo at TRUTH: each toss's fitted free flight up to its start
    sample (exactly a free flight, so the flight fit gives back the same start state), then
    MuJoCo's poses at the sample times."""
    out = []
    params = {**real.nominal("mujoco"), **TRUTH}
    for i in SYNTH_IDS:
        tr = ct.toss(i)
        fit = ct.fit_flight(tr)
        r = real.simulate_toss("mujoco", i, params, SYNTH_HORIZON)
        k = np.arange(fit.k0 + 1)
        pf, qf = fit.state(tr.t[k] - fit.t0)
        pos, quat = np.vstack([pf, r["poses"][1:, :3]]), np.vstack([qf, r["poses"][1:, 3:7]])
        t = np.concatenate([tr.t[k], fit.t0 + r["t"][1:]])
        out.append(ct.Toss(i, t, pos, quat, np.gradient(pos, t, axis=0), np.zeros((len(t), 3))))
    path = tmp_path_factory.mktemp("synthetic") / "tosses.csv.gz"
    ct.save(out, path)
    return str(path)


def test_the_fit_recovers_the_parameters_that_made_the_measurements(synthetic_file):
    f = real.fit("mujoco", SYNTH_IDS, source=synthetic_file, names=("mu", "e"), popsize=8, generations=10)
    # MuJoCo is deterministic and the start states are the generating ones, so the loss at
    # TRUTH is 0 and rises by >= 0.015 widths per 0.01 of mu or e on these tosses: the best
    # point DE finds must be within two steps of the 0.005 grid
    assert f.params["mu"] == pytest.approx(TRUTH["mu"], abs=0.01)
    assert f.params["e"] == pytest.approx(TRUTH["e"], abs=0.01)
    assert f.loss < 0.01 < f.nominal_loss
    spread = f.bootstrap(50)
    assert len(spread) == 50 and all(abs(s["mu"] - TRUTH["mu"]) <= 0.01 for s in spread)


def test_the_fit_runs_unchanged_on_a_dask_local_cluster():
    distributed = pytest.importorskip("distributed")
    kw = dict(names=("mu", "e"), popsize=2, generations=1, horizon=0.15, batch=1)
    local = real.fit("mujoco", (0, 2), **kw)
    from physval.core.session import Execution
    with distributed.LocalCluster(n_workers=1, threads_per_worker=2, processes=False,
                                  dashboard_address=None) as cluster:
        with real.Runner(execution=Execution(scheduler=cluster.scheduler_address, progress=False)) as runner:
            remote = real.fit("mujoco", (0, 2), runner=runner, **kw)
    assert remote.params == local.params and remote.loss == local.loss
    assert remote.evaluations == local.evaluations > 1


# --- the command --------------------------------------------------------------------------------

def _cli(*argv) -> int:
    """The command as a user types it: through the one dispatcher."""
    return main(["real", *argv, "--quiet"])


def test_the_command_fits_scores_and_writes_the_report(tmp_path):
    out = tmp_path / "real"
    assert _cli("--engines", "mujoco", "--limit", "2", "--horizon", "0.15", "--generations", "0",
                "--popsize", "2", "--bootstrap", "10", "--out", str(out), "--no-cache") == 0
    for name in ("real_report.md", "real_scores.csv", "real_summary.csv", "real_fits.csv", "params.json",
                 "plots/horizons.png", "plots/overlay_mujoco.png"):
        assert (out / name).is_file(), name
    scores = pd.read_csv(out / "real_scores.csv")
    assert set(scores.param_set) == {"fitted", "nominal", "start noise", "data"}
    assert set(scores[scores.engine == "mujoco"].toss) == {3, 5}  # the first two test tosses (odd ids)
    report = (out / "real_report.md").read_text()
    assert "## Ranking (test split)" in report and "noise floor" in report
    params = json.loads((out / "params.json").read_text())
    assert set(params["mujoco"]) == {"mu", "e", "contact_steps"}


def test_an_engine_given_its_own_fit_limit_is_fitted_within_it(tmp_path):
    """--fit-limit ENGINE=S: the budget of the engines the glob matches; the last match wins,
    a plain S holds for the rest."""
    from physval.commands.real import FIT_LIMIT, fit_limit
    limits = [(None, 150.0), ("reference*", 900.0), ("reference-lemke", 1200.0)]
    assert [fit_limit(e, limits) for e in ("mujoco", "reference-pgs", "reference-lemke")] == [150, 900, 1200]
    assert fit_limit("mujoco", []) == FIT_LIMIT
    # a budget too small for even one toss leaves that engine nominal, and says whose budget it was
    out = tmp_path / "real"
    assert _cli("--engines", "mujoco", "--limit", "2", "--horizon", "0.15", "--generations", "0", "--popsize", "2",
                "--bootstrap", "10", "--fit-limit", "1e9", "--fit-limit", "mujoco=1e-6", "--out", str(out),
                "--no-cache") == 0
    assert "its --fit-limit 1e-06 s" in (out / "real_report.md").read_text()


def test_any_toss_file_is_scored_with_saved_parameters(tmp_path, synthetic_file):
    params = tmp_path / "params.json"
    params.write_text(json.dumps({"mujoco": {**real.nominal("mujoco"), **TRUTH}}))
    out = tmp_path / "mine"
    assert _cli("--engines", "mujoco", "--tosses", synthetic_file, "--params", str(params),
                "--out", str(out), "--no-cache") == 0
    scores = pd.read_csv(out / "real_scores.csv")
    fitted = scores[(scores.engine == "mujoco") & (scores.param_set == "fitted")]
    assert sorted(fitted.toss) == list(SYNTH_IDS)  # every toss of a user's file is scored
    # the parameters that made the file reproduce it exactly
    assert fitted.corner_mean.max() == pytest.approx(0.0, abs=1e-9)


@pytest.mark.parametrize("argv, message", [
    (("--engines", "nope"), "unknown engine"),
    (("--tosses", "/nonexistent.csv"), "no such toss file"),
    (("--params", "/nonexistent.json"), "cannot read"),
    (("--limit", "0"), "must be >= 1"),
    (("--horizon", "-1"), "must be a finite number > 0"),
    (("--fit-limit", "=900"), "give an engine name or glob before '='"),
    (("--fit-limit", "reference*=none"), "'none' is not a number"),
])
def test_bad_input_exits_with_2(argv, message, capsys, tmp_path):
    assert _cli(*argv, "--out", str(tmp_path)) == 2
    assert message in capsys.readouterr().err


# --- engines from outside the repository, and faults ------------------------------------------

FAKES = Path(__file__).with_name("fakes.py")
QUICK = ("--limit", "3", "--horizon", "0.2", "--workers", "1")


def test_an_adhoc_adapter_reaches_the_workers(tmp_path):
    """`--adapter path/file.py:Class` names an engine no registry lists: the command finds
    it, and every worker process builds and steps it (a worker that could not resolve it
    would leave error rows)."""
    out = tmp_path / "out"
    assert _cli("--adapter", f"{FAKES}:FaultAboveFriction", "--engines", "fake-fault", "--nominal", *QUICK,
                "--no-cache", "--out", str(out)) == 0
    scores = pd.read_csv(out / "real_scores.csv")
    mine = scores[scores.engine == "fake-fault"]
    assert sorted(mine[mine.param_set == "nominal"].toss) == [3, 5, 7]
    assert (mine.status == "ok").all() and (mine.steps > 0).all(), mine[["status", "message"]]


def test_an_edited_adhoc_adapter_is_simulated_again_not_read_from_the_store(tmp_path):
    adapter = tmp_path / "mine.py"
    code = ("from tests.fakes import FakeAdapter\n\nclass Mine(FakeAdapter):\n"
            "    def __init__(self):\n        super().__init__(name='fake-mine', dimensions=frozenset({3}))\n")
    adapter.write_text(code)

    def cached() -> set:
        out = tmp_path / "out"
        assert _cli("--adapter", f"{adapter}:Mine", "--engines", "fake-mine", "--nominal", *QUICK,
                    "--cache", str(tmp_path / "cache"), "--out", str(out)) == 0
        return set(pd.read_csv(out / "real_scores.csv").query("engine == 'fake-mine'").cached)

    assert cached() == {False}
    assert cached() == {True}   # unchanged: every simulation read back
    adapter.write_text(code + "    # edited\n")
    assert cached() == {False}  # its source changed: simulated again


# A worker's first job loads the toss data (~1 CPU s): the time limit leaves room for that
# on a loaded machine (10 s was exceeded by a nominal toss at a load of 16 on 2 cores), and only the hanging jobs
# (the given parameters', one per toss) wait it out: on two workers, side by side (20 s of the test's wall, not 40).
@pytest.mark.parametrize("fault, limit, why", [("FaultAboveFriction", "900", "the engine raised NotImplementedError"),
                                               ("SegfaultAboveFriction", "900", "killed by signal SIGSEGV"),
                                               ("HangAboveFriction", "20", "per-job time limit of 20 s")])
def test_a_toss_whose_worker_dies_or_hangs_costs_only_its_job(fault, limit, why, tmp_path):
    """The fake engine raises in a step, crashes its worker or hangs at friction above 0.3
    and runs below: each of the given parameters' tosses (a job of its own) becomes an
    error row naming the exception, the signal or the limit, the nominal ones are scored,
    and the command completes with its report."""
    from tests import fakes
    engine = getattr(fakes, fault).name_
    params, out = tmp_path / "params.json", tmp_path / "out"
    params.write_text(json.dumps({engine: {"mu": 0.5}}))
    assert _cli("--adapter", f"{FAKES}:{fault}", "--engines", engine, "--params", str(params), *QUICK,
                "--limit", "2", "--workers", "2", "--job-timeout", limit, "--no-cache", "--out", str(out)) == 0
    scores = pd.read_csv(out / "real_scores.csv")
    nominal, given = (scores[(scores.engine == engine) & (scores.param_set == p)] for p in ("nominal", "fitted"))
    assert sorted(nominal.toss) == sorted(given.toss) == [3, 5]
    assert (nominal.status == "ok").all(), nominal.message
    assert (given.status == "error").all() and given.message.str.contains(why).all(), given.message
    assert given.corner_mean.isna().all() and (given.loss == real.FAIL_LOSS).all()
    assert "## Failed simulations" in (out / "real_report.md").read_text()


SLOW = '''
import time
from tests.fakes import FakeAdapter

class Slow(FakeAdapter):
    """Takes half a second to build each toss's scene."""
    def __init__(self):
        super().__init__(name="fake-slow", dimensions=frozenset({3}))

    def build(self, scene, settings):
        time.sleep(0.5)
        return super().build(scene, settings)
'''


# Two starts of physval and a worker each: 69 s on this loaded machine, so on demand; the
# read-back it rests on is checked in the default suite (test_a_tosss_job_is_kept_...).
@pytest.mark.slow
def test_an_interrupted_run_keeps_what_it_finished_and_the_same_command_resumes(tmp_path):
    """Ctrl-C once some tosses are done: exit 130, their jobs kept in the engine's row
    store; the same command again reads those back and simulates only the rest."""
    import signal
    import subprocess
    import sys
    import time
    (tmp_path / "slow.py").write_text(SLOW)
    argv = ["--adapter", f"{tmp_path / 'slow.py'}:Slow", "--engines", "fake-slow", "--nominal", "--limit", "4",
            "--horizon", "0.1", "--workers", "1", "--cache", str(tmp_path / "cache"), "--out", str(tmp_path / "out")]
    proc = subprocess.Popen([sys.executable, "-m", "physval", "real", *argv, "--quiet"], cwd=FAKES.parent.parent,
                            stderr=subprocess.PIPE, text=True)
    store = tmp_path / "cache" / "fake-slow.csv"
    deadline = time.monotonic() + 180
    while time.monotonic() < deadline and proc.poll() is None and not (
            store.is_file() and len(pd.read_csv(store)) >= 2):
        time.sleep(0.1)
    proc.send_signal(signal.SIGINT)
    err = proc.communicate(timeout=120)[1]
    assert proc.returncode == 130, err
    kept = len(pd.read_csv(store))
    assert 2 <= kept < 8  # 4 tosses at nominal, 4 from a drawn start: not all done
    assert _cli(*argv) == 0
    mine = pd.read_csv(tmp_path / "out" / "real_scores.csv").query("engine == 'fake-slow'")
    assert len(mine) == 8 and (mine.status == "ok").all() and mine.cached.sum() == kept


# --- the output folder --------------------------------------------------------------------------

@pytest.mark.parametrize("option", ["--out", "--cache"])
def test_a_folder_option_naming_a_file_stops_before_any_work(option, tmp_path, capsys):
    mine = tmp_path / "report.md"
    mine.write_text("mine")
    folders = {"--out": str(tmp_path / "out"), "--cache": str(tmp_path / "cache"), option: str(mine)}
    assert _cli("--engines", "mujoco", "--limit", "2", *(x for pair in folders.items() for x in pair)) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and f"{option} {mine}: exists and is not a folder" in err[0]
    # nothing simulated, nothing cached, nothing written
    assert mine.read_text() == "mine" and not (tmp_path / "cache").exists()
    assert not (tmp_path / "out" / "real_scores.csv").exists()


VANDAL = """
import pathlib, shutil
from tests.fakes import FakeAdapter

class Vandal(FakeAdapter):
    '''Replaces the run's --out folder by a file when it first builds a scene.'''
    def __init__(self):
        super().__init__(name="fake-vandal", dimensions=frozenset({{3}}))

    def build(self, scene, settings):
        out = pathlib.Path({out!r})
        if out.is_dir():
            shutil.rmtree(out)
            out.write_text("in the way")
        return super().build(scene, settings)
"""


def test_an_out_that_goes_away_during_the_run_keeps_the_results(tmp_path, capsys, monkeypatch):
    """--out is replaced by a file while the engine runs: the report and every result go to
    a new folder, one line on stderr names it, exit 1."""
    import tempfile
    monkeypatch.setattr(tempfile, "tempdir", str(tmp_path / "tmp"))
    (tmp_path / "tmp").mkdir()
    out = tmp_path / "out"
    (tmp_path / "vandal.py").write_text(VANDAL.format(out=str(out)))
    assert _cli("--adapter", f"{tmp_path / 'vandal.py'}:Vandal", "--engines", "fake-vandal", "--nominal", *QUICK,
                "--no-cache", "--out", str(out)) == 1
    assert out.read_text() == "in the way"
    (line,) = capsys.readouterr().err.strip().splitlines()
    (rescue,) = (tmp_path / "tmp").glob("physval-real-*")  # (multiprocessing keeps its own folders there too)
    assert f"cannot write to --out {out}" in line and str(rescue) in line
    scores = pd.read_csv(rescue / "real_scores.csv")
    assert sorted(scores[scores.param_set == "nominal"].toss) == [3, 5, 7]
    assert (rescue / "real_report.md").is_file() and (rescue / "params.json").is_file()


def test_an_engine_with_an_unbounded_parameter_fits_the_others_and_its_params_are_taken_back(tmp_path):
    """Rapier's push-out stiffness ranges up to inf (no cap, its default): the fit searches
    the parameters with a finite range and holds that one at its default (the command
    crashed in scipy's bounds check after 44 minutes of a full run), and writes it so (JSON's
    Infinity). A round trip: --params takes that file back (before: 'must be a number in
    [1, inf]')."""
    if not registry.available("rapier"):
        pytest.skip("rapier3d is not installed")
    assert "contact_natural_frequency" not in real.fitted_names("rapier")
    out = tmp_path / "real"
    assert _cli("--engines", "rapier", "--limit", "1", "--horizon", "0.1", "--generations", "0", "--popsize", "1",
                "--bootstrap", "2", "--workers", "1", "--out", str(out), "--no-cache") == 0
    params = json.loads((out / "params.json").read_text())["rapier"]
    assert params["contact_natural_frequency"] == math.inf
    again = tmp_path / "again"
    assert _cli("--engines", "rapier", "--params", str(out / "params.json"), "--limit", "1", "--horizon", "0.1",
                "--workers", "1", "--out", str(again), "--no-cache") == 0
    assert json.loads((again / "params.json").read_text())["rapier"] == params


# --- --params and what `physval real` writes (issue 33) ----------------------------------------

def test_a_params_file_of_more_engines_than_the_run_takes_the_runs_and_names_the_rest(tmp_path, capsys):
    """The parameters of engines outside the run (another selection, an engine not installed
    here, as in the committed reports/real/params.json) are left out, named in one line
    (before: exit 2, "engine 'mujoco-warp' is not installed", unless every extra was)."""
    params = tmp_path / "params.json"
    params.write_text(json.dumps({"mujoco": real.nominal("mujoco"), "pybullet": {"mu": 0.3},
                                  "mujoco-warp": {"mu": 0.3, "e": 0.2}}))
    assert _cli("--engines", "mujoco", "--params", str(params), "--limit", "1", "--horizon", "0.1", "--workers", "1",
                "--out", str(tmp_path / "out"), "--no-cache") == 0
    (line,) = capsys.readouterr().err.strip().splitlines()
    assert line == (f"physval real: --params {params}: the parameters of 2 engine(s) outside this run left out: "
                    "pybullet, mujoco-warp"), line
    assert set(json.loads((tmp_path / "out" / "params.json").read_text())) == {"mujoco"}


def test_a_fit_limit_for_no_engine_of_the_run_stops_before_any_work(tmp_path, capsys):
    """Before: taken in silence (a typo in the glob gave the engine the default budget)."""
    assert _cli("--engines", "mujoco", "--fit-limit", "mujco=60", "--out", str(tmp_path / "out")) == 2
    (line,) = capsys.readouterr().err.strip().splitlines()
    assert line == "physval: error: --fit-limit mujco=60: 'mujco' matches none of this run's engines (mujoco)"
    assert not (tmp_path / "out").exists()


def test_a_toss_is_priced_by_one_that_was_not_its_workers_first():
    """A worker's first toss of an engine holds the engine's start (Genesis: 17 CPU s for a
    2 s toss), which priced the scoring of slow engines at many times their cost: a toss is
    priced by the later ones, or by the least where none is known to be later (read back
    from the store, which does not keep the mark)."""
    from physval.readings.real import toss_cost
    rows = [{"elapsed_cpu": 17.0, "first_in_worker": 1}, {"elapsed_cpu": 2.0, "first_in_worker": 0},
            {"elapsed_cpu": 2.4, "first_in_worker": 0}, {"elapsed_cpu": 16.5, "first_in_worker": 1}]
    assert toss_cost(rows) == pytest.approx(2.2)
    assert toss_cost([{"elapsed_cpu": 17.0, "first_in_worker": math.nan},
                      {"elapsed_cpu": 2.0, "first_in_worker": math.nan}]) == 2.0
