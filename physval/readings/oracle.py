"""Pinocchio's contact solvers as an oracle for the reference (issue 40, item 4).

The reference (reference_impl/) solves, at each step, one contact problem over all its
contacts (note 000, "Matrix form for rigid bodies"): the Delassus matrix A = J M^-1 J^T (the
notes' collision matrix K, per pair of rows), the free velocity -b (J u less each row's
target velocity), and a friction coefficient mu per contact, with the friction PYRAMID
|gamma_t1|, |gamma_t2| <= mu gamma_n (t1 along the slip; reference_impl/lcp.py). Pinocchio 4
(`pin`, the extra `oracle`) solves the same problem with the Coulomb CONE
||gamma_t|| <= mu gamma_n by its proximal ADMM and its PGS (the solvers behind Inria's Simple
and the ContactBench study), from G, g and the cones alone.

- `capture`: the problems of a few steps of the reference's own scenes (SCENES: a box at rest
  on four corners, a box sliding along and 22.5 deg off its axis, stacks, an oblique impact),
  read between the world's collision phase and its solve (formulation "lemke"), with the
  reference's own solution of that step; `save` / `load` keep them in one small .npz;
- `solve`: each solver on a problem (the reference's Lemke, PGS and SPOOK, Pinocchio's ADMM
  and PGS), impulses in the reference's row order;
- `agreement`: where the solutions agree and where they part, in the reference's terms: the
  velocity after the impulse (each body's velocity change M^-1 J^T gamma, m/s), the total
  impulse on each body (N s), the residual of each friction law (m/s, below). Impulses
  themselves are compared only where they are unique (A of full rank): a box's four corners
  (12 rows of rank 6) share its weight in many ways that move the box alike;
- `precision_time`: precision against CPU time per solver and iteration budget (as ContactBench
  plots it): how far each result moves the bodies from the solution, and each law's
  residual; `plot` the figure.

Residuals, in m/s, zero exactly at a solution (PGS's own measure, pgs.py: a row's velocity
correction A_kk |d gamma_k|):
- pyramid: max_k A_kk |gamma_k - clamp(gamma_k - (A gamma - b)_k / A_kk)|, the reference's law;
- cone: per contact, A_nn |lambda - P_K(lambda - (sigma + mu ||sigma_t|| e_n) / A_nn)|, the
  natural map of Coulomb's law with De Saxce's correction (lambda the impulse, sigma = A gamma
  - b its velocity, K the cone), Pinocchio's law.
The two laws give the same solution where each contact sticks inside both sets or slides
along t1 (the reference turns t1 into the slip before it solves); they part where a contact's
friction leaves the cone for the pyramid's corners (slip turning during the step). Measured
figures: `physval bench oracle` (docs/measure/performance.md).

Pinocchio is optional: `capture`, `save`, `load`, `planted`, the residuals and the
reference's solvers run without it; what compares with Pinocchio's needs it, and
`available()` says whether it is there.
"""
from __future__ import annotations

import math
import time
from pathlib import Path
from typing import NamedTuple

import numpy as np
import pandas as pd

from reference_impl import lcp, lemke, pgs, spook

# The scenes the problems come from: (label, family, variant params, step). A step number is
# the step whose problem is read (1-based); "impact" the first step whose solve gives a
# normal impulse. Why each: the box's four corners make A singular (non-unique impulses);
# sliding along x and 22.5 deg off x, the slip is t1 and pyramid and cone coincide; the
# stacks add contacts between moving bodies (3 boxes; 4 boxes of 10:1 masses: A's
# conditioning); a brick landing on an edge, and on a corner, while sliding and spinning is
# a real impact (restitution target, friction in the same solve); the corner's one contact
# has a full-rank A, so its impulses themselves are unique and compared.
SCENES = (
    ("box at rest", "resting_blocks", {"n": 1, "dim": 3}, 100),
    ("box sliding", "slide_to_stop", {"mu_s": 0.5, "mu_k": 0.5, "v0": 2.0, "dim": 3}, 50),
    ("box sliding at 22.5 deg", "slide_to_stop", {"mu_s": 0.5, "mu_k": 0.5, "v0": 2.0, "dim": 3, "heading": 22.5},
     50),
    ("stack of 3", "resting_blocks", {"n": 3, "dim": 3}, 100),
    ("stack of 4, 10:1 masses", "stack_forces", {"n": 4, "masses": "light-heavy", "dim": 3}, 100),
    ("impact on an edge", "oblique_landing", {"body": "brick", "pose": "edge", "mu": 0.5, "vx": 1.0,
                                             "w": (0.0, -2.0, 0.0), "dim": 3}, "impact"),
    ("impact on a corner", "oblique_landing", {"body": "brick", "pose": "corner", "mu": 0.8, "vx": 0.5,
                                               "w": (0.0, -2.0, 0.0), "dim": 3}, "impact"),
)

