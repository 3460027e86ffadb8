"""The case format: a family is a scene builder, a parameter grid, observables, closed-form
expectations and tolerances (each with a one-line reason). One file per family under
`cases/`, exporting `FAMILY`; users add families the same way from `--cases-dir DIR`
(docs/extend/writing_cases.md walks through one).

How physval uses a family, per variant (one `params` dict of the grid) and engine:

    dt     = family.dt_for(params)              (or the run's --dt)
    checks = family.expect(params, dt)          closed forms, tolerances, reasons
    scene  = family.scene(params)               engine-neutral, validated when made
    traj   = engine runs scene for family.duration(params) seconds, one sample a step
    values = family.observe(traj, params)       {metric: number} for every check
    verdict per check: pass / fail / deviation (a known, bounded shortfall)
"""
from __future__ import annotations

import json
import math
from contextlib import contextmanager
from dataclasses import dataclass, replace
from typing import Callable, NamedTuple

from cases.scene import Scene
from cases.trajectory import Trajectory


class CaseError(ValueError):
    """A case family that cannot be used; the message names the family and the field."""


# What a family may ask of an engine beyond representing its scene (CaseFamily.needs):
# "contact_forces"  the observer reads Trajectory.force / impulse (normal force per pair);
# "contact_geometry"  the observer reads Trajectory.points for their geometry only: the
#                   contact points the engine reported after its last step
#                   (cases.trajectory.ContactPoint: the pair, where, the normal, the gap), as
#                   its collision detection found them;
# "contact_points"  ... and their forces too (f_n, f_t);
# "impact_model:M"  the closed forms assume the engine resolves simultaneous impacts by
#                   model M (cases.scene.IMPACT_MODELS); other engines report unsupported.
# "restitution_law:L"  the closed forms assume restitution law L at a frictional contact
#                   (cases.scene.RESTITUTION_LAWS); other engines report unsupported.
NEEDS = ("contact_forces", "contact_geometry", "contact_points")
NEEDS_PREFIXES = ("impact_model:", "restitution_law:")  # followed by one of IMPACT_MODELS, RESTITUTION_LAWS

# Labels a family carries (CaseFamily.tags); physval selects by them, it keeps no name lists:
TAGS = {
    "core": "the three core families: the default sweep, and run by every reference formulation by default",
    "conformance": "the adapter conformance battery (what every adapter must do)",
    "robustness": "hard scenes judged by invariants: `physval stress`",
    "cross_engine": "no full closed form: well-posed quantities, also compared across engines",
    "swept": "bodies moving further in a step than the gap they would hit: the default families of the engines' "
             "continuous-collision configurations (Adapter.default_tags)",
}

MAX_DT = 0.1  # s: a family's time step above this leaves no contact worth judging (adapters.base.Settings)

# The unit round-off of each float width an engine may declare (adapters.base.Capabilities
# .float_bits): one rounding of x errs by at most u |x|, u = 2^-p for a p-bit significand
# (IEEE 754 binary64: p = 53; binary32: p = 24).
UNIT_ROUNDOFF = {64: 2.0**-53, 32: 2.0**-24}

# Rounded updates of a body's velocity that one pair impact makes, per sub-step: an impulse
# solver applies the pair's impulse in its warm-start, solve and relax passes and (once a
# step, counted here per sub-step) its restitution pass, each rounding both bodies'
# velocities (u m |v|) and scaling the impulse by a stored, rounded inverse mass (u m |dv|
# <= u m |v| before and after): 4 passes x 2 roundings, over the 2 steps the impulse acts in
# (the impact's, and the next, whose warm start applies it again and whose solve takes it
# back). Where no force acts (zero gravity along the momentum) a velocity update adds 0
# exactly, so only impacts round the momentum.
IMPACT_ROUNDINGS = 2 * 4 * 2

# What a check's miss shows (Check.measures): the physics, the order of the engine's time
# integration (a tolerance that is a scheme's error bound on exactly conserved motion), or an
# invariance the engine breaks (two runs of one scene that physics says are the same differ:
# physval.core.invariance makes these checks, from the relations of cases.relations).
MEASURES = ("physics", "integrator", "invariance")


def impulse_roundoff(pair_momentum: float, impacts: int = 1) -> float:
    """Check.roundoff of a total momentum that `impacts` pair impacts change, each between
    bodies whose m |v| sum to at most `pair_momentum` (kg m/s)."""
    return IMPACT_ROUNDINGS * impacts * pair_momentum


