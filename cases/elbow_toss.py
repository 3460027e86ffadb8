"""Measured elbow tosses (the real-world tier's articulated body): the data, the elbow, and a
scene per toss.

The data (`cases/data/elbow_toss/`, README and BSD 3-Clause LICENSE beside it) are 541
motion-captured tosses of one "elbow", two bars joined by a hinge, onto one flat surface,
from DAIR's dair_pll repository, in SI units: per sample the base link's position and
orientation (w, x, y, z, body to world), the hinge angle, the base link's velocity (world
frame) and angular velocity (BODY frame, as the cube's: tests/test_elbow_toss.py checks it
on the data) and the hinge rate.

The elbow (dair_pll's contactnets_elbow.urdf): links `elbow_1` (the base) and `elbow_2`,
each a 0.10 x 0.05 x 0.05 m box of 0.37 kg centred on its centre of mass; the hinge runs
along elbow_1's y axis through HINGE (elbow_1's frame), and elbow_2's centre lies ARM from
the hinge along elbow_2's own x axis, elbow_2 being elbow_1 turned by theta about y. The two
links do not collide with each other (a pair a joint connects never does in a Scene).

What this module decides, engine-neutrally, as cases/cube_toss.py does for the cube (its
quaternion helpers, smoother and split are used here):

- **Start state: the last sample before first contact, from a local fit.** A free
  articulated body has no closed-form flight (the links exchange momentum through the
  hinge), so the start state is a least-squares quadratic in time through the last
  FIT_SAMPLES (5, 27 ms) samples before first contact, of the base position, the base
  orientation (as rotation vectors relative to the start sample) and the hinge angle:
  its value at the start sample is the start pose and its slope the start velocities. This
  averages the capture's noise as the cube's flight fit does, over fewer samples.
- **First contact**: the first sample whose lowest corner (of either link) is within
  CONTACT_BAND = 1 mm of the surface or below it, or the sample after an upward kick of the
  centre of mass's vertical velocity (in free flight it falls at g exactly, links or no
  links): the kick comes first in most tosses, since the model's corners miss the surface
  by millimetres at the first impact (the URDF's boxes are not the bars to the millimetre).
- **The surface** lies at z = 0: every toss's final sample has its lowest corner there to
  1e-8 m (the source shifted each toss so), so SURFACE_Z = 0.
- **Split**: even ids train, odd ids test, as the cube's (271 and 270 tosses).
- **Errors** are measured over both links: the root mean square distance between the 16
  corners of simulated and measured poses, in bar lengths (LENGTH = 0.1 m), and the
  difference of hinge angles; "same rest" is both links ending on the same face down.
"""
from __future__ import annotations

import functools
from dataclasses import dataclass, field, replace
from pathlib import Path

import numpy as np

from cases import cube_toss as ct
from cases import rotations
from cases.scene import Body, Box, Joint, Material, Plane, Scene

DATA = Path(__file__).parent / "data" / "elbow_toss" / "elbow_tosses.csv.gz"
COLUMNS = ("toss", "step", "t", "x", "y", "z", "qw", "qx", "qy", "qz", "theta",
           "vx", "vy", "vz", "wx", "wy", "wz", "dtheta")

# The elbow, from dair_pll's contactnets_elbow.urdf (README beside the data).
HALF = (0.05, 0.025, 0.025)       # m, half-extents of each link's box
LENGTH = 2 * HALF[0]              # m: the unit of position errors (a bar's length)
MASS = 0.37                       # kg, each link
INERTIA = 6.167e-4                # kg m^2 about each principal axis of each link (the URDF's value)
HINGE = np.array([-0.035, 0.06, 0.0])   # m, the hinge's point in elbow_1's frame
AXIS = np.array([0.0, 1.0, 0.0])        # the hinge axis in elbow_1's frame
ARM = np.array([0.035, 0.0, 0.0])       # m, elbow_2's centre from the hinge, in elbow_2's frame
LINKS = ("elbow_1", "elbow_2")
G = ct.G
SAMPLE_PERIOD = ct.SAMPLE_PERIOD  # s (the ContactNets capture; dair_pll rounds it to 6.8 ms)
MU_NOMINAL = 0.3                  # the URDF's mu_static
E_NOMINAL = ct.E_NOMINAL          # none given for the elbow: the cube's, same capture and surface
SURFACE_Z = 0.0                   # m, see the module notes (tests recompute it from the data)
CONTACT_BAND = ct.CONTACT_BAND    # m
FIT_SAMPLES = 5                   # samples of the start fit (27 ms)

