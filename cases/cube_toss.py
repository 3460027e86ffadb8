"""Measured cube tosses (the real-world tier): the data, the cube, and a scene per toss.

The data (`cases/data/cube_toss/`, README and BSD 3-Clause LICENSE beside it) are 400
motion-captured tosses of one acrylic cube onto one flat surface, from the ContactNets data
set, in SI units: per sample the centre position, the orientation quaternion (w, x, y, z,
body to world), the centre velocity (world frame) and the angular velocity in the BODY
frame, so that dq/dt = q * (0, w) / 2 (tests/test_real.py checks this on the data).

What this module decides, engine-neutrally:

- **Start state: the last sample before first contact, taken from a fit of the free
  flight.** Before its first contact the cube is a free rigid body under gravity, and its
  inertia is isotropic (a cube), so the centre follows a parabola and the angular velocity
  is constant in the world frame: q(t) = Exp(w (t - t0)) q(t0) (note 001, free rigid body:
  with I = I 1 the gyroscopic term w x I w vanishes). Fitting that motion to all pre-contact
  samples (typically 10-15) averages the measurement noise that a single sample carries
  (stored velocities are finite differences, a few per cent off), and starting just before
  the impact spends no simulated time on a flight every engine gets right: the errors then
  measure contact, and horizons count from the first impact. The first sample would carry
  the same fitted state forward through the flight; it would add cost, not information.
- **First contact**: the first sample whose lowest corner is within CONTACT_BAND = 1 mm of
  the surface (or below it), or the sample after an upward kick of the vertical velocity
  (an impact between two samples whose rebound clears the band; in the packaged data the
  band always comes first). Resting corners scatter by about 0.4 mm (standard deviation
  of the final samples' lowest corners), so a threshold at the surface itself misses
  grazing first contacts; 1 mm is 1 ms of fall at a typical 1 m/s, under a sample period.
- **The surface** lies SURFACE_Z = -1.13 mm below the data's z = 0: the median height of
  the cube's centre over the final (resting) samples of the training split is 1.13 mm less
  than the half-width (a face-down cube at rest has its centre at the half-width). The
  final samples give a level surface (slopes 3e-5 along x and 2.5e-4 along y): one
  horizontal plane. The offset is a property of the capture set-up (marker placement or the
  plane's calibration), not of any engine, so every scene's ground is put there.
- **Disturbed tosses are cut** where a cube that had come to rest is moved again
  (`disturbed_from`): nothing but a hand moves a resting cube. One toss of the packaged
  data (127) is cut this way, at 2.07 s of its 2.99 s.
- **Split**: tosses with an even id train, odd ids test (209 and 191 tosses). Ids are the
  original file numbers in recording order, so both halves span the whole session.
- **Noise floor**: how far the measured trajectory is from itself smoothed (a quadratic
  least-squares fit over 5 samples, 27 ms, on positions and on orientations: Savitzky-Golay),
  and how far the free-flight samples are from their exact free-flight fit. That fit's
  residuals also give the start state's uncertainty (`FlightFit.perturbed`): a simulation
  from a start state drawn from it shows how far the capture's noise alone, amplified by
  the impacts, carries an engine's prediction.
"""
from __future__ import annotations

import functools
from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np

from cases import rotations
from cases.scene import Body, Box, Material, Plane, Scene

if TYPE_CHECKING:
    from scipy.spatial.transform import Rotation

DATA = Path(__file__).parent / "data" / "cube_toss" / "cube_tosses.csv.gz"
COLUMNS = ("toss", "step", "t", "x", "y", "z", "qw", "qx", "qy", "qz", "vx", "vy", "vz", "wx", "wy", "wz")

# The cube and the set-up, from the data set's experiment description (README beside the data).
HALF = 0.052401                 # m, half-width a (g = 187.2137 a/s^2 scaled to 9.81 m/s^2)
WIDTH = 2 * HALF                # m: the unit of position errors
MASS = 0.37                     # kg
INERTIA = 0.2950 * HALF**2      # kg m^2 about every principal axis (8.10e-4; the data set's value,
                                # 20 % above a uniform solid cube's m (2a)^2 / 6 = 6.77e-4)