# Agreement tolerance on velocities, relative to the problem's velocity scale max |b|: the
# reference's Lemke accepts a solution whose impulses are up to 1e-6 of themselves off
# (lemke.lemke_or_retry: its last retry regularises by 1e-6 max(diag M)), which moves the
# velocities by up to 1e-6 of the change they make (|A d gamma| <= 1e-6 |A gamma| ~ 1e-6 |b|);
# Pinocchio is run to 1e-12 (ORACLE_TOL), far below it.
REL_TOL = 1e-6
ORACLE_TOL = 1e-12      # Pinocchio's absolute feasibility and complementarity tolerances
ORACLE_ITERATIONS = 20000

SOLVERS = ("reference lemke", "reference pgs", "reference spook", "pinocchio admm", "pinocchio pgs")
ITERATIVE = tuple(s for s in SOLVERS if s != "reference lemke")


def available() -> bool:
    """Whether Pinocchio (`pip install ".[oracle]"`) can be imported."""
    try:
        import pinocchio  # noqa: F401
    except ImportError:
        return False
    return True


# --- the problems ---------------------------------------------------------------------------

class Problem(NamedTuple):
    """One step's contact problem of the reference: A gamma - b >= 0 on normal rows (with
    gamma_n >= 0), the pyramid on tangent rows (lcp.py). `u` (N, 6) is the velocity the solve
    starts from and `target` each row's target velocity (b = target - J u), so a changed
    row gives its own b; `gamma` the reference's own impulses of that step."""
    name: str
    rows: lcp.Rows
    bodies: lcp.Bodies
    u: np.ndarray
    target: np.ndarray
    gamma: np.ndarray
    dt: float

    @property
    def A(self) -> np.ndarray:
        return lcp.delassus(self.rows, self.bodies)

    @property
    def b(self) -> np.ndarray:
        return self.target - lcp.row_velocity(self.rows, self.u)

    @property
    def contacts(self) -> int:
        return int(np.sum(self.rows.is_normal))

    def __repr__(self) -> str:
        return f"Problem({self.name!r}: {self.contacts} contacts, {len(self.rows.a)} rows)"


def capture(scenes=SCENES) -> list[Problem]:
    """The problems of `scenes` ((label, family, params, step) as SCENES), each read from the
    reference's world (formulation "lemke": the exact solve) between its collision phase and
    its solve, with the impulses that solve gives."""
    from cases.registry import builtin_families
    return [_capture(label, builtin_families()[family], params, step) for label, family, params, step in scenes]


def _capture(label: str, family, params: dict, step) -> Problem:
    from adapters.base import Settings
    from adapters.reference_engine import ReferenceAdapter
    from reference_impl.contact import contact_arrays
    dt = family.dt_for(params)
    # the reference's World, each step in its two halves (World.begin_step, end_step), so
    # that the problem is read between them
    world = ReferenceAdapter("lemke").world_of(family.scene(params), Settings(dt=dt))
    limit = step if step != "impact" else int(round(family.duration(params) / dt))
    for k in range(1, limit + 1):
        world.begin_step(dt)
        contacts, state_bodies = world.contact_problem()
        rows, bodies, u = lcp.world_rows(contacts, state_bodies)
        target = np.zeros(len(rows.a))  # lcp.world_rhs's: the contact's own on its normal row
        target[rows.is_normal] = contact_arrays(contacts).target
        world.end_step(dt)
        gamma = lcp.world_impulses(contacts)
        if len(rows.a) and (k == step or (step == "impact" and np.any(gamma[rows.is_normal] > 0.0))):
            if np.any(np.bincount(rows.normal[rows.normal >= 0], minlength=len(rows.a))[rows.is_normal] != 3):
                raise ValueError(f"{label}: every contact needs two friction rows (a 3D scene with mu > 0)")
            return Problem(label, rows, bodies, u, target, gamma, dt)
    raise ValueError(f"{label}: no contact problem by step {limit}")