@dataclass(frozen=True)
class Check:
    """One verdict: `metric` (the name observe() gives its value under) measured against a
    closed-form `expected` value in `unit` (SI, e.g. "m/s"), within `tolerance`.

    `kind` says which error the tolerance bounds: "abs" (|measured - expected|, in `unit`)
    or "rel" (that divided by |expected|). `why` is the one-line reason for its size: the
    physics or numerics that allow it (time step, contact stiffness, solver convergence).

    `roundoff` is the part of the tolerance that floating-point rounding takes, which
    depends on the engine's float width: the sum, over the rounded operations of one
    sub-step that the checked value accumulates through the run, of the magnitudes they
    round (in `unit`; for kind "rel", divided by |expected|). An engine computing with unit
    round-off u (UNIT_ROUNDOFF of its declared float width) in k sub-steps a step is judged
    within `tolerance + roundoff * k * u` (`at_precision`); `tolerance` alone is what a
    float64 engine is held to, with room for its round-off.

    `roundoff_at` is, where rounding errors do not add up per sub-step (a flight's
    positions: cases/roundoff.py), a function (float_bits, substeps) -> the part of the
    tolerance rounding takes at that width, measured by stepping the motion in that
    arithmetic with a stated factor; `at_precision` adds it as it adds `roundoff`.

    `measures` says what a miss shows (MEASURES): "physics" (the default), or "integrator"
    when the tolerance is the error bound of a time-stepping scheme of a stated order (a
    second-order rotation step, say) on motion whose physics conserves exactly, so that a
    miss measures the engine's integration order, not its physics; or "invariance" for the
    invariance battery's checks (physval.core.invariance); reports show those checks apart
    (physval.readings.scorecard)."""
    metric: str
    unit: str
    expected: float
    tolerance: float
    kind: str
    why: str
    roundoff: float = 0.0
    measures: str = "physics"
    roundoff_at: Callable[[int, int], float] | None = None

    def __post_init__(self):
        if not isinstance(self.metric, str) or not self.metric:
            raise CaseError(f"check metric = {self.metric!r}: must be a non-empty string")
        if self.measures not in MEASURES:
            raise CaseError(f"check {self.metric!r}: measures = {self.measures!r}: must be one of {', '.join(MEASURES)}")
        if self.kind not in ("abs", "rel"):
            raise CaseError(f"check {self.metric!r}: kind = {self.kind!r}: must be 'abs' or 'rel'")
        for name in ("expected", "tolerance", "roundoff"):
            value = getattr(self, name)
            if isinstance(value, bool) or not isinstance(value, (int, float)) or not math.isfinite(value):
                raise CaseError(f"check {self.metric!r}: {name} = {value!r}: must be a finite number")
        if self.tolerance < 0:
            raise CaseError(f"check {self.metric!r}: tolerance = {self.tolerance!r}: must be finite and >= 0")
        if self.roundoff < 0:
            raise CaseError(f"check {self.metric!r}: roundoff = {self.roundoff!r}: must be finite and >= 0")
        if not isinstance(self.why, str) or not self.why.strip():
            raise CaseError(f"check {self.metric!r}: why is empty: every tolerance needs its reason")
        if self.roundoff_at is not None and not callable(self.roundoff_at):
            raise CaseError(f"check {self.metric!r}: roundoff_at = {self.roundoff_at!r}: must be a function "
                            "(float_bits, substeps) -> tolerance, or None")


    def at_precision(self, float_bits: int = 64, substeps: int = 1) -> "Check":
        """The check an engine computing with `float_bits` floats in `substeps` sub-steps a
        step is judged by: its round-off part added to the tolerance at that width."""
        if not self.roundoff and self.roundoff_at is None:
            return self
        if float_bits not in UNIT_ROUNDOFF:
            raise CaseError(f"float_bits = {float_bits!r}: must be one of {sorted(UNIT_ROUNDOFF)}")
        k = max(1, int(substeps))
        extra = self.roundoff * k * UNIT_ROUNDOFF[float_bits]
        if self.roundoff_at is not None:
            extra += float(self.roundoff_at(float_bits, k))
        return replace(self, tolerance=self.tolerance + extra, roundoff=0.0, roundoff_at=None)


