"""The invariance battery: the relations of cases.relations transform a scene and map the
transformed run back (the vocabulary's part), physval.core.invariance judges the two runs
against the engine's promise (the core's part), every relation is proven to catch what it
claims by a planted engine that breaks exactly that invariance (physval/faults.py), and the
battery reaches the report and the scorecard.

The planted proofs run on a small test family of ~60 steps (a two-box stack and a slide
off the axes), so that they take seconds; on the relations' own default scenes they are
marked slow."""
from __future__ import annotations

import math
import subprocess
import sys

import numpy as np
import pandas as pd
import pytest

from adapters import registry
from adapters.base import Capabilities, Settings, SettingsError
from cases import relations as R
from cases.family import CaseFamily, Check, Variant
from cases.scene import Body, Box, Hull, Material, Mesh, Scene, cube, ground
from cases.trajectory import Trajectory
from physval import faults
from physval.core import Context, Job, execute
from physval.core import invariance
from physval.core.context import Resolver
from physval.core.deviations import parse
from physval.core.plan import relation_jobs
from physval.core.selection import select_variants
from physval.readings import invariance as reading, scorecard
from tests.fakes import FakeAdapter
from tests.helpers import run_job, variant_scene

GEOMETRIC = [r for r in R.RELATIONS if not r.needs]
SCENES = [("slide_to_stop", "mu=0.5,v0=2,heading=22.5deg"), ("slide_to_stop", "mu=0.5,v0=2,2D"),
          ("stack_forces", "n=4,light-heavy"), ("pair_restitution", "e12=0.7,e23=0.4,e13=0.4,m=1:1:1,2D"),
          ("eccentric_impact", "e=0.5"), ("tumbling_box", "tilt=diag,e=0.0,mu=0.3")]


def variant(family: str, id_: str) -> Variant:
    return next(v for v in Context().resolver().family(family).variants if v.id == id_)


def start(scene: Scene, dt: float = 1e-3) -> Trajectory:
    """A one-sample trajectory: the scene's start state (what a run records at step 0)."""
    states = {b.name: np.concatenate([b.position, b.orientation, b.velocity, b.angular_velocity])[None]
              for b in scene.dynamic_bodies}
    return Trajectory(dt=dt, t=np.zeros(1), states=states)


# --- the vocabulary: transform, then map back --------------------------------------------------------

@pytest.mark.parametrize("relation", GEOMETRIC, ids=lambda r: r.name)
@pytest.mark.parametrize("family, variant", SCENES, ids=lambda x: x)
def test_mapping_back_undoes_the_transform(relation, family, variant):
    """The transformed scene's start state, mapped back, is the scene's own: to rounding of
    its size for the rotations and translations (the transformed numbers are rounded), and
    bit for bit for the mirror and the power-of-two scales (every factor exact)."""
    scene, _ = variant_scene(family, variant)
    if relation.applies(scene):
        pytest.skip(relation.applies(scene))
    back = relation.map_back(start(relation.transform(scene)), scene)
    exact = relation.name in ("mirror", "scale_4", "scale_quarter", "body_order", "as_hull", "as_mesh")
    size = invariance.size_of(scene) + relation.offset(scene)
    for name, row in start(scene).states.items():
        if exact:
            assert np.array_equal(back.states[name], row), (relation.name, name)
        else:  # 1e5 m away the rounding of a coordinate is 1.5e-11 m: a few ulps of the moved size
            np.testing.assert_allclose(back.states[name], row, rtol=0, atol=8 * np.finfo(float).eps * max(size, 1))


def test_a_turn_turns_gravity_and_planes_with_the_scene():
    scene, _ = variant_scene("slide_to_stop", "mu=0.5,v0=2,heading=22.5deg")
    tilted = R.ROTATE_TILTED.transform(scene)
    M = R.rotation_matrix(R.ROTATE_TILTED.turn)
    np.testing.assert_allclose(tilted.gravity, M @ np.asarray(scene.gravity), atol=1e-15)
    plane = next(b for b in tilted.bodies if b.static).shape
    np.testing.assert_allclose(plane.normal, M @ [0, 0, 1], atol=1e-15)
    assert R.ROTATE_VERTICAL.transform(scene).gravity == scene.gravity  # a turn about g leaves it alone
    moved = R.TRANSLATIONS[-1].transform(scene)
    plane = next(b for b in moved.bodies if b.static).shape
    assert plane.offset == pytest.approx(0.64e5)  # the plane z = 0 moved 64 km up along its normal


