"""The streaming row store: a CSV file that rows are appended to as jobs finish (one write
per job), so an interrupted command keeps every finished job, and the same command run
again recomputes none of them.

Each row carries its job's key, the number of rows the job wrote (so a job cut short by a
kill is recognised and run again) and a cache key: the fingerprint of the code that
produced it (every source file of physval, cases, adapters, reference_impl, the known
deviations, a user's case files and --known files, and a plug-in's or --adapter's own
source and deviation file) with the engine's version. A row whose cache key differs from
the current one is stale and run again.
"""
from __future__ import annotations

import csv
import hashlib
import io
import json
import math
import os
import sys
import time
from collections import defaultdict
from pathlib import Path

from physval.files import write_atomic

STORE_COLUMNS = ["job", "job_rows", "cache_key"]
# a field is as long as it is (an engine's knobs, a traceback): the csv module's 128 KB
# default limit would make a store this module wrote unreadable
csv.field_size_limit(2**31 - 1)
PACKAGES = ("physval", "cases", "adapters", "reference_impl")


KNOBS_COLUMN = "knobs"
SYNC_EVERY = 1.0  # s: RowStore.append makes the file durable (fsync) when the last did so this long ago


def knob_ref(text: str) -> str:
    """The name a knob record goes by in knobs.json: 12 hex digits of its SHA-256."""
    return hashlib.sha256(text.encode()).hexdigest()[:12]


def read_knobs(path: Path) -> dict[str, dict[str, str]]:
    """knobs.json as {engine: {ref: the record's JSON text, as the row carried it}}; {} if absent."""
    path = Path(path)
    if not path.is_file():
        return {}
    return {engine: {ref: json.dumps(knobs, sort_keys=True) for ref, knobs in records.items()}
            for engine, records in json.loads(path.read_text()).items()}


def expand_knobs(rows: list[dict], knobs: dict[str, dict[str, str]]) -> list[dict]:
    """Rows whose knobs column names a knobs.json record, with the record in its place
    (rows that carry their knobs inline, as a store written before knobs.json did, unchanged).
    A name knobs.json lacks stays as it is (KeyError-free: `unresolved` finds them)."""
    for r in rows:
        text = r.get(KNOBS_COLUMN) or ""
        if text and not text.startswith("{"):
            r[KNOBS_COLUMN] = knobs.get(r["engine"], {}).get(text, text)
    return rows


def unresolved(row: dict) -> bool:
    text = row.get(KNOBS_COLUMN) or ""
    return bool(text) and not text.startswith("{")


def read_results(path) -> list[dict]:
    """The rows of a results.csv (or of the result folder holding one) as dicts of strings,
    each row's knobs read from knobs.json beside it."""
    path = Path(path)
    if path.is_dir():
        path = path / "results.csv"
    with open(path, newline="") as fh:
        rows = list(csv.DictReader(fh))
    return expand_knobs(rows, read_knobs(path.with_name(KNOBS_FILE)))


KNOBS_FILE = "knobs.json"


class StoreError(ValueError):
    """The store's file is not one of ours (bad --out): the message names it."""


ROOT = Path(__file__).resolve().parents[2]


def fingerprint(extra_files=()) -> str:
    """SHA-256 (16 hex digits) of the project's source and deviation files and `extra_files`."""
    files = []
    for pkg in PACKAGES:
        files += sorted((ROOT / pkg).rglob("*.py")) + sorted((ROOT / pkg).rglob("xfails/*.txt"))
    return digest(files + [Path(f) for f in extra_files])


def digest(files) -> str:
    """SHA-256 (16 hex digits) of the files' names and contents (those that exist)."""
    h = hashlib.sha256()
    for f in files:
        if f.is_file():
            h.update(str(f.relative_to(ROOT) if f.is_relative_to(ROOT) else f).encode())
            h.update(f.read_bytes())
    return h.hexdigest()[:16]


