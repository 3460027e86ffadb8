"""How `pytest -n 2` shares the suite between its workers (tests/conftest.py,
tests/helpers.py): a file whose tests share a costly set-up goes to one worker whole, the
battery's jobs are handed out costliest first, and a job two workers ask for at once runs
once."""
from __future__ import annotations

import threading
import time

from physval.core import Job
from tests import conftest, helpers


def test_a_file_with_a_shared_set_up_is_one_unit_and_any_other_test_its_own():
    assert conftest.one_worker_unit("tests/test_installed.py::test_a[physval list]") == "tests/test_installed.py"
    assert conftest.one_worker_unit("tests/test_faults.py::test_b[reference-gravity]") == "tests/test_faults.py"
    other = "tests/test_cases.py::test_case[central_impact[e=0.5,m=1:3]-mujoco]"
    assert conftest.one_worker_unit(other) == other


def test_the_session_hands_out_the_shared_set_ups_first_then_the_jobs_costliest_first(request):
    """This session's own order (whatever -k or --engine selected)."""
    items = request.session.items
    kinds = [0 if i.path.name in conftest.ONE_WORKER else 1 if conftest._job_of(i) is not None else 2 for i in items]
    assert kinds == sorted(kinds), "shared set-ups, then jobs, then the rest"
    cost = conftest._job_cost()
    costs = [cost(conftest._job_of(i)) for i, k in zip(items, kinds) if k == 1]
    assert costs == sorted(costs, reverse=True)
    files = [i.path.name for i, k in zip(items, kinds) if k == 0]
    assert files == sorted(files, key=list(conftest.ONE_WORKER).index), "in ONE_WORKER's order, each file whole"


def test_a_job_two_workers_ask_for_at_once_runs_once(tmp_path, monkeypatch):
    """Two askers (threads here: a lock file is held per open file, as by two processes)
    want the same job's rows while the first is still running it: it runs once, and both
    get its rows."""
    from cases.registry import builtin_families
    monkeypatch.setenv(helpers.SHARED_ROWS, str(tmp_path))
    monkeypatch.setattr(helpers, "_rows", {})
    runs = []

    class Ran:
        rows = [{"metric": "m", "status": "pass"}]

    def slow_execute(job, resolver):
        runs.append(job.key)
        time.sleep(0.3)  # the second asker arrives while this one runs
        return Ran()

    monkeypatch.setattr(helpers, "execute", slow_execute)
    job = Job("conformance", builtin_families()["conformance"].variants[0], "reference")
    got = []

    def ask():
        got.append(helpers.shared_rows(job))
        helpers._rows.clear()  # as another process would: nothing cached in memory

    askers = [threading.Thread(target=ask) for _ in range(2)]
    for t in askers:
        t.start()
    for t in askers:
        t.join()
    assert runs == [job.key] and got == [Ran.rows, Ran.rows]