def test_the_mirror_image_of_a_hull_and_a_mesh_stays_valid_and_handed_right():
    """A hull's corners and a mesh's vertices flip in the body frame; the mesh's triangles
    turn round so that they stay wound outward (Scene validates both)."""
    tet = Hull(((1.0, 1.0, 1.0), (-1.0, -1.0, 1.0), (-1.0, 1.0, -1.0), (1.0, -1.0, -1.0)))
    floor = Mesh(((-5.0, -5.0, 0.0), (5.0, -5.0, 0.0), (5.0, 5.0, 0.0), (-5.0, 5.0, 0.0)), ((0, 1, 2), (0, 2, 3)))
    scene = Scene((Body("floor", floor, static=True), Body("tet", tet, mass=1.0, position=(0.3, 0.0, 2.0),
                                                             angular_velocity=(1.0, 2.0, 3.0))))
    mirrored = R.MIRROR_IMAGE.transform(scene)
    assert mirrored.body("tet").shape.vertices[0] == (-1.0, 1.0, 1.0)
    assert mirrored.body("floor").shape.triangles == ((0, 2, 1), (0, 3, 2))
    assert mirrored.body("tet").position == (-0.3, 0.0, 2.0)
    assert mirrored.body("tet").angular_velocity == (1.0, -2.0, -3.0)  # a pseudo-vector: -F w


def test_scaling_follows_froude_s_law():
    """Lengths x k, velocities x sqrt(k), angular velocities / sqrt(k), inertias x k^2,
    lever arms x k, a Hooke stiffness / k: a body's motion maps onto itself with time x sqrt(k)."""
    body = Body("b", cube(0.1), mass=2.0, inertia=(0.01, 0.02, 0.03), position=(1.0, 0.0, 0.5),
                velocity=(2.0, 0.0, 0.0), angular_velocity=(0.0, 4.0, 0.0))
    scene = Scene((ground(), body), material=Material(mu_s=0.5, rolling_resistance=0.01))
    big = R.SCALE_UP.transform(scene).body("b")
    assert big.shape.half_extents == (0.4, 0.4, 0.4) and big.position == (4.0, 0.0, 2.0)
    assert big.velocity == (4.0, 0.0, 0.0) and big.angular_velocity == (0.0, 2.0, 0.0)
    assert big.inertia == (0.16, 0.32, 0.48) and big.mass == 2.0
    assert R.SCALE_UP.transform(scene).material.rolling_resistance == 0.04
    assert R.SCALE_UP.time_scale == 2.0 == math.sqrt(R.SCALE_UP.k)


def test_a_box_as_a_hull_is_the_same_solid():
    scene, _ = variant_scene("stack_forces", "n=4,light-heavy")
    hulls = R.AS_HULL.transform(scene)
    for a, b in zip(scene.dynamic_bodies, hulls.dynamic_bodies):
        assert b.shape.kind == "hull"
        np.testing.assert_allclose(b.shape.inertia(b.mass), a.shape.inertia(a.mass), rtol=1e-12)
    meshed = R.AS_MESH.transform(scene)
    floor = next(b for b in meshed.bodies if b.static)
    assert floor.shape.kind == "mesh" and max(abs(c) for v in floor.shape.vertices for c in v[:2]) >= 49


def test_relations_without_meaning_for_a_scene_say_why_and_make_no_job():
    scene, _ = variant_scene("slide_to_stop", "mu=0.5,v0=2,2D")
    assert "x-z plane" in R.ROTATE_VERTICAL.applies(scene)
    assert "2D" in R.AS_MESH.applies(scene)
    jobs = relation_jobs(["rotate_vertical", "rotate_tilted"], ["pymunk"], Context().resolver(), True)
    assert {j.relation for j in jobs} == {"rotate_tilted"}  # a 2D engine: no turn about z