class RowStore:
    """Rows of finished jobs in `path`, with `columns` (plus STORE_COLUMNS).

    `knobs_file`: where each engine's knob records are kept once (knobs.json). Rows stream
    to `path` with their knobs inline (one JSON object a row, ~1.3 KB: two thirds of a
    default run's 24 MB); the finished file (finalize, load) names each record instead (12
    hex digits) and knobs.json holds every distinct record once per engine, written before
    the CSV that names them. load() reads both forms back with the records inline; a job
    whose record knobs.json lacks is run again."""

    def __init__(self, path: Path, columns: list[str], knobs_file: Path | None = None):
        self.path = Path(path)
        self.columns = list(columns) + [c for c in STORE_COLUMNS if c not in columns]
        self.knobs_file = Path(knobs_file) if knobs_file is not None else None
        self.rows: dict[str, list[dict]] = {}   # job key -> rows, complete jobs only
        self._synced = -math.inf                  # when append last made the file durable
        self._check()

    def _check(self) -> None:
        if self.path.exists() and not self.path.is_file():
            raise StoreError(f"{self.path}: exists and is not a file")
        if self.path.exists() and self.path.stat().st_size:
            with open(self.path, newline="") as fh:
                header = next(csv.reader(fh), [])
            missing = [c for c in STORE_COLUMNS if c not in header]
            if missing:
                raise StoreError(f"{self.path}: not a file physval can resume (no {', '.join(missing)} column): "
                                 "choose another --out folder or remove the file")

    def load(self, cache_key_of, rewrite: bool = True) -> int:
        """Read finished jobs whose cache key is `cache_key_of(job rows' first row)`;
        return how many. The file is rewritten without cut-short or stale jobs (unless
        `rewrite` is False: a look that changes nothing, as `physval run --plan`'s)."""
        if not self.path.exists() or not self.path.stat().st_size:
            return 0
        text = self.path.read_text()
        if not text.endswith("\n"):  # a write cut short by a kill: drop the tail
            text = text[:text.rfind("\n") + 1]
        by_job = defaultdict(list)
        records = read_knobs(self.knobs_file) if self.knobs_file is not None else {}
        for r in expand_knobs(list(csv.DictReader(io.StringIO(text))), records):
            by_job[r["job"]].append(r)
        for key, rows in by_job.items():
            try:
                whole = len(rows) == int(rows[0]["job_rows"]) and not any(unresolved(r) for r in rows)
            except ValueError:
                whole = False
            if whole and rows[0]["cache_key"] == cache_key_of(rows[0]):
                self.rows[key] = rows
        if rewrite:
            self._write([r for rows in self.rows.values() for r in rows])
        return len(self.rows)

    def append(self, key: str, rows: list[dict], cache_key: str) -> None:
        """Add one finished job's rows: held in memory first, then one write, handed to the
        operating system at once (an interrupt in the write leaves them in memory, and
        finalize writes them; a killed physval loses nothing written), and made durable
        (fsync) by the first append SYNC_EVERY seconds or more after the last that was: a
        crash of the machine costs at most the jobs stored since (a cut-short tail is
        dropped by load(), and they run again). An fsync a job cost the main process 20 ms
        on a loaded disk."""
        stamped = [{**r, "job": key, "job_rows": len(rows), "cache_key": cache_key} for r in rows]
        self.rows[key] = stamped
        buf = io.StringIO()
        writer = csv.DictWriter(buf, self.columns, extrasaction="ignore")
        new = not self.path.exists() or not self.path.stat().st_size
        if new:
            writer.writeheader()
        writer.writerows(stamped)
        self.path.parent.mkdir(parents=True, exist_ok=True)
        with open(self.path, "a", newline="") as fh:
            fh.write(buf.getvalue())
            fh.flush()
            if time.monotonic() - self._synced >= SYNC_EVERY:
                os.fsync(fh.fileno())
                self._synced = time.monotonic()

    def finalize(self, keys: list[str]) -> list[dict]:
        """Rewrite the file with the rows of `keys` only, in that order; return them."""
        rows = [r for k in keys for r in self.rows.get(k, [])]
        self._write(rows)
        return rows

    def _write(self, rows: list[dict]) -> None:
        if self.knobs_file is not None and KNOBS_COLUMN in self.columns:
            rows = self._name_knobs(rows)
        buf = io.StringIO()
        writer = csv.DictWriter(buf, self.columns, extrasaction="ignore")
        writer.writeheader()
        writer.writerows(rows)
        write_atomic(self.path, buf.getvalue())

    def _name_knobs(self, rows: list[dict]) -> list[dict]:
        """Write knobs.json (every distinct record once per engine, one line each) and
        return the rows with each record's name in its place."""
        records: dict[str, dict[str, str]] = {}
        named = []
        for r in rows:
            text = r.get(KNOBS_COLUMN) or ""
            if text.startswith("{"):
                ref = knob_ref(text)
                records.setdefault(r["engine"], {})[ref] = text
                r = {**r, KNOBS_COLUMN: ref}
            named.append(r)
        lines = []
        for engine in sorted(records):
            inner = ",\n".join(f"  {json.dumps(ref)}: {text}" for ref, text in sorted(records[engine].items()))
            lines.append(f" {json.dumps(engine)}: {{\n{inner}\n }}")
        write_atomic(self.knobs_file, "{\n" + ",\n".join(lines) + "\n}\n")
        return named