G = 9.81                        # m/s^2
SAMPLE_PERIOD = 1.0 / 148.0     # s
MU_NOMINAL = 0.18               # the data set's nominal friction coefficient
E_NOMINAL = 0.125               # and restitution
SURFACE_Z = -1.13e-3            # m, see the module notes (tests recompute it from the data)
CONTACT_BAND = 1e-3             # m, see the module notes
# m/s: an upward change of the vertical velocity between consecutive sample intervals this
# large is an impact. In the measured free flights it stays within 0.13 m/s (standard
# deviation 0.007 m/s over 4500 samples: position noise through a second difference); an
# impact at 1 m/s with e = 0.1 changes it by ~1.1 m/s.
KICK = 0.3

# The eight corners in the body frame.
CORNERS = HALF * np.array([[sx, sy, sz] for sx in (-1, 1) for sy in (-1, 1) for sz in (-1, 1)], float)
# The six outward face normals in the body frame, in the order face_down() numbers them.
FACES = np.array([[1, 0, 0], [-1, 0, 0], [0, 1, 0], [0, -1, 0], [0, 0, 1], [0, 0, -1]], float)
FACE_NAMES = ("+x", "-x", "+y", "-y", "+z", "-z")


class TossError(ValueError):
    """A toss file or toss that cannot be used; the message says why."""


# --- quaternions (w, x, y, z), vectorised over rows ---------------------------------------

@functools.cache
def _rotation():
    """scipy's Rotation, imported when first used: the import takes 0.16 s, which every
    physval command (its parser names the `real` command) would otherwise pay."""
    from scipy.spatial.transform import Rotation
    return Rotation


def _to_scipy(q: np.ndarray) -> Rotation:
    q = np.atleast_2d(q)
    return _rotation().from_quat(q[:, [1, 2, 3, 0]])


def _from_scipy(r: Rotation) -> np.ndarray:
    q = np.atleast_2d(r.as_quat())
    return q[:, [3, 0, 1, 2]]


def rotate(q: np.ndarray, v: np.ndarray) -> np.ndarray:
    """Body-frame vectors v turned into the world frame by the quaternions q (rows)."""
    return _to_scipy(q).apply(v)


def angle_between(p: np.ndarray, q: np.ndarray) -> np.ndarray:
    """Geodesic angle (rad) between orientations, row by row: the angle of the rotation
    r = p^-1 q, 2 atan2(|r_xyz|, |r_w|) (q and -q are the same orientation; unlike
    2 acos |<p, q>| this is exact near 0)."""
    r = rotations.multiply(rotations.conjugate(p), q)
    return 2.0 * np.arctan2(np.linalg.norm(r[..., 1:], axis=-1), np.abs(r[..., 0]))


# --- the data -------------------------------------------------------------------------------

@dataclass(frozen=True, eq=False)
class Toss:
    """One measured toss: sample times from 0 and the measured state, per sample."""
    id: int
    t: np.ndarray       # (n,) s
    pos: np.ndarray     # (n, 3) m, world
    quat: np.ndarray    # (n, 4) w, x, y, z, body to world; sign made continuous
    vel: np.ndarray     # (n, 3) m/s, world
    omega: np.ndarray   # (n, 3) rad/s, BODY frame (as stored)

    def __len__(self) -> int:
        return len(self.t)

    @property
    def duration(self) -> float:
        return float(self.t[-1] - self.t[0])


def _continuous(q: np.ndarray) -> np.ndarray:
    """Flip signs so consecutive quaternions lie in one hemisphere (q and -q are one
    orientation; a continuous sign makes differences meaningful)."""
    q = q / np.linalg.norm(q, axis=1, keepdims=True)
    flip = np.sign(np.sum(q[1:] * q[:-1], axis=1))
    flip[flip == 0] = 1.0
    return q * np.concatenate([[1.0], np.cumprod(flip)])[:, None]


# A cube is at rest while its centre moves slower than REST_SPEED and it turns slower than
# REST_TURN for REST_SAMPLES samples (0.1 s; the capture's noise at rest reads ~0.005 m/s
# and ~1 deg/s); it is moved again (by hand: nothing else acts on a cube at rest) when
# either exceeds MOVE_SPEED or MOVE_TURN for MOVE_SAMPLES samples.
REST_SPEED, REST_TURN, REST_SAMPLES = 0.02, 10.0, 15      # m/s, deg/s, samples
MOVE_SPEED, MOVE_TURN, MOVE_SAMPLES = 0.1, 30.0, 3        # m/s, deg/s, samples