def test_every_relation_names_its_promise_and_scenes_that_exist():
    from physval.core.selection import select_variants
    families = Context().resolver().families
    for r in R.RELATIONS:
        assert r.promise in R.PROMISES and r.why and r.scenes, r.name
        for group in r.scenes:
            for spec in group:
                assert select_variants(families, [spec]), spec
    assert len({r.name for r in R.RELATIONS}) == len(R.RELATIONS)


# --- the contract: modes, and the settings that ask for them ----------------------------------------

def test_settings_check_the_thread_count_and_the_world_index():
    assert Settings(dt=1e-3, threads=4, world=(3, 4)).world == (3, 4)
    for bad in ({"threads": 0}, {"world": (4, 4)}, {"world": (1,)}, {"world": [0, 2]}):
        with pytest.raises(SettingsError, match=next(iter(bad))):
            Settings(dt=1e-3, **bad)
    with pytest.raises(ValueError, match="modes"):
        Capabilities(dimensions=frozenset({3}), shapes=frozenset(), native_restitution=True, static_kinetic=True,
                     contact_forces=True, iterations=True, modes=frozenset({"gpu"}))


def test_a_relation_needing_a_mode_the_engine_lacks_is_unsupported_with_the_reason():
    row, = run_job(Job("stack_forces", variant("stack_forces", "n=4,light-heavy"), "fake", relation="threads"),
                   adapter=FakeAdapter())
    assert row["status"] == "unsupported" and "thread pool" in row["reason"]
    assert row["metric"] == "invariance_threads" and row["measures"] == "invariance"


def test_every_engine_meets_every_relation_it_can_represent_and_says_why_not_the_rest():
    """For every installed engine (the registry's, plug-ins included) and every relation:
    a default run plans it on a scene the engine can represent, and each planned job either
    runs (the engine takes the transformed scene in the mode asked) or is refused with the
    adapter's reason; a relation with no job has a reason for every scene it could have
    taken. Planning and capabilities only: nothing is stepped."""
    resolver = Context().resolver()
    engines = [e for e in registry.engine_names() if registry.available(e)]
    runs = 0
    # named and --on-demand: every job an engine can take (physval.core.plan.leaves_out)
    planned = relation_jobs([r.name for r in R.RELATIONS], engines, resolver, True, on_demand=True)
    transformed = {}
    for engine in engines:
        caps = resolver.adapter(engine).capabilities
        for relation in R.RELATIONS:
            jobs = [j for j in planned if j.engine == engine and j.relation == relation.name]
            if not jobs:
                for spec in (spec for group in relation.scenes for spec in group):
                    (fam, (v, *_)), = select_variants(resolver.families, [spec]).items()
                    scene = resolver.family(fam).scene(v.params)
                    assert relation.applies(scene) or caps.cannot_run(scene), (engine, relation.name, spec)
                continue
            for job in jobs:
                key = (job.family, job.variant.id, relation.name)
                if key not in transformed:  # the same scenes for every engine: made once
                    transformed[key] = relation.transform(resolver.family(job.family).scene(job.variant.params))
                why = caps.cannot_run_as(relation.needs) or caps.cannot_run(transformed[key])
                assert why is None or (isinstance(why, str) and len(why) > 10), (engine, relation.name, why)
                runs += why is None
    assert runs >= len(engines)  # every engine runs some relation


# --- the core's judging ---------------------------------------------------------------------------

def test_the_promise_s_tolerance_follows_the_float_width_and_the_coordinates():
    scene, _ = variant_scene("slide_to_stop", "mu=0.5,v0=2,heading=22.5deg")
    near = invariance.tolerance(R.ROTATE_VERTICAL, scene, 1000)
    far = invariance.tolerance(R.TRANSLATIONS[1], scene, 1000)  # 1000 m
    L = invariance.size_of(scene)
    assert near == invariance.ROUNDINGS_PER_STEP * 2.0**-53 * 1000
    assert far == pytest.approx(near * (1000 + L) / L)
    assert invariance.tolerance(R.ROTATE_VERTICAL, scene, 1000, float_bits=32) == invariance.MEANINGFUL  # capped
    assert invariance.tolerance(R.THREADS, scene, 1000) == 0.0
    assert invariance.check(R.THREADS, scene, 10).why.startswith("bit-identical")