def cache_keys(ctx, engines: list[str]) -> dict[str, str]:
    """Per engine: the fingerprint of the code that measures (with a user's case files and
    --known files, and the engine's own source and deviation file when they lie outside
    this project: a plug-in's, an --adapter's), and the engine's version."""
    key = cache_key_of(ctx)
    return {e: key(e) for e in engines}


def cache_key_of(ctx):
    """engine -> its cache key (as cache_keys), each found once, the project's fingerprint
    read once: for stores whose engines are known only as their jobs come (a reading's
    waves)."""
    resolver = ctx.resolver()
    fp = fingerprint([f for d in ctx.cases_dirs for f in sorted(Path(d).glob("*.py"))] + list(ctx.known_files))
    found: dict[str, str] = {}

    def key(e: str) -> str:
        if e not in found:
            try:
                adapter = resolver.adapter(e)
            except Exception:
                found[e] = f"{fp}:not installed"
                return found[e]
            own = [f for f in adapter_sources(adapter) + resolver.deviation_files(e)
                   if f.is_file() and not f.resolve().is_relative_to(ROOT) and str(f) not in ctx.known_files]
            found[e] = f"{fp}{'+' + digest(own) if own else ''}:{resolver.version(e)}"
        return found[e]
    return key


def adapter_sources(adapter) -> list[Path]:
    """The source files of the package (or the lone module) that defines the adapter's
    class: a plug-in's code can change without its version string, and its jobs must run
    again as they do when this project's code changes."""
    module = type(adapter).__module__
    top = sys.modules.get(module.split(".")[0])
    if getattr(top, "__path__", None) and getattr(top, "__file__", None):
        return sorted(Path(top.__file__).parent.rglob("*.py"))
    return [Path(getattr(sys.modules.get(module), "__file__", None) or "")]


# Engines' own caches kept in physval's cache folder: environment variable -> subfolder. The
# engine reads its variable itself (adapters never import the harness); a value the user set
# is left as it is.
ENGINE_CACHES = {"WARP_CACHE_PATH": "warp"}  # Warp's compiled kernels (MuJoCo Warp): ~1 min to build


def engine_caches() -> None:
    """Point every engine cache of ENGINE_CACHES into cache_dir(), unless already set."""
    for variable, folder in ENGINE_CACHES.items():
        os.environ.setdefault(variable, str(cache_dir() / folder))


def cache_dir() -> Path:
    """Where engine-wide readings are cached across runs: $PHYSVAL_CACHE_DIR, else
    $XDG_CACHE_HOME/physval, else ~/.cache/physval."""
    if os.environ.get("PHYSVAL_CACHE_DIR"):
        return Path(os.environ["PHYSVAL_CACHE_DIR"])
    base = os.environ.get("XDG_CACHE_HOME") or str(Path.home() / ".cache")
    return Path(base) / "physval"