def _first_run(mask: np.ndarray, n: int) -> int | None:
    """Start of the first run of n True values in mask, or None."""
    run = 0
    for k, m in enumerate(mask.tolist()):
        run = run + 1 if m else 0
        if run >= n:
            return k - n + 1
    return None


def disturbed_from(tr: Toss) -> int | None:
    """Index of the first sample after the cube, having come to rest, was moved again, or
    None. In the packaged data one toss (127) is: it rests from 0.75 s and is slid and
    turned at up to 0.9 m/s and 130 deg/s from 2.07 s on."""
    h = np.diff(tr.t)
    speed = np.linalg.norm(np.diff(tr.pos, axis=0), axis=1) / h
    turn = np.degrees(angle_between(tr.quat[1:], tr.quat[:-1])) / h
    rest = _first_run((speed < REST_SPEED) & (turn < REST_TURN), REST_SAMPLES)
    if rest is None:
        return None
    moved = _first_run((speed[rest:] > MOVE_SPEED) | (turn[rest:] > MOVE_TURN), MOVE_SAMPLES)
    return None if moved is None else rest + moved + 1


def _cut(tr: Toss) -> Toss:
    """The toss up to where a cube at rest was moved again (disturbed_from), if it was."""
    k = disturbed_from(tr)
    if k is None:
        return tr
    return Toss(tr.id, tr.t[:k], tr.pos[:k], tr.quat[:k], tr.vel[:k], tr.omega[:k])


def read_frame(path: Path, columns=COLUMNS) -> list[tuple[int, dict[str, np.ndarray]]]:
    """(toss id, {column: values in step order}) for each toss of a toss CSV with `columns`,
    checked: every column there and finite, >= 8 samples a toss, increasing in time."""
    import pandas as pd  # here, not at the top: every process that loads the families imports this module
    try:
        frame = pd.read_csv(path)
    except (OSError, ValueError) as exc:
        raise TossError(f"{path}: cannot read it as a toss CSV ({exc})") from None
    missing = [c for c in columns if c not in frame.columns]
    if missing:
        raise TossError(f"{path}: missing columns {', '.join(missing)} (needs {', '.join(columns)})")
    values = frame.sort_values(["toss", "step"])[list(columns)].to_numpy(float)
    if not np.all(np.isfinite(values)):
        raise TossError(f"{path}: non-finite values (every column must be a finite number)")
    if not len(values):
        raise TossError(f"{path}: no tosses")
    out = []
    bounds = np.concatenate([[0], np.flatnonzero(np.diff(values[:, 0])) + 1, [len(values)]])
    for a, b in zip(bounds[:-1], bounds[1:]):  # numpy slices: pandas' groupby costs 10 times more here
        toss_id, t = int(values[a, 0]), values[a:b, columns.index("t")]
        if len(t) < 8 or np.any(np.diff(t) <= 0):
            raise TossError(f"{path}: toss {toss_id} has {len(t)} samples or non-increasing t "
                            "(needs >= 8 samples, increasing in time)")
        out.append((toss_id, {c: values[a:b, j] for j, c in enumerate(columns)}))
    return out


def columns_of(rows: dict[str, np.ndarray], *names: str) -> np.ndarray:
    """The named columns of a toss's rows (read_frame) side by side."""
    return np.column_stack([rows[n] for n in names])


def _read(path: Path) -> dict[int, Toss]:
    out = {}
    for toss_id, rows in read_frame(path):
        t = rows["t"]
        out[toss_id] = _cut(Toss(toss_id, t - t[0], columns_of(rows, "x", "y", "z"),
                                 _continuous(columns_of(rows, "qw", "qx", "qy", "qz")),
                                 columns_of(rows, "vx", "vy", "vz"), columns_of(rows, "wx", "wy", "wz")))
    return out


@functools.lru_cache(maxsize=4)
def _cached(path: str, mtime: float) -> dict[int, Toss]:
    return _read(Path(path))


def load(path: str | Path | None = None) -> dict[int, Toss]:
    """All tosses of a file (default: the packaged data set) by id, read once per process
    (and again only if the file changes)."""
    p = Path(path) if path is not None else DATA
    if not p.is_file():
        raise TossError(f"{p}: no such toss file")
    return _cached(str(p.resolve()), p.stat().st_mtime)


