"""A compact, readable rigid-body contact engine: the project's reference implementation.

Imports the standard library, numpy and numba only; nothing from `cases`, `adapters` or
`physval`. Settings live in one `config.Config`.

Speed: the whole step is compiled. Each function is written once, in plain Python on numpy
arrays, floats and named tuples, and compiled by numba (`compiled.njit`, nopython, no
fastmath, so every operation rounds as in Python); `World.step` is two compiled calls,
`world.begin` (the broad and narrow phase, the rows, the warm start, gravity: compiled
once for every formulation) and `world.end` (the formulation's solve and the integration:
compiled per formulation), with nothing per body or per contact in Python. Where the previous, partly Python version of this engine summed with numpy (einsum,
BLAS products, LAPACK), the compiled code sums in numpy's order or calls the same BLAS and
LAPACK routines, so its results are those of that version to the last bit. numba is a
dependency of the project; without it, or with NUMBA_DISABLE_JIT=1, the same functions
run as plain Python, much slower. Compiled code is kept in numba's on-disk cache
(compiled.py says where, and when it is compiled again).

Modules:

- `vectors`     3-vectors and 3x3 matrices on tuples or arrays
- `rigid_body`  body state (x, q, v, w), mass, inertia, symplectic Euler integration
- `geometry`    shapes and narrow phase: contact points with normal, depth, feature id
- `broadphase`  sort-and-sweep along one axis (note 001, "broad phase sweep")
- `contact`     contacts and their constraint rows (normal, tangents), `r x n` terms, effective mass
- `sequential_impulses`  the default formulation "si" (note 001, "sequential impulses")
- `joints`      ball, revolute, prismatic and fixed joints as rows beside the contact rows
                (limits unilateral, joint friction boxed)
- `world`       `World`: bodies, pair materials, gravity, joints (`join`); `step(dt)`

One step (`World.step`: `world.begin`, then `world.end`; note 001, "simulation loop"):

1. collide: broad phase, narrow phase (shapes up to `config.margin` apart, plus the
   step each body can travel); each contact gets its rows (`contact.prepare`), its
   approach velocity `vn0` measured now (before external forces), its normal `target`
   velocity (restitution, speculative gaps: `contact.normal_target`; contacts that touch
   only late in the step are left to the next one), whether it `sticks`, and, with
   `config.warm_start`, last step's impulses of the same contact (same bodies, same
   feature id) in `Pn` / `Pt` / `Pq` (then `warm` is True);
2. gravity: v += g dt (skipped when gravity is zero), then the constant loads
   (`World.load`: v += F/m dt, w += I^-1 tau dt);
3. solve: the formulation named by `config.formulation` changes body velocities;
4. integrate positions and orientations from v + vp, w + wp (pseudo-velocities, zero
   unless the formulation set them), then clear vp, wp.

Formulation interface -- one module per formulation:

    class Settings(NamedTuple): ...               # what its solve needs of the Config
    def settings(config: config.Config) -> Settings
    STAGES: tuple[str, ...]                       # the stages its solve can run, in order
    @njit
    def solve(contacts: contact.Contacts, bodies: rigid_body.Bodies, dt: float,
              settings: Settings) -> int          # bit k set: STAGES[k] ran

- Name: `config.formulation = "<name>"` imports `reference_impl.<name>`; the only alias is
  "si" -> `sequential_impulses`. The type of its `Settings` picks its `solve` when `world.end`
  compiles (world.solve), so adding a formulation is adding one file; formulation-specific
  settings go in `config.params` (document the keys in the module docstring).
- Called after external forces are in the velocities (`bodies.v`, `bodies.w`) and before
  positions move; `bodies.v0`, `bodies.w0` hold the velocities before external forces (so
  the external impulse of a step is `(v - v0) / inv_mass`).
- It must change `bodies.v`, `bodies.w` (dynamic bodies only; `inv_mass` and `inv_I` are
  0 for static ones and `inv_I` is 0 for bodies that cannot rotate) and leave in each
  contact the impulses of this step: `Pn[j]` (normal, N s, >= 0), `Pt[j, :n_tangents[j]]`
  and `Pq[j, :n_rolling[j] + n_torsion[j]]`. The world reports `Pn / dt` summed per body
  pair as the contact force and keeps the impulses for next step's warm start.
- On entry `Pn`, `Pt`, `Pq` hold the warm-start values (0 if none or warm start is off;
  `contacts.warm` says which); whether to apply them is the formulation's choice.
- It may set pseudo-velocities `bodies.vp`, `bodies.wp` (position correction that moves
  positions this step but is not kept as velocity).
- `knobs(config) -> dict`, in Python: what the formulation does with the contacts (its
  solver, friction set, restitution, depenetration, settings in force), for the record of
  the run; only the formulation that runs describes itself.
- Optional, in Python: `unsupported(world) -> str | None`, the reason the formulation
  cannot represent this world faithfully (adapters raise `Unsupported` with it);
  `CONTACT_TORQUES` (it has torque rows) and `KEEP_LATE_CONTACTS` (it keeps the contacts
  that touch late in the step: a force law must see them).
- Optional, joints: `JOINT_KINDS` (the joints.KINDS it solves) and, compiled,
  `solve_joints(contacts, joints, bodies, dt, settings) -> int`, which `world.end` calls
  in place of `solve` for a world with joints (joints.Joints: their rows and position
  errors made at the step's start, their impulses kept in `P` for the warm start);
  `JOINT_LIMITS`, `LIMIT_RESTITUTION`, `JOINT_FRICTION` (it solves limit rows, with a
  restitution, and friction rows: joints.py). A formulation without them refuses a world
  that asks for them (World.unsupported).

Contacts (`contact.Contacts`, a struct of arrays, row j the contact j) give every
formulation the same pieces: for each contact its bodies `a`, `b` (indices into the
bodies' arrays), `point`, `n` (unit, from a to b), `depth` (> 0 overlapping, < 0 a gap),
`feature`, `e`, `mu_s`, `mu_k`, `mu` (the one in force: mu_s while it `sticks`, else mu_k),
`target` (the normal velocity to reach: row velocity >= target; use it rather than
re-deriving restitution from `vn0`, it also holds the speculative -gap/dt of contacts not
yet touching), `bias` (beta/dt (depth - slop)+), and its rows: `normal`, `tangents` (0, 1
(2D) or 2 of them: none when the pair is frictionless) and `torques`, each row the
ROW_TERMS numbers of contact.py (J and M^-1 J^T of the row, its K and mass = 1 / K), with
`contact.velocity(row, ...)` (J v) and `contact.apply(row, P, ...)` (v += M^-1 J^T P). From
Python, `World.contacts` gives the same as `contact.Contact` objects.
"""

__version__ = "0.1.0"
