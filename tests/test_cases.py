"""Every case x variant x engine, and the conformance battery on every engine, judged by
their tolerances and the known deviations' recorded bands.

A check whose measurement lies in the band its known-deviation entry records makes the
test xfail with the entry's cause; a check that now passes although a band records it
fails the test (strict: the deviation is gone, `physval known ENGINE --write`); a
deviation that left its band is a `fail` and fails the test.
"""
from __future__ import annotations

import pytest

from physval.core import Context, execute


def _line(r) -> str:
    return (f"{r['metric']} = {r['measured']:.6g} {r['unit']}, but should be {r['expected']:.6g} "
            f"within {r['tolerance']:.3g} ({r['tolerance_kind']}; {r['tolerance_reason']}) -- {r['reason']}")


def judge_job(job):
    resolver = Context().resolver()
    try:
        resolver.adapter(job.engine)
    except Exception as exc:
        pytest.skip(str(exc))
    rows = execute(job, resolver).rows
    repro = f"reproduce: physval run --cases '{job.family}[{job.variant.id}]' --engines {job.engine}"
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


def test_case(job):
    judge_job(job)


def test_conformance(conformance_job):
    judge_job(conformance_job)
