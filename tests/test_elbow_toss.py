"""The elbow tosses (cases/elbow_toss.py, `physval real --data elbow_toss`) on a small slice:
the data's units and conventions, the model's kinematics, the start state and its scene,
the hinge through an engine, and the command end to end. Every simulation here is a few
tosses over short horizons on MuJoCo."""
from __future__ import annotations

import io

import numpy as np
import pandas as pd
import pytest

from adapters import registry
from cases import cube_toss as ct
from cases import elbow_toss as et
from physval.cli import main
from physval.readings import real

needs_mujoco = pytest.mark.skipif(not registry.available("mujoco"), reason="the slice runs on MuJoCo")


@pytest.fixture(scope="module")
def tosses():
    return et.load()


# --- the data ----------------------------------------------------------------------------------

def test_the_packaged_data_has_541_tosses_sampled_at_148_hz(tosses):
    assert len(tosses) == 541
    steps = np.concatenate([np.diff(tr.t) for tr in tosses.values()])
    assert np.median(steps) == pytest.approx(et.SAMPLE_PERIOD, abs=1e-6)  # t is written to 1 us


def test_the_centre_of_mass_falls_at_g_before_the_first_contact(tosses):
    """Units and time base together: in free flight the centre of mass of the two links
    (whatever the hinge does) falls at g. Measured: a median 9.58 m/s^2 over the 12 samples
    before first contact (484 tosses), 2.4 % short of 9.81; a time base of dair_pll's 6.8 ms
    would read 9.47, and lengths in the cube's half-width (0.0524 m, not 0.05) 10.0. The 4 %
    band holds the measured value and excludes neither; 1/148 s and metres are the source's."""
    acc = []
    for tr in tosses.values():
        kc = et.first_contact(tr)
        if kc >= 12:
            z = et.centre_of_mass(et.poses(tr)[kc - 12:kc])[:, 2]
            acc.append(2 * np.polyfit(tr.t[kc - 12:kc], z, 2)[0])
    assert len(acc) > 400
    assert -np.median(acc) == pytest.approx(et.G, rel=0.04)


def test_stored_angular_velocity_is_in_the_base_links_body_frame(tosses):
    for toss_id in (0, 3, 101, 301):
        res = ct.omega_convention_residuals(tosses[toss_id])
        assert res["body"] < 0.2, res  # finite differences over 1/148 s
        assert res["world"] > 4 * res["body"], res


def test_every_toss_ends_with_its_lowest_corner_on_the_surface(tosses):
    assert et.rest_height(tosses) == pytest.approx(et.SURFACE_Z, abs=1e-6)


# --- the model --------------------------------------------------------------------------------

def test_the_hinge_angle_read_from_both_links_is_the_stored_one(tosses):
    tr = tosses[5]
    _, q1, _, q2 = et.links(et.poses(tr))
    wrapped = np.angle(np.exp(1j * (et.hinge_angle(q1, q2) - tr.theta)))
    assert np.abs(wrapped).max() < 1e-12


def test_at_zero_angle_the_bars_lie_side_by_side_a_centimetre_apart():
    pose = np.array([0.0, 0.0, 0.5, 1.0, 0.0, 0.0, 0.0, 0.0])
    p1, _, p2, _ = et.links(pose)
    np.testing.assert_allclose(p2 - p1, [[0.0, 0.06, 0.0]], atol=1e-15)
    gap = (p2 - p1)[0, 1] - 2 * et.HALF[1]
    assert gap == pytest.approx(0.01)


def test_the_start_state_keeps_the_hinge_together(tosses):
    """Both links carry the hinge's point: its position and its velocity computed from
    either link agree (the scene starts with the joint satisfied)."""
    for toss_id in (1, 3, 7):
        fit = et.fit_flight(tosses[toss_id])
        p1, q1, p2, q2 = et.links(fit.pose())
        v1, w1, v2, w2 = et.start_velocities(fit)
        from_1 = p1[0] + ct.rotate(q1, et.HINGE[None, :])[0]
        from_2 = p2[0] - ct.rotate(q2, et.ARM[None, :])[0]
        np.testing.assert_allclose(from_1, from_2, atol=1e-12)
        np.testing.assert_allclose(v1 + np.cross(w1, from_1 - p1[0]), v2 + np.cross(w2, from_2 - p2[0]), atol=1e-12)
        sc = et.scene(tosses[toss_id], fit=fit)
        assert {"joint", "contact", "friction", "restitution"} <= sc.effects
        np.testing.assert_allclose(sc.joints[0].anchor, from_1)


def test_the_start_fit_reproduces_the_samples_it_fits_to_the_captures_noise(tosses):
    residuals = [np.sqrt(np.mean(et.fit_flight(tosses[i]).residual_pos ** 2)) for i in range(1, 60, 2)
                 if et.first_contact(tosses[i]) >= et.FIT_SAMPLES]
    assert 0 < np.median(residuals) < 5e-4  # m: tenths of a millimetre, the capture's noise