def save(problems: list[Problem], path: Path) -> None:
    """The problems in one .npz (arrays named '<k>.<field>'; names and dt in 'names', 'dt')."""
    arrays = {"names": np.array([p.name for p in problems]), "dt": np.array([p.dt for p in problems])}
    for k, p in enumerate(problems):
        for part, fields in (("rows", p.rows), ("bodies", p.bodies)):
            for field, value in zip(fields._fields, fields):
                arrays[f"{k}.{part}.{field}"] = value
        for field in ("u", "target", "gamma"):
            arrays[f"{k}.{field}"] = getattr(p, field)
    Path(path).parent.mkdir(parents=True, exist_ok=True)
    np.savez_compressed(path, **arrays)


def load(path: Path) -> list[Problem]:
    with np.load(path) as f:
        return [Problem(str(name), lcp.Rows(*(f[f"{k}.rows.{x}"] for x in lcp.Rows._fields)),
                        lcp.Bodies(*(f[f"{k}.bodies.{x}"] for x in lcp.Bodies._fields)),
                        f[f"{k}.u"], f[f"{k}.target"], f[f"{k}.gamma"], float(f["dt"][k]))
                for k, name in enumerate(f["names"])]


def planted(problem: Problem, fault: str) -> Problem:
    """`problem` made wrong as a faulty reference would make it, the reference's solution of
    it in `gamma`: "mu" (every contact's mu doubled) or "normal" (the first contact's normal
    flipped). The oracle must tell it from the real one (tests/test_oracle.py)."""
    rows = lcp.Rows(*(x.copy() for x in problem.rows))
    if fault == "mu":
        rows.mu[:] *= 2.0
    elif fault == "normal":
        rows.J_a[0] *= -1.0
        rows.J_b[0] *= -1.0
    else:
        raise ValueError(f"fault {fault!r}: choose mu or normal")
    wrong = problem._replace(name=f"{problem.name} ({fault} planted)", rows=rows)
    return wrong._replace(gamma=lemke.contact_lcp(wrong.A, wrong.b, rows))


# --- residuals (m/s) --------------------------------------------------------------------------

def pyramid_residual(problem: Problem, gamma: np.ndarray) -> float:
    """The reference's law: max_k A_kk |gamma_k - clamp(gamma_k - w_k / A_kk)|, w = A gamma - b."""
    A = problem.A
    d = np.diag(A)
    lo, hi = lcp.bounds(problem.rows, gamma)
    w = A @ gamma - problem.b
    return float(np.max(d * np.abs(gamma - np.clip(gamma - w / d, lo, hi)), initial=0.0))


def cone_residual(problem: Problem, gamma: np.ndarray) -> float:
    """Coulomb's law with the cone (Pinocchio's): per contact, A_nn |lambda - P_K(lambda -
    (sigma + mu ||sigma_t|| e_n) / A_nn)| (De Saxce's correction makes the natural map zero
    exactly at a solution of the Coulomb problem)."""
    A, rows = problem.A, problem.rows
    w = A @ gamma - problem.b
    worst = 0.0
    for k in np.flatnonzero(rows.is_normal):
        mu, s = rows.mu[k + 1], slice(k, k + 3)
        lam, sigma = gamma[s], w[s].copy()
        sigma[0] += mu * math.hypot(sigma[1], sigma[2])
        worst = max(worst, A[k, k] * float(np.linalg.norm(lam - _cone_projection(lam - sigma / A[k, k], mu))))
    return worst


def _cone_projection(x: np.ndarray, mu: float) -> np.ndarray:
    """Projection of (n, t1, t2) onto ||t|| <= mu n."""
    n, t = x[0], math.hypot(x[1], x[2])
    if t <= mu * n:
        return x.copy()
    if mu * t <= -n:
        return np.zeros(3)
    scale = (mu * t + n) / (mu * mu + 1.0)
    out = np.array([scale, 0.0, 0.0])
    if t > 0.0:
        out[1:] = mu * scale * x[1:] / t
    return out


# --- the solvers --------------------------------------------------------------------------------

def solve(problem: Problem, solver: str, iterations: int | None = None) -> np.ndarray:
    """gamma (the reference's row order) by `solver` (SOLVERS) with at most `iterations`
    sweeps or iterations (None: to its tolerance: the reference's PGS and SPOOK 1e-13 m/s in
    at most 1000 sweeps, pgs.PGSSettings; Pinocchio's ORACLE_TOL in ORACLE_ITERATIONS)."""
    return solver_call(problem, solver, iterations)()