def test_a_free_flight_keeps_every_invariance_and_the_row_says_where_runs_part():
    """The fake engine flies bodies free (symplectic Euler): turned, moved, mirrored or
    scaled, the flight is the same to rounding; the verdict's value is the difference."""
    for name in ("rotate_tilted", "translate_100000m", "mirror", "scale_4", "body_order"):
        job = Job("slide_to_stop", variant("slide_to_stop", "mu=0.5,v0=2,heading=22.5deg"), "fake", relation=name)
        row, = run_job(job, adapter=FakeAdapter())
        assert row["status"] == "pass", (name, row["reason"])
        assert row["measured"] <= row["tolerance"] and "of scale" in row["reason"] + " of scale"


def test_a_known_deviation_names_the_relation_it_records():
    """An entry with metric `*` covers a family's closed forms, not the battery's verdicts:
    a broken invariance is recorded by an entry that names it."""
    text = ("slide_to_stop[*]:*  # the family's shortfall\n"
            "slide_to_stop[*]:invariance_rotate_*  # friction in a fixed tangent frame\n"
            "    e [x]:invariance_rotate_vertical = 0.2 +- 0.01\n")
    path = pytest.importorskip("pathlib").Path(sys.modules[__name__].__file__).parent / "_known_invariance.txt"
    try:
        path.write_text(text)
        first, second = parse(path)
    finally:
        path.unlink()
    assert not first.matches("slide_to_stop", "x", "invariance_rotate_vertical")
    assert first.matches("slide_to_stop", "x", "stop_distance")
    assert second.matches("slide_to_stop", "x", "invariance_rotate_vertical")


# --- planted engines: each relation catches what it claims --------------------------------------------

def _probe_scene(p: dict) -> Scene:
    """Two boxes stacked on the ground, or a box sliding off the axes (mu = 0.5), or gliding
    (frictionless: one normal row a step, solved exactly, so the plain engine keeps every
    invariance to rounding where an iterative friction solve stops at its tolerance); 60 steps."""
    if p["scene"] == "stack":
        boxes = (Body("low", cube(0.1), mass=1.0, position=(0.0, 0.0, 0.1)),
                 Body("high", cube(0.1), mass=1.0, position=(0.0, 0.0, 0.3)))
        return Scene((ground(),) + boxes, material=Material(mu_s=0.5))
    v = (2.0 * math.cos(math.radians(22.5)), 2.0 * math.sin(math.radians(22.5)), 0.0)
    return Scene((ground(), Body("box", cube(0.1), mass=1.0, position=(0.0, 0.0, 0.1), velocity=v)),
                 material=Material(mu_s=0.5 if p["scene"] == "slide" else 0.0))


PROBE = CaseFamily(name="invariance_probe", summary="a two-box stack, a slide and a glide off the axes", source="test",
                   grid=({"scene": "stack"}, {"scene": "slide"}, {"scene": "glide"}), scene=_probe_scene, duration=lambda p: 0.06,
                   observe=lambda traj, p: {"none": 0.0},
                   expect=lambda p, dt: [Check("none", "-", 0.0, 1.0, "abs", "no closed form: a relation's scene")])
# the probe scene each planted fault shows on: friction's direction needs sliding (the slide);
# a drift, a damping and a rounding of positions need motion that the plain engine keeps to
# rounding (the glide); the solver's order, the worlds, threads and a restore need contacts on
# contacts (the stack)
PROBE_SCENE = {"rotate_vertical": "slide", "rotate_tilted": "glide", "translate_10m": "glide",
               "translate_1000m": "glide", "translate_100000m": "glide", "mirror": "glide", "scale_4": "glide",
               "scale_quarter": "glide", "as_hull": "slide", "as_mesh": "slide"}


