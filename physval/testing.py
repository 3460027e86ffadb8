"""physval's case battery as pytest tests, from the installed package: an engine's own
repository runs it without a physval checkout (in the spirit of scikit-learn's
`parametrize_with_checks`).

    # tests/test_battery.py in the engine's repository
    import pytest
    from physval.testing import check, engine_checks

    @pytest.mark.parametrize("job", engine_checks(["my-engine"]))
    def test_battery(job):
        check(job)

`engine_checks` gives one pytest parameter per job: the conformance battery, every case
variant the engine can represent and the invariance battery (each relation of
cases.relations on its default scenes), with ids such as `central_impact[e=0.5,m=1:3]-my-engine`
and `stack_forces[n=4,light-heavy]-my-engine-body_order` (so `pytest -k` selects them); runs the engine declares too slow for a default run are
marked `slow`. `check(job)` runs the job in the test's process and judges it as `physval
run` does, with the engine's known deviations (its `xfails/<name>.txt`): a check within
its tolerance passes, one inside its recorded band is an expected failure (xfail, with the
cause), anything else fails with the measured value, the closed form, the tolerance and
its reason, and the `physval run` that reproduces it. A scene the engine cannot represent,
or an engine that is not installed, is a skip that says why.
"""
from __future__ import annotations

import pytest

from physval.core import Context, Job, execute
from cases.relations import RELATIONS
from physval.core.plan import plan, relation_jobs


def engine_checks(engines: list[str] | None = None, conformance: bool | None = None, named: bool = True,
                  ctx: Context = Context()) -> list:
    """pytest parameters (a Job each) of the battery on `engines` (names or globs, as
    `--engines` takes them; default every registered engine). `conformance`: True for the
    conformance battery only, False for the case families only, None for both. `named`:
    whether the engines were named (a named engine runs every family it can represent;
    otherwise the slow reference formulations run their default families only, as in a
    default `physval run`)."""
    from adapters.registry import engine_names
    from physval.core.selection import select_engines
    known = engine_names(ctx.adapters)
    chosen = select_engines(engines, known, known, "engine_checks")
    resolver = ctx.resolver()
    families = {n: list(f.variants) for n, f in resolver.families.items()
                if conformance is None or ("conformance" in f.tags) == conformance}
    from physval.readings import cost
    price = cost.pricer(resolver, cost.model_for(None))  # the shipped table: a job over the limit is slow
    jobs, later = plan(families, chosen, resolver, named, on_demand=False, price=price)
    if not conformance:
        jobs += relation_jobs([r.name for r in RELATIONS], chosen, resolver, named, price=price)
    return ([pytest.param(j, id=j.test_id) for j in jobs]
            + [pytest.param(j, id=j.test_id, marks=[pytest.mark.slow]) for j, _ in later])


def _line(r) -> str:
    return (f"{r['metric']} = {r['measured']:.6g} {r['unit']}, but should be {r['expected']:.6g} "
            f"within {r['tolerance']:.3g} ({r['tolerance_kind']}; {r['tolerance_reason']}) -- {r['reason']}")


def check(job: Job, ctx: Context = Context(), rows: list[dict] | None = None) -> None:
    """Run `job` here and judge it: pass, xfail (a recorded known deviation within its
    band), skip (not installed, or a scene the engine cannot represent), or fail with a
    readable message. A recorded deviation that now passes fails (strict: its band is out
    of date). `rows`: the job's rows, run already (a suite whose tests share one run's
    rows: physval's own runs each job once for its battery and its agreement tests)."""
    resolver = ctx.resolver()
    try:
        resolver.adapter(job.engine)
    except Exception as exc:
        pytest.skip(str(exc))
    if rows is None:
        rows = execute(job, resolver).rows
    repro = (f"reproduce: physval run --cases '{job.family}[{job.variant.id}]' --engines {job.engine}"
             + (f" --relations {job.relation}" if job.relation else ""))
    if {r["status"] for r in rows} == {"unsupported"}:
        pytest.skip(f"unsupported: {rows[0]['reason']}")
    broken = [r for r in rows if r["status"] in ("error", "unstable")]
    assert not broken, f"{broken[0]['status']}: {broken[0]['reason']}\n{repro}"
    failed = [r for r in rows if r["status"] == "fail"]
    assert not failed, "\n".join(_line(r) for r in failed) + "\n" + repro
    passing_but_banded = [r for r in rows if r["status"] == "pass" and r["band"]]
    assert not passing_but_banded, (
        "a recorded known deviation now passes (strict: `physval known " + job.engine + " --write` updates the "
        "bands, or remove the entry): " + "; ".join(f"{r['metric']} (band {r['band']})" for r in passing_but_banded))
    devs = [r for r in rows if r["status"] == "deviation"]
    if devs:
        pytest.xfail("; ".join(f"{r['metric']}: {r['reason']}" for r in devs))