def save(tosses, path: str | Path) -> None:
    """Write Toss objects as a toss CSV with COLUMNS (gzipped if the name ends in .gz)."""
    import pandas as pd
    frames = []
    for tr in tosses:
        cols = {"toss": tr.id, "step": np.arange(len(tr)), "t": tr.t}
        for names, values in ((("x", "y", "z"), tr.pos), (("qw", "qx", "qy", "qz"), tr.quat),
                              (("vx", "vy", "vz"), tr.vel), (("wx", "wy", "wz"), tr.omega)):
            cols.update({n: values[:, i] for i, n in enumerate(names)})
        frames.append(pd.DataFrame(cols, columns=list(COLUMNS)))
    pd.concat(frames, ignore_index=True).to_csv(path, index=False, float_format="%.17g")


def toss(toss_id: int, path: str | Path | None = None) -> Toss:
    tosses = load(path)
    if toss_id not in tosses:
        raise TossError(f"toss {toss_id} is not in {path or DATA}")
    return tosses[toss_id]


# --- the split ------------------------------------------------------------------------------

def is_test(toss_id: int) -> bool:
    """The fixed split: odd ids test, even ids train (see the module notes)."""
    return toss_id % 2 == 1


def split(ids) -> tuple[list[int], list[int]]:
    """(train ids, test ids), each sorted."""
    ids = sorted(int(i) for i in ids)
    return [i for i in ids if not is_test(i)], [i for i in ids if is_test(i)]


# --- geometry of the measured motion ------------------------------------------------------

def lowest_corner(pos: np.ndarray, quat: np.ndarray) -> np.ndarray:
    """Height of the lowest corner above the data's z = 0, per sample."""
    R = _to_scipy(quat).as_matrix()                     # (n, 3, 3)
    return pos[:, 2] + np.min(np.einsum("nij,cj->nci", R, CORNERS)[:, :, 2], axis=1)


def face_down(quat: np.ndarray) -> np.ndarray:
    """Index into FACES of the face whose outward normal points most nearly down, per
    row: the body axis along world -z."""
    down = _to_scipy(quat).inv().apply([0.0, 0.0, -1.0])   # world -z in the body frame
    return np.argmax(np.atleast_2d(down) @ FACES.T, axis=1)


def first_contact(tr: Toss, surface: float = SURFACE_Z) -> int:
    """Index of the first sample in contact: the first whose lowest corner is within
    CONTACT_BAND of the surface, or the sample after the first upward kick of the vertical
    velocity (KICK), whichever comes first. The kick catches an impact that falls between
    two samples and rebounds clear of the band before the next one."""
    near = np.flatnonzero(lowest_corner(tr.pos, tr.quat) <= surface + CONTACT_BAND)
    kick = kicks(tr.t, tr.pos[:, 2])
    found = [int(near[0])] if len(near) else []
    found += [int(kick[0]) + 1] if len(kick) else []
    if not found:
        raise TossError(f"toss {tr.id}: the cube never reaches the surface")
    return min(found)


def kicks(t: np.ndarray, z: np.ndarray) -> np.ndarray:
    """Indices of the samples where the vertical velocity of a freely falling centre of mass
    z(t) changes upward by more than KICK: the change of the finite-difference velocity at
    each interior sample, gravity's -g h taken out, which is zero in free flight."""
    h = np.diff(t)
    vz = np.diff(z) / h
    return np.flatnonzero(np.diff(vz) + G * 0.5 * (h[1:] + h[:-1]) > KICK) + 1


def rest_height(tosses, ids=None) -> float:
    """The surface height the tosses imply: median over their final (resting) samples of
    centre height minus half-width (module notes)."""
    ids = sorted(tosses) if ids is None else ids
    return float(np.median([tosses[i].pos[-1, 2] - HALF for i in ids]))


def tilt(quat: np.ndarray) -> np.ndarray:
    """Angle (rad) between world up and the nearest face normal, per row: 0 for a cube
    lying flat on a face."""
    up = np.atleast_2d(_to_scipy(quat).inv().apply([0.0, 0.0, 1.0]))
    return np.arccos(np.clip(np.max(np.abs(up), axis=1), 0.0, 1.0))


