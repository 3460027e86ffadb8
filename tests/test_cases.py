"""Every case x variant x engine, and the conformance battery on every engine, judged by
their tolerances.

A check listed in adapters/xfails/<engine>.txt that fails makes the test xfail with the
entry's reason; one that passes fails the test (strict), so a fixed engine shows.
"""
from __future__ import annotations

import functools

import pytest

from adapters import registry
from physval.runner import families, run_job


@functools.cache
def _families():
    return families()


@functools.cache
def _adapter(name):
    return registry.get(name)


def _line(r) -> str:
    return (f"{r['metric']} = {r['measured']:.6g} {r['unit']}, but should be {r['expected']:.6g} "
            f"within {r['tolerance']:.3g} ({r['tolerance_kind']}; {r['tolerance_reason']}) -- {r['reason']}")


def judge_job(job):
    try:
        adapter = _adapter(job.engine)
    except registry.EngineError as exc:
        pytest.skip(str(exc))
    rows = run_job(job, _families()[job.family], adapter)
    repro = f"reproduce: physval run --cases '{job.family}[{job.variant.id}]' --engines {job.engine}"
    if {r["status"] for r in rows} == {"unsupported"}:
        pytest.skip(f"unsupported: {rows[0]['reason']}")
    broken = [r for r in rows if r["status"] in ("error", "unstable")]
    assert not broken, f"{broken[0]['status']}: {broken[0]['reason']}\n{repro}"
    failed = [r for r in rows if r["status"] == "fail"]
    assert not failed, "\n".join(_line(r) for r in failed) + "\n" + repro
    by_entry = {}
    for r in rows:
        if r["known_deviation"]:
            by_entry.setdefault(r["known_deviation"], []).append(r)
    stale = [e for e, rs in by_entry.items() if all(r["status"] == "pass" for r in rs)]
    assert not stale, ("known deviation now passes everywhere in this run (strict: remove or narrow it in "
                       f"adapters/xfails/{job.engine}.txt): " + "; ".join(stale))
    devs = [r for r in rows if r["status"] == "deviation"]
    if devs:
        pytest.xfail("; ".join(f"{r['metric']}: {r['reason']}" for r in devs))


def test_case(job):
    judge_job(job)


def test_conformance(conformance_job):
    judge_job(conformance_job)