class Catch(NamedTuple):
    """A wrong answer a family must catch (CaseFamily.catches): `fault`, the name of a
    planted fault (physval/faults.py: an effect off or doubled, an inertia swapped, another
    combination rule or restitution law, ...), and `variant`, the id of the variant whose
    checks show it. tests/test_catches.py plants each on that variant, on the reference
    engine (or `engine`, a reference formulation where the variant needs one), and
    requires a check to fail there (and none without the fault), so a family cannot claim
    what it cannot see."""
    fault: str
    variant: str
    engine: str = "reference"  # where it is planted: the reference, or a formulation that runs the variant


@dataclass(frozen=True)
class Variant:
    """One point of a family's grid: the `family` name, its readable `id` (the family's
    variant_id of the params: unique in the family, used in test ids, reports and
    `--cases NAME[ID]` selections) and its `params` dict."""
    family: str
    id: str
    params: dict

    @property
    def test_id(self) -> str:
        return f"{self.family}[{self.id}]"

    @property
    def params_json(self) -> str:
        return json.dumps(self.params, sort_keys=True)


def friction_label(p: dict) -> str:
    """'mu=0.5' when mu_s = mu_k, else 'mu_s=0.5,mu_k=0.3': for variant ids."""
    return f"mu={p['mu_s']}" if p["mu_s"] == p["mu_k"] else f"mu_s={p['mu_s']},mu_k={p['mu_k']}"


def plane_label(p: dict) -> str:
    """',2D' for a 2D variant (params 'dim' = 2), else '': for variant ids."""
    return ",2D" if p.get("dim", 3) == 2 else ""


def _default_id(params: dict) -> str:
    return ",".join(f"{k}={v}" for k, v in params.items())