def rest_tilt(tosses, ids=None) -> float:
    """Median tilt (rad) of the final samples: a cube at rest on a flat surface lies flat,
    so this is what the capture reads for flat."""
    ids = sorted(tosses) if ids is None else ids
    return float(np.median([tilt(tosses[i].quat[-1:])[0] for i in ids]))


# --- the free flight and the start state ----------------------------------------------------

MIN_FLIGHT_SAMPLES = 4  # a parabola (3 coefficients per axis) and a constant spin, fitted with >= 1 spare


@dataclass(frozen=True)
class FlightFit:
    """The free flight before first contact, fitted: p(t) = p0 + v0 s - g s^2/2 e_z and
    q(t) = Exp(w s) q0 with s = t - t0, t0 the start sample's time."""
    t0: float
    p0: np.ndarray       # (3,)
    v0: np.ndarray       # (3,) world
    q0: np.ndarray       # (4,)
    w: np.ndarray        # (3,) world frame, constant in a free cube's flight
    k0: int              # start sample
    contact: int         # first contact sample
    residual_pos: np.ndarray  # (k,) |p_meas - p_fit| over the flight samples, m
    residual_rot: np.ndarray  # (k,) angle between measured and fitted orientation, rad
    # (A^T A)^-1 of the fit's design A = [1, s]: times a residual variance, the covariance
    # of (value at t0, rate) along one axis (least squares)
    cov_unit: np.ndarray = field(default_factory=lambda: np.zeros((2, 2)))

    def state(self, s: np.ndarray):
        """Fitted position and orientation at times s after t0 (flight only)."""
        s = np.atleast_1d(np.asarray(s, float))
        p = self.p0 + np.outer(s, self.v0) - 0.5 * G * np.outer(s * s, [0.0, 0.0, 1.0])
        q = _from_scipy(_rotation().from_rotvec(np.outer(s, self.w)) * _to_scipy(self.q0))
        return p, q

    def perturbed(self, seed: int, surface: float = SURFACE_Z) -> "FlightFit":
        """The start state drawn once from its own uncertainty: (p0, v0) along each axis
        from sigma_p^2 (A^T A)^-1 and (orientation, w) about each axis from
        sigma_theta^2 (A^T A)^-1, with sigma the fit's RMS residual per axis (the
        least-squares covariance, residuals taken as white noise). A draw that puts a
        corner below the surface is lifted clear of it (by at most the draw's size)."""
        rng = np.random.default_rng(seed)
        L = np.linalg.cholesky(self.cov_unit)
        sigma_p = np.sqrt(np.mean(self.residual_pos ** 2) / 3.0)
        sigma_t = np.sqrt(np.mean(self.residual_rot ** 2) / 3.0)
        dp = L @ rng.standard_normal((2, 3)) * sigma_p     # rows: delta p0, delta v0
        dr = L @ rng.standard_normal((2, 3)) * sigma_t     # rows: delta rotation, delta w
        p0 = self.p0 + dp[0]
        q0 = _from_scipy(_rotation().from_rotvec(dr[0]) * _to_scipy(self.q0))[0]
        clearance = lowest_corner(p0[None, :], q0[None, :])[0] - surface
        if clearance <= 0.0:
            p0 = p0 + [0.0, 0.0, 1e-6 - clearance]
        return replace(self, p0=p0, v0=self.v0 + dp[1], q0=q0, w=self.w + dr[1])


