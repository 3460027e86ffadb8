"""Every case x variant x engine, and the conformance battery on every engine, judged by
their tolerances and the known deviations' recorded bands (physval.testing.check; the
jobs come from tests/conftest.py through physval.testing.engine_checks). Each job runs
once in the session: the agreement tests read the same rows (tests.helpers.shared_rows).

A check whose measurement lies in the band its known-deviation entry records makes the
test xfail with the entry's cause; a check that now passes although a band records it
fails the test (strict: the deviation is gone, `physval known ENGINE --write`); a
deviation that left its band is a `fail` and fails the test.
"""
from __future__ import annotations

from physval.testing import check

from tests.helpers import shared_rows, skip_if_not_installed


def test_case(job):
    skip_if_not_installed(job.engine)
    check(job, rows=shared_rows(job))


def test_conformance(conformance_job):
    skip_if_not_installed(conformance_job.engine)
    check(conformance_job, rows=shared_rows(conformance_job))