@dataclass(frozen=True)
class CaseFamily:
    """A family of analytic cases: one scene builder over a grid of parameters, with the
    closed form and tolerance of every check.

    - `name`: an identifier, unique among families (the file's stem is a good choice).
    - `summary`: one sentence for `physval list` and the report.
    - `source`: where the closed form comes from (note and slide, book, derivation).
    - `grid`: one params dict per variant (JSON-serialisable values); `full_grid`: more
      variants that only `--full` runs (long or many-body scenes).
    - `scene(params) -> Scene`; `duration(params) -> seconds`.
    - `observe(trajectory, params) -> {metric: float}`: one finite number per check, under
      any engine, even a wrong one (then the check fails with a size). Helpers that make
      discrete-time readings exact are in `cases.observables`.
    - `expect(params, dt) -> [Check]`: the closed forms; a tolerance may depend on dt.
    - `dt`: the default time step in s (or params -> dt per variant), in (0, 0.1].
    - `needs`: what the observer needs beyond the scene (NEEDS; e.g. "contact_forces", or
      "impact_model:M" when the closed forms hold for impact model M only), a frozenset or
      params -> frozenset; engines that lack it report the variant `unsupported`.
    - `sweep_variants`: variant ids `physval sweep` varies dt and iterations on (default:
      the first variant).
    - `variant_id(params) -> str`: the readable id in test ids, reports and selections.
    - `tags`: labels from TAGS ("core", "robustness", "cross_engine", ...).
    - `catches`: the wrong answers the family must catch (`Catch`: a planted fault's name
      and the variant that shows it): what its docstring claims to test, as faults.
    """
    name: str
    summary: str
    source: str
    grid: tuple[dict, ...]
    scene: Callable[[dict], Scene]
    duration: Callable[[dict], float]
    observe: Callable[[Trajectory, dict], dict]
    expect: Callable[[dict, float], list[Check]]
    dt: float | Callable[[dict], float] = 1e-3
    needs: frozenset[str] | Callable[[dict], frozenset[str]] = frozenset()
    sweep_variants: tuple[str, ...] = ()
    variant_id: Callable[[dict], str] = _default_id
    tags: frozenset[str] = frozenset()
    full_grid: tuple[dict, ...] = ()
    catches: tuple[Catch, ...] = ()

    def dt_for(self, params: dict) -> float:
        """A variant's default time step (e.g. fine enough to sample a 1 ms compliant contact)."""
        return float(self.dt(params) if callable(self.dt) else self.dt)

    def needs_of(self, params: dict) -> frozenset[str]:
        """Capabilities beyond the scene's that a variant needs (e.g. contact forces)."""
        return frozenset(self.needs(params) if callable(self.needs) else self.needs)

    @property
    def cross_engine(self) -> bool:
        """Tagged "cross_engine": the report also compares the engines with each other."""
        return "cross_engine" in self.tags

    @property
    def variants(self) -> tuple[Variant, ...]:
        """The grid's variants (what a run takes without --full)."""
        return tuple(Variant(self.name, self.variant_id(p), dict(p)) for p in self.grid)

    @property
    def all_variants(self) -> tuple[Variant, ...]:
        """The grid and the full grid (variants of both counted once)."""
        ids = {v.id for v in self.variants}
        extra = tuple(Variant(self.name, self.variant_id(p), dict(p)) for p in self.full_grid)
        return self.variants + tuple(v for v in extra if v.id not in ids)

    @property
    def module_file(self) -> str:
        """The file that defines the family (for messages)."""
        import inspect
        try:
            return inspect.getsourcefile(self.scene) or self.name
        except TypeError:
            return self.name

    def validate(self, full: bool = False) -> None:
        """Raise CaseError, naming the family, variant and field, unless every variant
        builds a valid scene and its checks (`full`: the full grid too)."""
        self.validate_grid(full)
        for v in self.all_variants if full else self.variants:
            self.validate_variant(v)

    def validate_grid(self, full: bool = False) -> None:
        """The family as a whole: its name, tags, a grid of distinct variant ids, and
        sweep_variants among them. CaseError naming the family otherwise."""
        if not isinstance(self.name, str) or not self.name.isidentifier():
            raise CaseError(f"family name {self.name!r}: must be an identifier (letters, digits, _)")
        unknown = set(self.tags) - set(TAGS)
        if unknown:
            raise CaseError(f"{self.name}: tags {sorted(unknown)}: unknown; choose from {', '.join(TAGS)}")
        if not self.grid:
            raise CaseError(f"{self.name}: grid is empty: a family needs at least one variant")
        with user_code(self.name, "variant_id() raised", VARIANT_RULE):
            ids = [v.id for v in (self.all_variants if full else self.variants)]
            every = {v.id for v in self.all_variants}
        repeated = sorted({i for i in ids if ids.count(i) > 1})
        if repeated:
            raise CaseError(f"{self.name}[{repeated[0]}]: variant id repeats: make variant_id distinguish the grid")
        unknown = set(self.sweep_variants) - every
        if unknown:
            raise CaseError(f"{self.name}: sweep_variants names no variant: {sorted(unknown)}")
        if not all(isinstance(c, tuple) and len(c) in (2, 3) and all(isinstance(x, str) for x in c)
                   for c in self.catches):
            raise CaseError(f"{self.name}: catches must be cases.family.Catch(fault, variant[, engine]) names")
        unknown = {c[1] for c in self.catches} - every
        if unknown:
            raise CaseError(f"{self.name}: catches name no variant: {sorted(unknown)}")

    def validate_variant(self, v: Variant) -> tuple[Scene, float, list[Check]]:
        """Build the variant (its scene, dt, duration, needs and checks), each checked:
        what it built. CaseError '<family>[<variant>]: ...' otherwise, for any exception
        the family's code raises too (an exit included)."""
        with user_code(v.test_id, "its code raised", VARIANT_RULE):
            return self._built(v)

    def _built(self, v: Variant) -> tuple[Scene, float, list[Check]]:
        from cases.scene import IMPACT_MODEL_NEED, IMPACT_MODELS, RESTITUTION_LAW_NEED, RESTITUTION_LAWS
        try:
            json.dumps(v.params)
        except TypeError as exc:
            raise CaseError(f"params must be JSON-serialisable ({exc})") from None
        scene = self.scene(v.params)
        if not isinstance(scene, Scene):
            raise CaseError(f"scene() returned {type(scene).__name__}, not a Scene")
        dt = self.dt_for(v.params)
        if not (math.isfinite(dt) and 0 < dt <= MAX_DT):
            raise CaseError(f"dt = {dt!r}: must lie in (0, {MAX_DT:g}] s")
        T = self.duration(v.params)
        if not (isinstance(T, (int, float)) and math.isfinite(T) and T > 0):
            raise CaseError(f"duration = {T!r}: must be > 0 s")
        if T / dt > 5e7:
            raise CaseError(f"duration / dt = {T / dt:.3g} steps: more than 5e7")
        bad = [n for n in self.needs_of(v.params) if n not in NEEDS and not any(
            n.startswith(prefix) and n[len(prefix):] in values
            for prefix, values in ((IMPACT_MODEL_NEED, IMPACT_MODELS), (RESTITUTION_LAW_NEED, RESTITUTION_LAWS)))]
        if bad:
            raise CaseError(f"needs {sorted(bad)}: unknown; choose from {', '.join(NEEDS)} "
                            f"or {', '.join(p + '...' for p in NEEDS_PREFIXES)}")
        try:
            checks = self.expect(v.params, dt)
        except CaseError as exc:
            raise CaseError(f"expect(): {exc}") from None
        if not checks:
            raise CaseError("expect() returned no checks")
        if not all(isinstance(c, Check) for c in checks):
            raise CaseError("expect() must return a list of cases.family.Check")
        metrics = [c.metric for c in checks]
        if len(set(metrics)) != len(metrics):
            raise CaseError(f"expect() names a metric twice: {metrics}")
        return scene, dt, list(checks)