def fit_flight(tr: Toss, surface: float = SURFACE_Z) -> FlightFit:
    """Fit the pre-contact samples with free-flight motion (module notes) and pick the
    start sample: the last one before contact whose fitted lowest corner is above the
    surface (the fit may put the sample just before contact a fraction of a millimetre low)."""
    kc = first_contact(tr, surface)
    if kc < MIN_FLIGHT_SAMPLES:
        raise TossError(f"toss {tr.id}: {kc} samples before first contact, needs >= {MIN_FLIGHT_SAMPLES}")
    t, p, q = tr.t[:kc], tr.pos[:kc], tr.quat[:kc]
    k0 = kc - 1
    while True:
        s = t - t[k0]
        # centre: least squares on p + g s^2/2 e_z = p0 + v0 s
        target = p + 0.5 * G * np.outer(s * s, [0.0, 0.0, 1.0])
        A = np.column_stack([np.ones_like(s), s])
        (p0, v0), *_ = np.linalg.lstsq(A, target, rcond=None)
        # orientation: rotation vectors of q_k q_k0^-1 are w s for a constant world spin;
        # fit w and a small correction c of q_k0 (q0 = Exp(c) q_k0) by linear least squares
        rel = (_to_scipy(q) * _to_scipy(q[k0]).inv()).as_rotvec()
        if np.linalg.norm(rel, axis=1).max() > 0.9 * np.pi:  # rotation vectors wrap at pi
            raise TossError(f"toss {tr.id}: the cube turns by more than 0.9 pi in its free flight, "
                            "which this fit does not unwrap (the packaged tosses turn by at most 1.2 rad)")
        (c, w), *_ = np.linalg.lstsq(A, rel, rcond=None)
        q0 = _from_scipy(_rotation().from_rotvec(c) * _to_scipy(q[k0]))[0]
        fit = FlightFit(float(t[k0]), p0, v0, q0, w, k0, kc, np.zeros(0), np.zeros(0))
        pf, qf = fit.state(s)
        if lowest_corner(pf[k0:k0 + 1], qf[k0:k0 + 1])[0] > surface or k0 == MIN_FLIGHT_SAMPLES - 1:
            break
        k0 -= 1
    if lowest_corner(pf[k0:k0 + 1], qf[k0:k0 + 1])[0] <= surface:
        raise TossError(f"toss {tr.id}: the fitted flight reaches the surface before any sample")
    return FlightFit(fit.t0, p0, v0, q0, w, k0, kc, np.linalg.norm(p - pf, axis=1), angle_between(q, qf),
                     np.linalg.inv(A.T @ A))


def scene(tr: Toss, mu: float = MU_NOMINAL, e: float = E_NOMINAL, fit: FlightFit | None = None) -> Scene:
    """The cube on the ground at the toss's start state (fit_flight), with friction mu and
    restitution e. The scene's angular velocity is in the WORLD frame (cases.scene), which
    the flight fit gives directly."""
    fit = fit or fit_flight(tr)
    cube = Body("cube", Box((HALF, HALF, HALF)), mass=MASS, inertia=(INERTIA, INERTIA, INERTIA),
                position=tuple(fit.p0), orientation=tuple(fit.q0 / np.linalg.norm(fit.q0)),
                velocity=tuple(fit.v0), angular_velocity=tuple(fit.w))
    ground = Body("ground", Plane(offset=SURFACE_Z), static=True)
    return Scene(bodies=(ground, cube), gravity=(0.0, 0.0, -G), material=Material(e=e, mu_s=mu))


def world_omega(tr: Toss) -> np.ndarray:
    """The stored body-frame angular velocities turned into the world frame."""
    return rotate(tr.quat, tr.omega)


# --- the noise floor ------------------------------------------------------------------------

def _quadratic_smoother(width: int = 5) -> np.ndarray:
    """S[j] = the weights that evaluate, at the j-th of `width` equally spaced samples, the
    least-squares quadratic through them (Savitzky-Golay; the middle row is the classic
    (-3, 12, 17, 12, -3)/35 for width 5, the others serve the ends of a toss)."""
    x = np.arange(width) - (width - 1) / 2
    V = np.vander(x, 3)
    return V @ np.linalg.solve(V.T @ V, V.T)


SMOOTHER = _quadratic_smoother(5)