def solver_call(problem: Problem, solver: str, iterations: int | None = None):
    """A call that runs `solve` with everything that is not the solver's own work made
    beforehand (A and b; Pinocchio's cones and settings), so that timing it times the solver:
    each solver is given the Delassus matrix (the reference's PGS its rows and bodies, from
    which it makes its per-body sums as part of its sweep, pgs.py) and returns gamma."""
    rows, bodies, A, b = problem.rows, problem.bodies, problem.A, problem.b
    if solver == "reference lemke":
        return lambda: lemke.contact_lcp(A, b, rows)
    if solver in ("reference pgs", "reference spook"):
        settings = pgs.PGSSettings() if iterations is None else pgs.PGSSettings(iterations=iterations, tolerance=0.0)
        sigma = None
        if solver == "reference spook":  # note 004's regularisation eps on the normal rows (spook.py)
            eps = spook.parameters(spook.DEFAULT_K, spook.DEFAULT_D, problem.dt)[0]
            sigma = np.where(rows.is_normal, eps, 0.0)
        return lambda: pgs.projected_gauss_seidel(rows, bodies, b, settings, sigma).gamma
    if solver in ("pinocchio admm", "pinocchio pgs"):
        return _pinocchio(problem, A, b, solver.split()[1], iterations)
    raise ValueError(f"solver {solver!r}: choose from {', '.join(SOLVERS)}")


def _order(problem: Problem) -> np.ndarray:
    """Pinocchio's row order: per contact (t1, t2, n), its cone's normal last."""
    return np.array([k + d for k in np.flatnonzero(problem.rows.is_normal) for d in (1, 2, 0)])


def _pinocchio(problem: Problem, A: np.ndarray, b: np.ndarray, which: str, iterations: int | None):
    """solver_call of Pinocchio's `which` ("admm", "pgs"): its problem G, g and one point
    contact model per contact (the model only carries the contact's cone: the solver reads
    G and g as given)."""
    import pinocchio as pin
    order, model = _order(problem), pin.Model()
    G, g = np.ascontiguousarray(A[np.ix_(order, order)]), np.ascontiguousarray(-b[order])
    models, datas = pin.StdVec_ConstraintModel(), pin.StdVec_ConstraintData()
    for k in np.flatnonzero(problem.rows.is_normal):
        contact = pin.PointContactConstraintModel(model)
        contact.setFriction(float(problem.rows.mu[k + 1]))
        models.append(pin.ConstraintModel(contact))
        datas.append(models[-1].createData())
    kind, settings_of, result_of = ((pin.ADMMConstraintSolver, pin.ADMMSolverSettings, pin.ADMMSolverResult)
                                    if which == "admm" else
                                    (pin.PGSConstraintSolver, pin.PGSSolverSettings, pin.PGSSolverResult))
    settings, result, solver = settings_of(), result_of(), kind(len(g))
    tol = ORACLE_TOL if iterations is None else 0.0
    settings.max_iterations = ORACLE_ITERATIONS if iterations is None else int(iterations)
    settings.absolute_feasibility_tol = settings.absolute_complementarity_tol = tol
    settings.relative_feasibility_tol = settings.relative_complementarity_tol = tol

    def call() -> np.ndarray:
        # a fresh operator every solve: ADMM leaves its penalty rho on the operator as damping
        # (a PGS solve after an ADMM solve on the same operator solved G + 2 I, measured); and
        # from zero: the result would warm-start the next solve
        result.reset()
        solver.solve(pin.DelassusOperatorDense(G), g, models, datas, settings, result)
        gamma = np.empty(len(g))
        gamma[order] = result.retrieveConstraintImpulses()
        return gamma
    return call


# --- agreement ------------------------------------------------------------------------------------

class Outcome(NamedTuple):
    """What is unique in a solution: each body's velocity change du (N, 6; m/s, rad/s) and
    the total contact impulse on it (N, 3; N s)."""
    du: np.ndarray
    impulse: np.ndarray


def outcome(problem: Problem, gamma: np.ndarray) -> Outcome:
    du = lcp.velocity_change(problem.rows, problem.bodies, gamma)
    m_inv = problem.bodies.m_inv
    impulse = np.where(m_inv[:, None] > 0.0, du[:, :3] / np.where(m_inv > 0.0, m_inv, 1.0)[:, None], 0.0)
    return Outcome(du, impulse)