# --- code a case author (or a plug-in) wrote --------------------------------------------------

# What such code may do, said in the one-line error when it does something else.
IMPORT_RULE = "a case file must import without error and define FAMILY"
VARIANT_RULE = "scene, duration, dt, needs, variant_id and expect must build every variant"
OBSERVE_RULE = "an observer must give every check a finite number whatever the engine did"


def raised(exc: BaseException) -> str:
    """An exception as a message names it: 'Type: first line of its message', or
    'SystemExit(code)' for an exit."""
    if isinstance(exc, SystemExit):
        return f"SystemExit({exc.code!r})"
    text = str(exc).splitlines()[0] if str(exc) else ""
    return f"{type(exc).__name__}: {text}" if text else type(exc).__name__


def raised_where(exc: BaseException) -> str:
    """', at FILE:LINE' of the innermost frame of the exception's traceback in the user's
    own code: outside physval's packages (cases, adapters, physval, reference_impl) and the
    Python installation (the standard library, site-packages), so an observer that hands
    numpy an empty window is named at its own line, not numpy's; the innermost frame if
    none is; '' without a traceback. FILE is relative to the working directory if inside it."""
    import traceback
    frames = traceback.extract_tb(exc.__traceback__) if exc.__traceback__ else []
    if not frames:
        return ""
    path, line = users_frame(exc) or (frames[-1].filename, frames[-1].lineno)
    return f", at {path}:{line}"


def users_frame(exc: BaseException) -> tuple[str, int] | None:
    """(FILE, LINE) of the innermost frame of the exception's traceback in the user's own
    code (raised_where), or None where no frame is the user's."""
    import sys
    import sysconfig
    import traceback
    from pathlib import Path
    frames = traceback.extract_tb(exc.__traceback__) if exc.__traceback__ else []
    own = [Path(sys.modules[name].__file__).resolve().parent for name in ("cases", "adapters", "physval",
                                                                         "reference_impl") if name in sys.modules]
    libraries = {Path(sysconfig.get_paths()[key]).resolve() for key in ("stdlib", "platstdlib", "purelib", "platlib")}

    def users(frame) -> bool:
        path = Path(frame.filename).resolve()
        return not any(path.is_relative_to(root) for root in own + list(libraries))

    frame = next((f for f in reversed(frames) if users(f)), None)
    if frame is None:
        return None
    path = Path(frame.filename)
    try:
        path = path.resolve().relative_to(Path.cwd())
    except ValueError:
        pass
    return str(path), frame.lineno


@contextmanager
def user_code(where: str, doing: str, rule: str, error: type[Exception] = CaseError):
    """Run code physval did not write (a family's functions, a user's file, an adapter):
    any exception it raises becomes one `error` line, '`where`: `doing` Type: message
    (`rule`), at FILE:LINE' (`raised_where`), an exit (SystemExit) and every other
    BaseException included, so that no user code ends physval's process by raising; only
    Ctrl-C passes. A CaseError or SceneError (the family's own complaint, already one line)
    becomes '`where`: message'."""
    from cases.scene import SceneError
    try:
        yield
    except KeyboardInterrupt:
        raise
    except (CaseError, SceneError) as exc:
        raise error(f"{where}: {exc}") from None
    except BaseException as exc:
        raise error(f"{where}: {doing} {raised(exc)} ({rule}){raised_where(exc)}") from None