def smoothing_windows(n: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """For each of n samples: its window's first sample, the window's (n, 5) sample indices
    and the SMOOTHER weights that evaluate the quadratic there (centred where possible, the
    first or last 5 samples at the ends)."""
    width = len(SMOOTHER)
    k = np.arange(n)
    first = np.clip(k - width // 2, 0, n - width)
    return first, first[:, None] + np.arange(width), SMOOTHER[k - first]


def smoothed(tr: Toss) -> tuple[np.ndarray, np.ndarray]:
    """Positions and orientations smoothed by a quadratic least-squares fit over 5 samples
    (27 ms): centred where possible, the first or last 5 samples at the ends of the toss.
    Orientations: the window's samples as rotation vectors relative to its middle sample,
    smoothed, applied back."""
    first, window, weights = smoothing_windows(len(tr))
    width = len(SMOOTHER)
    p = np.einsum("nw,nwi->ni", weights, tr.pos[window])
    base = _to_scipy(tr.quat[first + width // 2])
    rel = np.stack([(base.inv() * _to_scipy(tr.quat[window[:, w]])).as_rotvec() for w in range(width)], axis=1)
    q = _from_scipy(base * _rotation().from_rotvec(np.einsum("nw,nwi->ni", weights, rel)))
    return p, _continuous(q)


def noise_floor(tr: Toss) -> dict[str, np.ndarray]:
    """Per sample, the measured trajectory against itself smoothed: centre distance in cube
    widths and orientation angle in degrees."""
    p, q = smoothed(tr)
    return {"pos_err": np.linalg.norm(tr.pos - p, axis=1) / WIDTH,
            "rot_err": np.degrees(angle_between(tr.quat, q))}


def omega_convention_residuals(tr: Toss) -> dict[str, float]:
    """How well dq/dt = q (0, w) / 2 (body-frame w) and dq/dt = (0, w) q / 2 (world-frame
    w) describe the stored angular velocity: median |finite difference - prediction|
    relative to the median |finite difference| (predictions averaged over each interval)."""
    h = np.diff(tr.t)[:, None]
    dq = np.diff(tr.quat, axis=0) / h
    w = np.column_stack([np.zeros(len(tr)), tr.omega])
    out = {}
    for frame, pred in (("body", 0.5 * rotations.multiply(tr.quat, w)), ("world", 0.5 * rotations.multiply(w, tr.quat))):
        mid = 0.5 * (pred[1:] + pred[:-1])
        out[frame] = float(np.median(np.linalg.norm(dq - mid, axis=1)) / np.median(np.linalg.norm(dq, axis=1)))
    return out


def corner_error(p_a: np.ndarray, q_a: np.ndarray, p_b: np.ndarray, q_b: np.ndarray) -> np.ndarray:
    """Root mean square distance between corresponding corners of two cube poses, per row,
    in cube widths: one number for position and orientation together (a pure translation
    d gives d; a pure rotation by theta gives sqrt(2) sin(theta/2))."""
    ca = p_a[:, None, :] + np.einsum("nij,cj->nci", _to_scipy(q_a).as_matrix(), CORNERS)
    cb = p_b[:, None, :] + np.einsum("nij,cj->nci", _to_scipy(q_b).as_matrix(), CORNERS)
    return np.sqrt(np.mean(np.sum((ca - cb) ** 2, axis=2), axis=1)) / WIDTH


# --- the tier's interface: poses as rows, as cases/elbow_toss.py gives them too ----------------
# physval real reads every toss module through these names (physval/readings/real.py, TOSSES):
# a pose row is the centre and the orientation (w, x, y, z), 7 numbers.

UNIT, UNIT_NAME = WIDTH, "cube widths"   # position errors are in this unit
BODY = "cube"                            # the body whose state the scene records
POSE_SIZE = 7
NEEDS_JOINTS = False                     # a scene of one free body


def poses(tr: Toss) -> np.ndarray:
    return np.column_stack([tr.pos, tr.quat])


def read_poses(states: dict, steps_at: np.ndarray) -> np.ndarray:
    """Pose rows from a simulation's recorded states at the given step counts."""
    rows = states[BODY][steps_at]
    return np.column_stack([rows[:, :3], rows[:, 3:7] / np.linalg.norm(rows[:, 3:7], axis=1, keepdims=True)])


def pose_error(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """corner_error of pose rows a against b."""
    return corner_error(a[:, :3], a[:, 3:7], b[:, :3], b[:, 3:7])


def same_rest(a: np.ndarray, b: np.ndarray) -> bool:
    """Whether two final poses lie on the same face."""
    return bool(face_down(a[None, 3:7])[0] == face_down(b[None, 3:7])[0])


def smoothed_poses(tr: Toss) -> np.ndarray:
    return np.column_stack(smoothed(tr))


def with_poses(tr: Toss, k0: int, rows: np.ndarray) -> Toss:
    """The toss with its samples from k0 on replaced by the pose rows (a simulation taken as
    the measurement: physval real's start-noise floor); velocities kept as measured."""
    n = k0 + len(rows)
    return Toss(tr.id, tr.t[:n], np.vstack([tr.pos[:k0], rows[:, :3]]), np.vstack([tr.quat[:k0], rows[:, 3:7]]),
                tr.vel[:n], tr.omega[:n])