CORNERS = np.array([[sx, sy, sz] for sx in (-1, 1) for sy in (-1, 1) for sz in (-1, 1)], float) * HALF
TossError = ct.TossError


@dataclass(frozen=True, eq=False)
class ElbowToss(ct.Toss):
    """One measured toss: the base link's state as a cube toss's, and the hinge."""
    theta: np.ndarray = field(default_factory=lambda: np.zeros(0))   # (n,) rad
    dtheta: np.ndarray = field(default_factory=lambda: np.zeros(0))  # (n,) rad/s


def _read(path: Path) -> dict[int, ElbowToss]:
    out = {}
    for toss_id, rows in ct.read_frame(path, COLUMNS):
        t = rows["t"]
        out[toss_id] = ElbowToss(toss_id, t - t[0], ct.columns_of(rows, "x", "y", "z"),
                                 ct._continuous(ct.columns_of(rows, "qw", "qx", "qy", "qz")),
                                 ct.columns_of(rows, "vx", "vy", "vz"), ct.columns_of(rows, "wx", "wy", "wz"),
                                 rows["theta"], rows["dtheta"])
    return out


@functools.lru_cache(maxsize=4)
def _cached(path: str, mtime: float) -> dict[int, ElbowToss]:
    return _read(Path(path))


def load(path: str | Path | None = None) -> dict[int, ElbowToss]:
    """All tosses of a file (default: the packaged data set) by id, read once per process."""
    p = Path(path) if path is not None else DATA
    if not p.is_file():
        raise TossError(f"{p}: no such toss file")
    return _cached(str(p.resolve()), p.stat().st_mtime)


def toss(toss_id: int, path: str | Path | None = None) -> ElbowToss:
    tosses = load(path)
    if toss_id not in tosses:
        raise TossError(f"toss {toss_id} is not in {path or DATA}")
    return tosses[toss_id]


split = ct.split


# --- poses: (n, 8) rows of base position, base quaternion (w, x, y, z) and hinge angle ---------

def poses(tr: ElbowToss) -> np.ndarray:
    return np.column_stack([tr.pos, tr.quat, tr.theta])


def _turn_y(theta: np.ndarray) -> np.ndarray:
    """Quaternions of turns by theta about y."""
    theta = np.asarray(theta, float)
    return np.column_stack([np.cos(theta / 2), np.zeros_like(theta), np.sin(theta / 2), np.zeros_like(theta)])


