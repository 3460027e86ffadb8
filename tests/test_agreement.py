"""Cross-engine agreement (physval/readings/agreement.py): on every `cross_engine` family, each
engine's well-posed quantities must match the reference's to within each check's own
tolerance. A quantity the engine is known to get wrong (its check is a recorded
deviation, whose size the report shows) is left out of the comparison; the others must
agree. Pymunk takes part on the 2D variants."""
from __future__ import annotations

import functools
import math
from typing import NamedTuple

import pytest

from cases.registry import builtin_families
from physval.core import Context, Job
from physval.core.plan import leaves_out, priced
from physval.readings.agreement import REFERENCE, distance

from tests.conftest import selected_engines
from tests.helpers import shared_rows


@functools.cache
def _families():
    return {n: f for n, f in builtin_families().items() if f.cross_engine}


def _rows(family: str, variant_id: str, engine: str) -> list[dict]:
    """The job's rows as the session ran it (its battery test reads the same: shared_rows)."""
    fam = _families()[family]
    variant = next(v for v in fam.variants if v.id == variant_id)
    return shared_rows(Job(family, variant, engine))


class Pairing(NamedTuple):
    """A cross-engine family's variant on an engine (its `engine` is what `pytest --engine` selects by)."""
    family: str
    variant: str
    engine: str


def _on_demand(engine: str, name: str, fam, variant) -> bool:
    """A run a default run leaves out (physval.core.plan.leaves_out: families outside an
    engine's default_tags, runs it declares on demand, runs measured over the per-job
    limit): the pairing runs with `pytest -m slow`, as the run's checks do."""
    from adapters.registry import EngineError, get
    try:
        adapter = get(engine)
    except EngineError:
        return False
    return leaves_out(adapter, fam.tags, fam.scene(variant.params), **priced(_price(), Job(name, variant, engine))) \
        is not None


@functools.cache
def _price():
    from physval.readings import cost
    return cost.pricer(Context().resolver(), cost.model_for(None))


def pytest_generate_tests(metafunc):
    if "pairing" in metafunc.fixturenames:
        engines = [e for e in selected_engines(metafunc.config)[0] if not e.startswith(REFERENCE)]
        params = [pytest.param(Pairing(name, v.id, e), id=f"{name}[{v.id}]-{e}",
                               marks=[pytest.mark.slow] if _on_demand(e, name, fam, v) else [])
                  for name, fam in _families().items() for v in fam.variants for e in engines]
        metafunc.parametrize("pairing", params)


def test_engines_agree_with_the_reference(pairing):
    family, variant, engine = pairing
    try:
        Context().resolver().adapter(engine)
    except Exception as exc:
        pytest.skip(str(exc))
    mine = {r["metric"]: r for r in _rows(family, variant, engine)}
    if {r["status"] for r in mine.values()} == {"unsupported"}:
        pytest.skip(f"unsupported: {next(iter(mine.values()))['reason']}")
    reference = {r["metric"]: r for r in _rows(family, variant, REFERENCE)}
    assert all(r["status"] == "pass" for r in reference.values()), "the reference misses a closed form here"
    apart, known = [], []
    for metric, r in mine.items():
        if r["status"] == "deviation" or (r["status"] == "fail" and r["known_deviation"]):
            # a recorded deviation (a fail when it left its band: tests/test_cases.py says so)
            known.append(f"{metric}: {r['reason']}")
            continue
        ref = reference[metric]
        d = distance(r["tolerance_kind"], r["measured"], ref["measured"])
        if not d <= r["tolerance"] or math.isnan(d):
            apart.append(f"{metric}: {engine} {r['measured']:.6g} vs reference {ref['measured']:.6g} {r['unit']}, "
                         f"apart by {d:.3g} > tolerance {r['tolerance']:.3g} ({r['tolerance_reason']})")
    assert not apart, "\n".join(apart)
    if known and len(known) == len(mine):
        pytest.xfail("every quantity is a known deviation: " + "; ".join(known))
