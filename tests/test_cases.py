"""Every case x variant x engine, judged by its tolerances.

A check listed in adapters/xfails/<engine>.txt that fails makes the test xfail with the
entry's reason; one that passes fails the test (strict), so a fixed engine shows.
"""
from __future__ import annotations

import functools

import pytest

from adapters import registry
from cases.registry import builtin_families
from physval.runner import run_job


@functools.cache
def _families():
    return builtin_families()


@functools.cache
def _adapter(name):
    return registry.get(name)


def _line(r, job) -> str:
    return (f"{r['metric']} = {r['measured']:.6g} {r['unit']}, but should be {r['expected']:.6g} "
            f"within {r['tolerance']:.3g} ({r['tolerance_kind']}; {r['tolerance_reason']}) -- {r['reason']}")


def test_case(job):
    try:
        adapter = _adapter(job.engine)
    except registry.EngineError as exc:
        pytest.skip(str(exc))
    rows = run_job(job, _families()[job.family], adapter)
    repro = f"reproduce: physval run --cases '{job.family}[{job.variant.id}]' --engines {job.engine}"
    statuses = {r["status"] for r in rows}
    if statuses == {"unsupported"}:
        pytest.skip(f"unsupported: {rows[0]['reason']}")
    broken = [r for r in rows if r["status"] in ("error", "unstable")]
    assert not broken, f"{broken[0]['status']}: {broken[0]['reason']}\n{repro}"
    failed = [r for r in rows if r["status"] == "fail"]
    assert not failed, "\n".join(_line(r, job) for r in failed) + "\n" + repro
    stale = [r for r in rows if r["status"] == "pass" and r["known_deviation"]]
    assert not stale, ("known deviation now passes (remove it from adapters/xfails/"
                       f"{job.engine}.txt): " + ", ".join(r["metric"] for r in stale))
    devs = [r for r in rows if r["status"] == "deviation"]
    if devs:
        pytest.xfail("; ".join(f"{r['metric']}: {r['reason']}" for r in devs))