def links(pose: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """World centres and orientations of both links, (p1, q1, p2, q2), from pose rows."""
    pose = np.atleast_2d(pose)
    p1, q1, theta = pose[:, :3], pose[:, 3:7], pose[:, 7]
    q2 = rotations.multiply(q1, _turn_y(theta))
    p2 = p1 + ct.rotate(q1, np.tile(HINGE, (len(p1), 1))) + ct.rotate(q2, np.tile(ARM, (len(p1), 1)))
    return p1, q1, p2, q2


def hinge_angle(q1: np.ndarray, q2: np.ndarray) -> np.ndarray:
    """The hinge angle from the two links' orientations: the turn q1^-1 q2 about elbow_1's y
    (the component about y of that relative rotation, exact while the hinge holds)."""
    r = rotations.multiply(rotations.conjugate(np.atleast_2d(q1)), np.atleast_2d(q2))
    return 2.0 * np.arctan2(r[:, 2] * np.sign(r[:, 0] + (r[:, 0] == 0)), np.abs(r[:, 0]))


def corners(pose: np.ndarray) -> np.ndarray:
    """The 16 corners (8 per link) in the world, (n, 16, 3)."""
    p1, q1, p2, q2 = links(pose)
    c1 = p1[:, None, :] + np.einsum("nij,cj->nci", ct._to_scipy(q1).as_matrix(), CORNERS)
    c2 = p2[:, None, :] + np.einsum("nij,cj->nci", ct._to_scipy(q2).as_matrix(), CORNERS)
    return np.concatenate([c1, c2], axis=1)


def lowest_corner(pose: np.ndarray) -> np.ndarray:
    """Height of the lowest corner of either link above z = 0, per row."""
    return corners(pose)[:, :, 2].min(axis=1)


def corner_error(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """RMS distance between corresponding corners of two elbow poses, per row, in bar lengths."""
    return np.sqrt(np.mean(np.sum((corners(a) - corners(b)) ** 2, axis=2), axis=1)) / LENGTH


def rest_faces(pose: np.ndarray) -> np.ndarray:
    """(n, 2): the face of each link that points most nearly down (cases.cube_toss.FACES)."""
    _, q1, _, q2 = links(pose)
    return np.column_stack([ct.face_down(q1), ct.face_down(q2)])


def centre_of_mass(pose: np.ndarray) -> np.ndarray:
    """The elbow's centre of mass (the links' centres averaged: equal masses), per row."""
    p1, _, p2, _ = links(pose)
    return 0.5 * (p1 + p2)


def first_contact(tr: ElbowToss, surface: float = SURFACE_Z) -> int:
    """Index of the first sample in contact: the first whose lowest corner is within
    CONTACT_BAND of the surface, or the sample after the first upward kick of the centre of
    mass's vertical velocity (cube_toss.KICK), whichever comes first. The kick finds most
    first impacts: the URDF's boxes are not the real bars to the millimetre, and at the first
    impact the model's lowest corner is often several millimetres clear of the surface."""
    near = np.flatnonzero(lowest_corner(poses(tr)) <= surface + CONTACT_BAND)
    kick = ct.kicks(tr.t, centre_of_mass(poses(tr))[:, 2])
    found = [int(near[0])] if len(near) else []
    found += [int(kick[0]) + 1] if len(kick) else []
    if not found:
        raise TossError(f"toss {tr.id}: the elbow never reaches the surface")
    return min(found)


def rest_height(tosses, ids=None) -> float:
    """The surface height the tosses imply: median over their final samples of the lowest corner."""
    ids = sorted(tosses) if ids is None else ids
    return float(np.median([lowest_corner(poses(tosses[i])[-1:])[0] for i in ids]))


# --- the start state ------------------------------------------------------------------------

@dataclass(frozen=True)
class StartFit:
    """The start state at sample k0 (the last before first contact), from a quadratic
    least-squares fit over the FIT_SAMPLES samples up to it (module notes)."""
    t0: float
    p0: np.ndarray       # (3,) base position
    v0: np.ndarray       # (3,) its velocity, world
    q0: np.ndarray       # (4,) base orientation
    w: np.ndarray        # (3,) base angular velocity, world
    theta0: float        # hinge angle, rad
    dtheta: float        # hinge rate, rad/s
    k0: int
    contact: int
    residual_pos: np.ndarray   # (k,) |p_meas - p_fit| over the fitted samples, m
    residual_rot: np.ndarray   # (k,) rad, base orientation
    residual_theta: np.ndarray  # (k,) rad
    cov_unit: np.ndarray = field(default_factory=lambda: np.zeros((2, 2)))  # (A^T A)^-1, value and slope

    def pose(self) -> np.ndarray:
        return np.concatenate([self.p0, self.q0, [self.theta0]])

    def perturbed(self, seed: int, surface: float = SURFACE_Z) -> "StartFit":
        """The start state drawn once from its own uncertainty (as cube_toss.FlightFit.perturbed:
        each value and slope from sigma^2 (A^T A)^-1, sigma the fit's RMS residual per axis);
        a draw that puts a corner below the surface is lifted clear of it."""
        rng = np.random.default_rng(seed)
        L = np.linalg.cholesky(self.cov_unit)
        sigma_p = np.sqrt(np.mean(self.residual_pos ** 2) / 3.0)
        sigma_r = np.sqrt(np.mean(self.residual_rot ** 2) / 3.0)
        sigma_h = np.sqrt(np.mean(self.residual_theta ** 2))
        dp = L @ rng.standard_normal((2, 3)) * sigma_p
        dr = L @ rng.standard_normal((2, 3)) * sigma_r
        dh = L @ rng.standard_normal(2) * sigma_h
        q0 = ct._from_scipy(ct._rotation().from_rotvec(dr[0]) * ct._to_scipy(self.q0))[0]
        out = replace(self, p0=self.p0 + dp[0], v0=self.v0 + dp[1], q0=q0, w=self.w + dr[1],
                      theta0=self.theta0 + dh[0], dtheta=self.dtheta + dh[1])
        clearance = lowest_corner(out.pose())[0] - surface
        return out if clearance > 0.0 else replace(out, p0=out.p0 + [0.0, 0.0, 1e-6 - clearance])


def fit_flight(tr: ElbowToss, surface: float = SURFACE_Z, before: int | None = None) -> StartFit:
    """The start state (StartFit) at the last sample before first contact whose fitted pose
    clears the surface; `before`: a sample to start before instead of the first contact
    (one earlier in the flight: tests compare a simulated free flight with the measured one)."""
    kc = first_contact(tr, surface) if before is None else before
    if kc < FIT_SAMPLES:
        raise TossError(f"toss {tr.id}: {kc} samples before first contact, needs >= {FIT_SAMPLES}")
    for k0 in range(kc - 1, FIT_SAMPLES - 2, -1):
        window = np.arange(k0 - FIT_SAMPLES + 1, k0 + 1)
        s = tr.t[window] - tr.t[k0]
        A = np.column_stack([np.ones_like(s), s, s * s])
        # base orientation: rotation vectors of q_k q_k0^-1 (world frame), whose slope at
        # s = 0 is the world angular velocity
        rel = (ct._to_scipy(tr.quat[window]) * ct._to_scipy(tr.quat[k0]).inv()).as_rotvec()
        Cp, Cr, Ch = (np.linalg.lstsq(A, y, rcond=None)[0] for y in (tr.pos[window], rel, tr.theta[window]))
        q0 = ct._from_scipy(ct._rotation().from_rotvec(Cr[0]) * ct._to_scipy(tr.quat[k0]))[0]
        if lowest_corner(np.concatenate([Cp[0], q0, [Ch[0]]]))[0] > surface:
            break
    else:
        raise TossError(f"toss {tr.id}: no fitted start state clears the surface")
    rot = ct._from_scipy(ct._rotation().from_rotvec(A @ Cr) * ct._to_scipy(tr.quat[k0]))
    return StartFit(float(tr.t[k0]), Cp[0], Cp[1], q0, Cr[1], float(Ch[0]), float(Ch[1]), int(k0), kc,
                    np.linalg.norm(tr.pos[window] - A @ Cp, axis=1), ct.angle_between(tr.quat[window], rot),
                    np.abs(tr.theta[window] - A @ Ch), np.linalg.inv(A.T @ A)[:2, :2])


def start_velocities(fit: StartFit) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """(v1, w1, v2, w2): world velocities of both links' centres and their angular velocities
    at the start: elbow_2 turns with w1 plus the hinge rate about the hinge axis, and its
    centre moves with the base's motion plus that turn about the hinge."""
    p1, q1, p2, _ = links(fit.pose())
    axis = ct.rotate(q1, AXIS[None, :])[0]
    hinge = p1[0] + ct.rotate(q1, HINGE[None, :])[0]
    w2 = fit.w + fit.dtheta * axis
    v2 = fit.v0 + np.cross(fit.w, p2[0] - p1[0]) + np.cross(fit.dtheta * axis, p2[0] - hinge)
    return fit.v0, fit.w, v2, w2


def scene(tr: ElbowToss, mu: float = MU_NOMINAL, e: float = E_NOMINAL, fit: StartFit | None = None) -> Scene:
    """The elbow on the ground at the toss's start state (fit_flight): two boxes and a
    revolute joint, with friction mu and restitution e on every contact."""
    fit = fit or fit_flight(tr)
    p1, q1, p2, q2 = links(fit.pose())
    v1, w1, v2, w2 = start_velocities(fit)
    box = Box(HALF)

    def link(name, p, q, v, w):
        return Body(name, box, mass=MASS, inertia=(INERTIA,) * 3, position=tuple(p), orientation=tuple(q / np.linalg.norm(q)),
                    velocity=tuple(v), angular_velocity=tuple(w))
    hinge = Joint("revolute", LINKS[1], LINKS[0], anchor=tuple(p1[0] + ct.rotate(q1, HINGE[None, :])[0]),
                  axis=tuple(ct.rotate(q1, AXIS[None, :])[0]))
    ground = Body("ground", Plane(offset=SURFACE_Z), static=True)
    return Scene(bodies=(ground, link(LINKS[0], p1[0], q1[0], v1, w1), link(LINKS[1], p2[0], q2[0], v2, w2)),
                 gravity=(0.0, 0.0, -G), material=Material(e=e, mu_s=mu), joints=(hinge,))


def read_poses(states: dict, steps_at: np.ndarray) -> np.ndarray:
    """Pose rows (n, 8) from a simulation's recorded states at the given step counts: the
    base link's position and orientation, and the hinge angle from both links' orientations."""
    a, b = states[LINKS[0]][steps_at], states[LINKS[1]][steps_at]
    q1 = a[:, 3:7] / np.linalg.norm(a[:, 3:7], axis=1, keepdims=True)
    q2 = b[:, 3:7] / np.linalg.norm(b[:, 3:7], axis=1, keepdims=True)
    return np.column_stack([a[:, :3], q1, hinge_angle(q1, q2)])


# --- the tier's interface (as cases/cube_toss.py's) -----------------------------------------

UNIT, UNIT_NAME = LENGTH, "bar lengths"
POSE_SIZE = 8
NEEDS_JOINTS = True
pose_error = corner_error


def same_rest(a: np.ndarray, b: np.ndarray) -> bool:
    """Whether two final poses have each link on the same face."""
    return bool(np.all(rest_faces(a[None, :]) == rest_faces(b[None, :])))


def smoothed_poses(tr: ElbowToss) -> np.ndarray:
    """Base position and orientation smoothed as the cube's (cube_toss.smoothed), the hinge
    angle by the same 5-sample quadratic."""
    p, q = ct.smoothed(tr)
    _, window, weights = ct.smoothing_windows(len(tr))
    theta = np.einsum("nw,nw->n", weights, tr.theta[window])
    return np.column_stack([p, q, theta])


def with_poses(tr: ElbowToss, k0: int, rows: np.ndarray) -> ElbowToss:
    """The toss with its samples from k0 on replaced by the pose rows (cube_toss.with_poses)."""
    n = k0 + len(rows)
    return ElbowToss(tr.id, tr.t[:n], np.vstack([tr.pos[:k0], rows[:, :3]]), np.vstack([tr.quat[:k0], rows[:, 3:7]]),
                     tr.vel[:n], tr.omega[:n], np.concatenate([tr.theta[:k0], rows[:, 7]]), tr.dtheta[:n])