def tolerance(problem: Problem) -> float:
    """The velocity tolerance of agreement (m/s): REL_TOL of the problem's velocity scale."""
    return REL_TOL * max(float(np.max(np.abs(problem.b))), 1e-9)


def differences(problem: Problem, reference: Problem, gamma: np.ndarray | None = None) -> dict:
    """How far `reference`'s solution (its own rows: a planted one may differ from
    `problem`'s) is from Pinocchio's ADMM on `problem`: the largest velocity change
    difference (m/s) and total impulse difference (N s) over the bodies."""
    gamma = reference.gamma if gamma is None else gamma
    ours, theirs = outcome(reference, gamma), outcome(problem, solve(problem, "pinocchio admm"))
    return {"velocity m/s": float(np.max(np.abs(ours.du - theirs.du))),
            "impulse N s": float(np.max(np.abs(ours.impulse - theirs.impulse))),
            "tolerance m/s": tolerance(problem)}


def agrees(problem: Problem, reference: Problem) -> bool:
    """Whether `reference`'s solution moves every body as Pinocchio's does, within tolerance."""
    d = differences(problem, reference)
    return d["velocity m/s"] <= d["tolerance m/s"]


def agreement(problems: list[Problem]) -> pd.DataFrame:
    """Per problem and solver (each run to its tolerance): the residual of each law, the
    difference from Pinocchio's ADMM in what is unique (velocity change, total impulse per
    body) and, where A has full rank, in the impulses themselves."""
    out = []
    for p in problems:
        oracle = solve(p, "pinocchio admm")
        theirs = outcome(p, oracle)
        rank, tol = int(np.linalg.matrix_rank(p.A)), tolerance(p)
        for solver in SOLVERS:
            gamma = oracle if solver == "pinocchio admm" else solve(p, solver)
            ours = outcome(p, gamma)
            dv = float(np.max(np.abs(ours.du - theirs.du)))
            out.append({"problem": p.name, "contacts": p.contacts, "rows": len(p.rows.a), "rank A": rank,
                        "solver": solver, "pyramid residual m/s": pyramid_residual(p, gamma),
                        "cone residual m/s": cone_residual(p, gamma), "velocity diff m/s": dv,
                        "impulse diff N s": float(np.max(np.abs(ours.impulse - theirs.impulse))),
                        "impulses diff N s": (float(np.max(np.abs(gamma - oracle))) if rank == len(p.rows.a)
                                              else math.nan),
                        "tolerance m/s": tol, "agrees": dv <= tol})
    return pd.DataFrame(out)


# --- precision against time ---------------------------------------------------------------------

BUDGETS = (1, 2, 4, 8, 16, 32, 64, 128, 256, 512, 1024)  # sweeps or iterations per solve
MIN_TIMED = 2e-3  # s of CPU per timing: short solves are repeated until they add up to it
ROUNDS = 3        # timings per point, least kept (a burst of load slows one, not all)


def cpu_time(call) -> float:
    """Least CPU time (user + sys of this process) of one `call()`, over ROUNDS timings of
    enough calls to last MIN_TIMED."""
    call()  # compiled code loads at its first call
    n, best = 1, math.inf
    for _ in range(ROUNDS):
        while True:
            t0 = time.process_time()
            for _ in range(n):
                call()
            spent = time.process_time() - t0
            if spent >= MIN_TIMED:
                break
            n *= 4
        best = min(best, spent / n)
    return best


def precision_time(problems: list[Problem], solvers=SOLVERS, budgets=BUDGETS) -> pd.DataFrame:
    """Per problem, solver and budget: the CPU time of one solve (s, cpu_time: the Python
    call included, as for every solver), how far its result moves the bodies from the
    solution (`velocity error`: the largest velocity change difference from Pinocchio's ADMM
    run to ORACLE_TOL, m/s: unique where the impulses are not) and the residual of each law.
    Lemke has no budget: one point."""
    out = []
    for p in problems:
        solution = outcome(p, solve(p, "pinocchio admm")).du
        for solver in solvers:
            for budget in (None,) if solver == "reference lemke" else budgets:
                gamma = solve(p, solver, budget)
                out.append({"problem": p.name, "solver": solver, "budget": budget or 0,
                            "cpu s": cpu_time(solver_call(p, solver, budget)),
                            "velocity error m/s": float(np.max(np.abs(outcome(p, gamma).du - solution))),
                            "cone residual m/s": cone_residual(p, gamma),
                            "pyramid residual m/s": pyramid_residual(p, gamma)})
    return pd.DataFrame(out)