# the engine a representation relation's proof runs on: one that takes hulls and meshes and
# keeps both within its promise on the probe and on slide_to_stop (measured: Rapier, the hull
# bit-identical, the mesh ground within float32 round-off; Box2D keeps the polygon, Box3D the
# hull; PyBullet, MuJoCo, DART and Drake part from step 1 or 2)
SHAPES_ENGINE = "rapier"


def _engine_of(fault: str, relation: str = "") -> str:
    """The engine a fault is planted in for its proof: for a representation relation the
    engine above, else the first of faults.ENGINES (the reference first) whose adapter makes
    the change the fault needs (Adapter.plantable)."""
    if relation in ("as_hull", "as_mesh"):
        return SHAPES_ENGINE
    return next(e for e in faults.ENGINES if faults.plantable_in(e, faults.by_name(fault)) is None)


def _verdict(relation: str, fault: str) -> dict:
    engine = _engine_of(fault, relation)
    if not registry.available(engine):
        pytest.skip(f"{engine} is not installed")
    v = next(v for v in PROBE.variants if v.params["scene"] == PROBE_SCENE.get(relation, "stack"))
    results = {}
    for planted in ("none", fault):
        resolver = Resolver(Context(planted=faults.by_name(planted))).provide(family=PROBE)
        results[planted], = execute(Job(PROBE.name, v, engine, relation=relation), resolver).rows
    return results


@pytest.mark.parametrize("relation, fault", sorted(faults.PROVES.items()))
def test_a_planted_fault_is_flagged_by_its_relation(relation, fault):
    """The plain wrapper keeps the invariance; the engine with the fault planted breaks it,
    and the row says where the two runs part."""
    got = _verdict(relation, fault)
    assert got["none"]["status"] == "pass", got["none"]["reason"]
    assert got[fault]["status"] == "fail", got[fault]["reason"]
    assert invariance.parted_at(got[fault]["reason"]) >= 0


def test_every_relation_has_a_planted_fault_that_proves_it_or_says_why_not():
    assert set(faults.PROVES) | set(faults.UNPROVEN) == {r.name for r in R.RELATIONS}
    assert all(faults.by_name(f) for f in faults.PROVES.values())
    shapes = {"as_hull": "hull", "as_mesh": "mesh"}
    for relation in faults.UNPROVEN:  # a proof is owed as soon as an engine takes the shape
        for engine in registry.engine_names():
            if registry.available(engine):
                assert shapes[relation] not in Context().resolver().adapter(engine).capabilities.shapes, engine
    if registry.available(SHAPES_ENGINE):  # where the representation relations are proven
        assert set(shapes.values()) <= Context().resolver().adapter(SHAPES_ENGINE).capabilities.shapes


@pytest.mark.parametrize("relation, fault", [("rotate_vertical", "handed drift"), ("mirror", "damping"),
                                             ("mirror", "position round-off"), ("scale_4", "handed drift"),
                                             ("translate_100000m", "damping"), ("body_order", "cold restore")])
def test_a_fault_another_relation_proves_keeps_this_invariance(relation, fault):
    """The relations are specific: a drift about the vertical commutes with a turn about
    it and with a scale, a damping rate with a mirror and a move, float32 positions with a
    mirror (negation is exact), a restore that is never made with another body order; so a
    broken invariance points at its cause."""
    got = _verdict(relation, fault)
    assert got[fault]["status"] == "pass", got[fault]["reason"]


@pytest.mark.slow
@pytest.mark.parametrize("relation, fault", sorted(faults.PROVES.items()))
def test_a_planted_fault_is_flagged_on_its_relation_s_default_scenes(relation, fault):
    engine = _engine_of(fault, relation)
    statuses = {}
    for planted in ("none", fault):
        resolver = Context(planted=faults.by_name(planted)).resolver()
        statuses[planted] = [execute(j, resolver).rows[0]["status"]
                             for j in relation_jobs([relation], [engine], resolver, True)]
    assert set(statuses["none"]) == {"pass"} and "fail" in statuses[fault]


