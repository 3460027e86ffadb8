"""A compact, readable rigid-body contact engine: the project's reference implementation.

Imports the standard library, numpy and numba only; nothing from `cases`, `adapters` or
`physval`. Settings live in one `config.Config`.

Speed: the inner loops (the sweeps of sequential impulses and of projected Gauss-Seidel,
Lemke's pivots, the pairwise Newton-Coulomb loop, the compliant substeps, the box-box
narrow phase, the contact rows of a step) are written
once, in plain Python on numpy arrays, and compiled by numba (`compiled.njit`, nopython,
no fastmath, so every operation rounds as in Python: the results are those of the plain
Python code to the last digit where the operations are the same, and within 1e-8
relative where a 3x3 solve or matrix product now runs in numba's LAPACK/BLAS). numba is a
dependency of the project (wheels 64 MB with llvmlite, 8.5 s to install); without it, or
with NUMBA_DISABLE_JIT=1, the same functions run as plain Python, slower. Compiled code is
cached on disk by numba (`__pycache__` beside each module, or $NUMBA_CACHE_DIR): the first
process on a fresh checkout compiles (about 30 s of CPU for all formulations, Lemke's
pivoting 16 s of it, the narrow phase and rows 4 s), later processes load the cache (about
1 s). The world's bookkeeping around them (contact and row objects, broad phase, warm
starting, integration) is plain Python: on a 55-box pyramid the sequential impulses'
compiled sweeps are about 40 % of a step, on a 5-box stack the bookkeeping is most of it.
The cyclic garbage collector is paused during a step (World.step).

Modules:

- `rigid_body`  body state (x, q, v, w), mass, inertia, symplectic Euler integration
- `geometry`    shapes and narrow phase: contact points with normal, depth, feature id
- `broadphase`  sort-and-sweep along one axis (note 001, "broad phase sweep")
- `contact`     contact constraint rows (normal, tangents), `r x n` terms, effective mass
- `sequential_impulses`  the default formulation "si" (note 001, "sequential impulses")
- `world`       `World`: bodies, pair materials, gravity; `step(dt)`

One step of `World.step(dt)` (note 001, "simulation loop"):

1. collide: broad phase, narrow phase (shapes up to `config.margin` apart, plus the
   step each body can travel); each contact gets its rows (`contact.prepare`), its
   approach velocity `vn0` measured now (before external forces), its normal `target`
   velocity (restitution, speculative gaps: `Contact.normal_target`; contacts that touch
   only late in the step are left to the next one), whether it `sticks`, and, with
   `config.warm_start`, last step's impulses of the same contact (same bodies, same
   feature id) in `Pn` / `Pt` (then `warm` is True);
2. gravity: v += g dt (skipped when gravity is zero);
3. solve: the formulation named by `config.formulation` changes body velocities;
4. integrate positions and orientations from v + vp, w + wp (pseudo-velocities, zero
   unless the formulation set them), then clear vp, wp.

Formulation interface -- one module per formulation, one function:

    solve(contacts: list[contact.Contact], bodies: list[rigid_body.RigidBody],
          dt: float, config: config.Config) -> tuple[str, ...]

- Name: `config.formulation = "<name>"` imports `reference_impl.<name>` and calls its
  `solve`; the only alias is "si" -> `sequential_impulses`. Add a formulation by adding
  one file; formulation-specific settings go in `config.params` (document the keys in
  the module docstring).
- Called after external forces are in the velocities (`body.v`, `body.w`) and before
  positions move; `body.v0`, `body.w0` hold the velocities before external forces (so
  the external impulse of a step is `(v - v0) / inv_mass`).
- It must change `body.v`, `body.w` (dynamic bodies only; `inv_mass` and `inv_I` are 0
  for static ones and `inv_I` is 0 for bodies that cannot rotate) and leave in each
  contact the impulses of this step: `Pn` (normal, N s, >= 0) and `Pt` (list, one per
  tangent row). The world reports `Pn / dt` summed per body pair as the contact force
  and keeps `Pn`, `Pt` for next step's warm start.
- On entry `Pn`, `Pt` hold the warm-start values (0 if none or warm start is off;
  `contact.warm` says which); whether to apply them is the formulation's choice.
- It may set pseudo-velocities `body.vp`, `body.wp` (position correction that moves
  positions this step but is not kept as velocity).
- It returns the names of the stages it ran (e.g. ("warm_start", "velocity", "friction",
  "position")); the world appends them to `world.stages`.
- `knobs(config) -> dict`: what the formulation does with the contacts (its solver,
  friction set, restitution, depenetration, settings in force), for the record of the
  run; only the formulation that runs describes itself.
- Optional: `unsupported(world) -> str | None`, the reason the formulation cannot
  represent this world faithfully (adapters raise `Unsupported` with it).

Contact rows (`contact.Row`, see contact.py) give every formulation the same pieces:
`row.velocity()` (relative velocity along the row, J v), `row.apply(P)` (impulse P along
the row on both bodies, v += M^-1 J^T P), `row.mass` (1 / J M^-1 J^T) and
`contact.coupling(row_i, row_j)` (the off-diagonal J_i M^-1 J_j^T, for matrix solvers).
A contact has `normal` (Row) and `tangents` (tuple of 0, 1 (2D) or 2 Rows: none when
the pair is frictionless), `target` (the normal velocity to reach: row velocity >=
target; use it rather than re-deriving restitution from `vn0`, it also holds the
speculative -gap/dt of contacts not yet touching), `e`, `mu_s`, `mu_k`, `mu` (the one in
force: mu_s while it `sticks`, else mu_k), `depth` (> 0 overlapping, < 0 a gap), `bias`
(beta/dt (depth - slop)+), `point`, `n` (unit, from body a to body b), `a`, `b`,
`feature`.
"""

__version__ = "0.1.0"