def plot(curves: pd.DataFrame, path: Path) -> None:
    """Velocity error (m/s) against CPU time per solve, one panel per problem, one line per
    solver (its budgets), log-log."""
    from physval.report import engine_styles, pyplot, save_figure
    plt = pyplot()
    names = list(dict.fromkeys(curves["problem"]))
    cols = min(4, len(names))
    rows = math.ceil(len(names) / cols)
    fig, axes = plt.subplots(rows, cols, figsize=(3.8 * cols, 3.2 * rows), squeeze=False)
    styles = engine_styles([s.replace(" ", "-") for s in SOLVERS])
    floor = 1e-16  # an exact zero drawn at the plot's floor
    for ax, name in zip(axes.flat, names):
        for solver, df in curves[curves["problem"] == name].groupby("solver", sort=False):
            ax.loglog(df["cpu s"] * 1e6, np.maximum(df["velocity error m/s"], floor), label=solver, ms=4,
                      **styles[solver.replace(" ", "-")])
        ax.set_title(name, fontsize=9)
        ax.set_xlabel("CPU time per solve (us)", fontsize=8)
        ax.set_ylabel("velocity error (m/s)", fontsize=8)
        ax.tick_params(labelsize=7)
    for ax in list(axes.flat)[len(names):]:
        ax.axis("off")
    axes.flat[0].legend(fontsize=7)
    fig.suptitle("Precision against CPU time: the reference's contact solvers beside Pinocchio's (1 to 1024 "
                 "sweeps or iterations; Lemke exact)", fontsize=10)
    fig.tight_layout()
    save_figure(fig, path)


# --- the bench section ----------------------------------------------------------------------------

NOTE = ("The reference's contact problems of a few steps of its own scenes (physval/readings/oracle.py: "
        "SCENES), each solved by the reference's Lemke, PGS and SPOOK (PGS on A + eps, note 004's "
        "regularisation at its default k and d: a different problem by design, so it parts by about eps gamma) "
        "and by Pinocchio's ADMM and PGS (the `oracle` extra), each to its own tolerance. Residuals in m/s, zero at "
        "a solution: `pyramid` the reference's friction law, `cone` Coulomb's (Pinocchio's); where A is singular "
        "(a box's four corners) the reference may share friction between corners in a way the cone does not allow "
        "while moving the box alike, so its cone residual is not zero there. `velocity diff` and `impulse diff`: the "
        "largest difference from Pinocchio's ADMM in each body's velocity change and total contact impulse "
        "(unique even where the impulses are not); `impulses diff` only where A has full rank. `agrees`: velocity "
        "diff within `tolerance` (1e-6 of the problem's largest |b|: Lemke's own acceptance). Figure "
        "bench_oracle.png: velocity error (from ADMM's solution) against CPU time (user + sys) of one solve, "
        "Python call included, for budgets of 1 to 1024 sweeps or iterations; its points in "
        "bench_oracle_curves.csv.")


def measure(out: Path) -> pd.DataFrame:
    """The bench section: the agreement table; the problems (oracle_problems.npz), the
    precision-time points (bench_oracle_curves.csv) and their figure (bench_oracle.png)
    written to `out`. Raises RuntimeError without Pinocchio."""
    if not available():
        raise RuntimeError('Pinocchio is not installed: pip install ".[oracle]" (the `pin` package)')
    from physval.report import write_atomic
    problems = capture()
    save(problems, Path(out) / "oracle_problems.npz")
    curves = precision_time(problems)
    write_atomic(Path(out) / "bench_oracle_curves.csv", curves.to_csv(index=False))
    plot(curves, Path(out) / "bench_oracle.png")
    return readable(agreement(problems))


def readable(df: pd.DataFrame) -> pd.DataFrame:
    """`df` with its m/s and N s columns in two significant digits (the bench's tables round
    to 4 decimals, which would show 1e-12 as 0); not compared: empty."""
    out = df.copy()
    for col in [c for c in df.columns if c.endswith(("m/s", "N s"))]:
        out[col] = [("" if math.isnan(x) else f"{x:.2g}") for x in df[col]]
    return out