# --- the report and the scorecard --------------------------------------------------------------------

def _rows() -> pd.DataFrame:
    def row(engine, relation, status, measured, reason):
        return {"engine": engine, "case": "stack_forces", "variant": "n=4,light-heavy",
                "metric": R.METRIC_PREFIX + relation, "status": status, "measured": measured, "tolerance": 4.5e-11,
                "reason": reason, "known_deviation": "", "measures": "invariance",
                "over_tol": measured / 4.5e-11 if status != "unsupported" else math.nan}
    return pd.DataFrame([
        row("a", "rotate_vertical", "pass", 0.0, "the two runs are identical to the last bit over 400 steps"),
        row("a", "mirror", "pass", 1e-14, "largest difference 1e-14 of scale (step 3), within 4.5e-11 throughout"),
        row("b", "rotate_vertical", "fail", 0.005, "abs error 0.005 > tolerance 4.5e-11; the two runs part at step 1 "
            "of 400 (t = 0.001 s), first in box0 velocity[2]; largest difference 0.005 of scale (step 9)"),
        row("b", "mirror", "unsupported", math.nan, "mirror: no")])


def test_the_scorecard_grades_the_battery_in_its_invariance_column():
    card = scorecard.measure(_rows()).set_index(["engine", "effect"])
    assert card.loc[("a", scorecard.INVARIANCE), "grade"] == "A"
    assert card.loc[("b", scorecard.INVARIANCE), "grade"] == "F4"  # 0/1 within, the miss 1e8 tolerances
    assert card.loc[("a", "resting and stacking"), "judged"] == 0  # the battery's checks count under no effect


def test_the_report_section_shows_each_engine_against_each_relation_and_where_runs_part():
    rows = reading.measure(_rows())
    assert list(rows.parts_at) == [-1, -1, 1, -1]
    grid = reading.grid(rows).set_index("engine")
    assert grid.loc["a", "rotate_vertical"] == "=" and grid.loc["a", "mirror"].startswith("ok")
    assert grid.loc["b", "rotate_vertical"] == "**0.005 @1**" and grid.loc["b", "mirror"] == "-"
    text = reading.section(rows)
    assert "## Invariance" in text and "### Broken invariances" in text and "box0" not in text.split("###")[0]


def test_a_bad_relation_name_is_one_line_and_exit_2(tmp_path):
    proc = subprocess.run([sys.executable, "-m", "physval", "run", "--relations", "rotate_sideways",
                           "--out", str(tmp_path)], capture_output=True, text=True)
    assert proc.returncode == 2
    assert "--relations 'rotate_sideways': rotate_sideways is not a relation" in proc.stderr
    assert len(proc.stderr.strip().splitlines()) == 1


def test_a_finite_ground_stands_under_a_scene_far_from_the_origin():
    """Engines given a Plane as a finite box or segment centre it on the plane's point
    nearest the origin: exactly there for a scene near it (the same bits as before the
    battery), moved in whole cells under the bodies of a scene moved 1 km or 100 km, which
    would otherwise slide off the ground's edge (measured before: DART's and PyBullet's
    box ground 1 km away, Pymunk's segment 100 km away, the box fell through at step 1)."""
    scene, _ = variant_scene("slide_to_stop", "mu=0.5,v0=2,heading=22.5deg")
    plane = next(b for b in scene.bodies if b.static).shape
    assert np.array_equal(plane.centre_under(scene, 100.0), plane.offset * np.asarray(plane.normal))
    for relation in R.TRANSLATIONS[1:]:
        moved = relation.transform(scene)
        far = next(b for b in moved.bodies if b.static).shape
        centre = far.centre_under(moved, 100.0)
        assert abs(np.asarray(far.normal) @ centre - far.offset) < 1e-9 * far.offset  # on the plane
        body = np.asarray(moved.body("box").position)
        assert np.linalg.norm((body - centre) - ((body - centre) @ far.normal) * np.asarray(far.normal)) <= 100.0