def test_a_start_drawn_from_its_uncertainty_moves_a_little(tosses):
    fit = et.fit_flight(tosses[3])
    drawn = fit.perturbed(3)
    assert 0 < np.abs(drawn.p0 - fit.p0).max() < 5e-3
    assert et.lowest_corner(drawn.pose())[0] > et.SURFACE_Z


def test_identical_poses_score_zero_and_a_shift_scores_its_length(tosses):
    tr = tosses[7]
    fit = et.fit_flight(tr)
    k = np.arange(fit.k0, len(tr))
    same = real.score(tr, fit, tr.t[k] - fit.t0, et.poses(tr)[k], family="elbow_toss")
    assert same["corner_mean"] == pytest.approx(0.0, abs=1e-12) and same["same_face"] is True
    shifted = et.poses(tr)[k] + [0.03, 0.04, 0.0, 0, 0, 0, 0, 0]
    moved = real.score(tr, fit, tr.t[k] - fit.t0, shifted, family="elbow_toss")
    assert moved["corner_mean"] == pytest.approx(0.05 / et.LENGTH, rel=1e-9)  # 5 cm = half a bar


# --- through an engine ------------------------------------------------------------------------

@needs_mujoco
def test_mujoco_starts_from_the_measured_start_sample(tosses):
    """The scene built from the fitted start state, read back through the engine's recorded
    states (both links, the hinge angle from their orientations), is the start sample to
    the fit's residual: tenths of a millimetre."""
    row = real.simulate_toss("mujoco", 7, real.nominal("mujoco", family="elbow_toss"), horizon=0.02,
                             family="elbow_toss")
    assert row["status"] == "ok", row["message"]
    assert row["corner_err"][0] < 0.005  # bar lengths: 0.5 mm


@needs_mujoco
def test_mujocos_free_flight_of_the_elbow_follows_the_measured_one(tosses):
    """The hinge's conventions, end to end: started 10 samples before the first contact,
    MuJoCo's free flight of the two links follows the measured one over those 61 ms to a few
    millimetres and degrees (measured: at most 6.2 mm and 3.4 deg over these 8 tosses), where
    a hinge rate of the wrong sign would miss by twice its rate times the time (toss 134
    turns its hinge at 6.4 rad/s: 45 deg)."""
    from adapters.base import Settings
    from physval.core.context import Context
    from physval.core.jobs import run_scene
    adapter = Context().resolver().adapter("mujoco")
    ids = [i for i in sorted(tosses) if et.first_contact(tosses[i]) >= 22][:8]
    assert 134 in ids
    for toss_id in ids:
        tr = tosses[toss_id]
        fit = et.fit_flight(tr, before=et.first_contact(tr) - 10)
        k = np.arange(fit.k0, fit.k0 + 10)
        steps = np.rint((tr.t[k] - fit.t0) / real.DT).astype(int)
        run, _ = run_scene(adapter, et.scene(tr, fit=fit), Settings(dt=real.DT), int(steps[-1]))
        poses = et.read_poses(run.trajectory.states, steps)
        assert et.corner_error(poses, et.poses(tr)[k]).max() < 0.1, toss_id  # bar lengths: 1 cm
        hinge = np.angle(np.exp(1j * (poses[:, 7] - tr.theta[k])))
        assert np.degrees(np.abs(hinge)).max() < 6, toss_id


@needs_mujoco
def test_the_elbow_is_scored_by_physval_real_and_jointless_engines_are_named(tmp_path, capsys):
    out = tmp_path / "out"
    assert main(["real", "--data", "elbow_toss", "--engines", "mujoco,reference-force", "--nominal", "--limit", "1",
                 "--horizon", "0.1", "--workers", "1", "--no-cache", "--quiet", "--out", str(out)]) == 0
    report = (out / "real_report.md").read_text()
    assert "measured elbow tosses" in report and "bar lengths" in report
    assert "reference-force: unsupported: builds no revolute joint" in report
    scores = pd.read_csv(out / "real_scores.csv")
    mine = scores[(scores.engine == "mujoco") & (scores.param_set == "nominal")]
    assert len(mine) == 1 and (mine.status == "ok").all() and mine.corner_mean.notna().all()
    assert "mu 0.3" in report  # the URDF's friction, the elbow's nominal


