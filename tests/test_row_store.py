"""The row store shared by two commands at once (`physval real` runs with one --cache, each
engine's rows in one file): nothing that one of them stored is lost to the other's load,
which rewrites the file (physval/core/store.py)."""
from __future__ import annotations

import multiprocessing
import threading

from physval.core.store import RowStore

COLUMNS = ["engine", "case", "value"]


def _row(job: str) -> list[dict]:
    return [{"engine": "e", "case": "c", "value": job}]


def _same_key(row: dict) -> str:
    return "k"


def test_a_job_stored_while_another_run_loads_the_file_is_kept(tmp_path):
    """The race, made to happen: run B has read the store and is about to rewrite it when
    run A appends a job. Without a lock B's rewrite drops A's job from the file (A still has
    it in memory, but the next run, and a resumed A, would not). With the store held while
    it is read and rewritten, A's append waits for B's rewrite and lands after it."""
    path = tmp_path / "e.csv"
    first = RowStore(path, COLUMNS)
    first.append("j1", _row("j1"), "k")
    second = RowStore(path, COLUMNS)
    rewrite = second._write
    appending = threading.Thread(target=first.append, args=("j2", _row("j2"), "k"))

    def rewrite_after_an_append(rows):
        appending.start()
        appending.join(timeout=0.5)  # unlocked: the append is done by now; locked: it waits for this rewrite
        rewrite(rows)
    second._write = rewrite_after_an_append
    assert second.load(_same_key) == 1
    appending.join()
    assert _jobs(path) == ["j1", "j2"]


def _jobs(path) -> list[str]:
    store = RowStore(path, COLUMNS)
    store.load(_same_key, rewrite=False)
    return sorted(store.rows)


def _append_many(path: str, n: int) -> None:
    store = RowStore(path, COLUMNS)
    for i in range(n):
        store.append(f"j{i}", _row(f"j{i}"), "k")


def test_two_processes_appending_and_loading_lose_no_row(tmp_path):
    """Two processes, as two runs sharing a --cache: one stores 150 jobs while the other
    loads (and rewrites) the same file over and over. Every job is in the file at the end,
    with one header."""
    path = tmp_path / "e.csv"
    RowStore(path, COLUMNS).append("first", _row("first"), "k")
    writer = multiprocessing.get_context("spawn").Process(target=_append_many, args=(str(path), 150))
    writer.start()
    while writer.is_alive():
        RowStore(path, COLUMNS).load(_same_key)
    writer.join()
    assert writer.exitcode == 0
    assert _jobs(path) == sorted(["first"] + [f"j{i}" for i in range(150)])
    assert path.read_text().count("engine,case,value") == 1