@needs_mujoco
def test_an_elbow_job_is_kept_in_the_row_store_and_read_back_the_same(tmp_path):
    params = real.nominal("mujoco", family="elbow_toss")
    with real.Runner(folder=tmp_path) as runner:
        first = real.simulate_many("mujoco", params, [3], runner=runner, keep=True, horizon=0.1, family="elbow_toss")
    with real.Runner(folder=tmp_path) as runner:
        again = real.simulate_many("mujoco", params, [3], runner=runner, keep=True, horizon=0.1, family="elbow_toss")
    assert first[0]["cached"] is False and again[0]["cached"] is True
    np.testing.assert_array_equal(first[0]["trajectory"]["poses"], again[0]["trajectory"]["poses"])
    assert first[0]["trajectory"]["poses"].shape[1] == et.POSE_SIZE


# --- the conversion of the source files --------------------------------------------------------

def _converter():
    import importlib.util
    spec = importlib.util.spec_from_file_location("convert_elbow", et.DATA.parent.parent / "convert_elbow.py")
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def _torch_save(path, array: np.ndarray, monkeypatch) -> None:
    """A file laid out as torch.save writes a float64 tensor (a zip: archive/data.pkl naming
    the storage by a persistent id, archive/data/0 its raw little-endian bytes), made without
    PyTorch: stand-in modules give the pickle torch's global names."""
    import collections
    import pickle
    import sys
    import types
    import zipfile
    torch, utils = types.ModuleType("torch"), types.ModuleType("torch._utils")

    def _rebuild_tensor_v2(*args):
        raise AssertionError("only pickled here, never called")
    _rebuild_tensor_v2.__module__, _rebuild_tensor_v2.__qualname__ = "torch._utils", "_rebuild_tensor_v2"
    storage_type = type("DoubleStorage", (), {"__module__": "torch"})
    torch.DoubleStorage, torch._utils, utils._rebuild_tensor_v2 = storage_type, utils, _rebuild_tensor_v2
    monkeypatch.setitem(sys.modules, "torch", torch)
    monkeypatch.setitem(sys.modules, "torch._utils", utils)
    storage = object()

    class Tensor:
        def __reduce__(self):
            return _rebuild_tensor_v2, (storage, 0, array.shape, (array.shape[1], 1), False, collections.OrderedDict())

    class Pickler(pickle.Pickler):
        def persistent_id(self, obj):
            return ("storage", storage_type, "0", "cpu", array.size) if obj is storage else None
    buf = io.BytesIO()
    Pickler(buf, protocol=2).dump(Tensor())
    with zipfile.ZipFile(path, "w") as z:
        z.writestr("archive/data.pkl", buf.getvalue())
        z.writestr("archive/data/0", np.ascontiguousarray(array, "<f8").tobytes())
        z.writestr("archive/version", "3\n")


def test_the_converter_maps_dair_pll_s_state_order_onto_the_columns(tmp_path, monkeypatch):
    """dair_pll's order [q (4), p (3), theta, w (3, body), v (3), dtheta] lands in the named
    columns: each source column holds its own index, so every value says where it came from."""
    conv = _converter()
    source = np.tile(np.arange(15, dtype=float), (3, 1)) + np.arange(3)[:, None] * 100
    (tmp_path / "src").mkdir()
    _torch_save(tmp_path / "src" / "7.pt", source, monkeypatch)
    np.testing.assert_array_equal(conv.read_pt(tmp_path / "src" / "7.pt"), source)
    frame = pd.read_csv(io.StringIO(conv.convert(tmp_path / "src")))
    assert list(frame.columns) == list(et.COLUMNS)
    first = frame.iloc[0]
    expected = {"qw": 0, "qx": 1, "qy": 2, "qz": 3, "x": 4, "y": 5, "z": 6, "theta": 7, "wx": 8, "wy": 9, "wz": 10,
                "vx": 11, "vy": 12, "vz": 13, "dtheta": 14}
    assert {c: first[c] for c in expected} == expected
    assert list(frame.toss) == [7, 7, 7] and frame.t.iloc[2] == pytest.approx(2 * et.SAMPLE_PERIOD, abs=1e-6)


def test_the_converter_refuses_a_pickle_that_is_not_a_tensor(tmp_path):
    import pickle
    import zipfile
    conv = _converter()
    with zipfile.ZipFile(tmp_path / "1.pt", "w") as z:
        z.writestr("archive/data.pkl", pickle.dumps(print, protocol=2))
    with pytest.raises(pickle.UnpicklingError, match="print: not part of a saved float64 tensor"):
        conv.read_pt(tmp_path / "1.pt")


def test_a_toss_file_without_the_hinge_columns_stops_before_any_work(tmp_path, capsys):
    """The cube's file given as elbow tosses: one line naming the missing columns, exit 2."""
    out = tmp_path / "out"
    assert main(["real", "--data", "elbow_toss", "--tosses", str(ct.DATA), "--out", str(out)]) == 2
    err = capsys.readouterr().err
    assert "missing columns theta, dtheta" in err and len(err.strip().splitlines()) == 1
    assert not out.exists()
