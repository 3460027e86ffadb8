"""The streaming row store: a CSV file that rows are appended to as jobs finish (one write
per job), so an interrupted command keeps every finished job, and the same command run
again recomputes none of them.

Each row carries its job's key, the number of rows the job wrote (so a job cut short by a
kill is recognised and run again) and a cache key: the fingerprint of the code that
produced it (every source file of physval, cases and adapters but other engines' code: the
engine's own adapter module, with the engine code it imports, reference_impl for the
reference's formulations (ENGINE_CODE); a plug-in's or --adapter's own source and the user
modules it imports) with the engine's version and the machine's id (machine_id: rows are
reused only on the machine that measured them), and for
a family from a user's --cases-dir the fingerprint of its own file and of the user modules
that file imports; then, after KNOWN_PART, the fingerprint of the engine's known-deviation
files (its own and the --known files). A row whose code part differs from the current one
is stale and run again: an edit of one user family file runs that family's jobs again, not
every job. A row whose known-deviation part alone differs holds a measurement that is still
current under verdicts that may not be: its job is judged again from the stored values
(`RowStore.rejudge`, physval.core.jobs.rejudge), in seconds, not stepped again, since a
known-deviation band changes verdicts, not trajectories.
"""
from __future__ import annotations

import ast
import contextlib
import csv
import fnmatch
import functools
import hashlib
import io
import json
import math
import os
import sys
import time
from collections import defaultdict
from dataclasses import dataclass, field
from pathlib import Path
from typing import Callable

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


@contextlib.contextmanager
def held(path: Path):
    """Hold the store file `path` (created empty if missing) against every other process and
    thread that holds it: an exclusive advisory lock (flock) on the file itself, so no lock
    file lies beside a report. A rewrite replaces the file (write_atomic), so a holder that
    waited on the file it replaced takes the lock again on the file now at `path`. Two
    commands sharing a store (`physval real` runs with one --cache) then neither rewrite
    away a job the other appended between their read and their write, nor write two
    headers. Where fcntl is missing, no lock."""
    try:
        import fcntl
    except ImportError:
        yield
        return
    path.parent.mkdir(parents=True, exist_ok=True)
    while True:
        fd = os.open(path, os.O_RDWR | os.O_CREAT, 0o644)
        try:
            fcntl.flock(fd, fcntl.LOCK_EX)
            if os.fstat(fd).st_ino == os.stat(path).st_ino:
                break
        except FileNotFoundError:  # replaced and not yet there: take it again
            pass
        except BaseException:
            os.close(fd)
            raise
        os.close(fd)
    try:
        yield
    finally:
        os.close(fd)  # closing the last descriptor of the lock releases it


def whole_rows(text: str) -> str:
    """A store's text without a last row cut short (a write stopped by a kill, a full disk):
    every whole row ends with a newline."""
    return text if text.endswith("\n") else text[:text.rfind("\n") + 1]


def read_results(path) -> list[dict]:
    """The rows of a results.csv (or of the result folder holding one) as dicts of strings,
    each row's knobs read from knobs.json beside it; a last row cut short is no row."""
    path = Path(path)
    if path.is_dir():
        path = path / "results.csv"
    with open(path, newline="") as fh:
        rows = list(csv.DictReader(io.StringIO(whole_rows(fh.read()))))
    return expand_knobs(rows, read_knobs(path.with_name(KNOBS_FILE)))


KNOBS_FILE = "knobs.json"


class StoreError(ValueError):
    """The store's file is not one of ours (bad --out): the message names it."""


ROOT = Path(__file__).resolve().parents[2]


# Engine code: an engine's adapter module, and the reference's formulations (one unit: its
# world imports a formulation by name, which no import statement shows). An engine's cache key
# covers the project's other source files and only the engine code its adapter imports
# (engine_code): an edit of one engine's adapter runs that engine's jobs again (and those of
# the engines whose adapters import it: MuJoCo's is MuJoCo Warp's, MJX's, Genesis' and
# Newton's), an edit of reference_impl the reference's formulations', not every job. No other
# module imports engine code, but for these, whose use of it makes no job's rows
# (tests/test_execution.py holds the project to that):
ENGINE_CODE = ("adapters/*_engine.py", "reference_impl/*.py")
ENGINE_PACKAGES = ("reference_impl",)
IMPORTS_ENGINE_CODE = {
    "physval/core/preload.py": "loads the reference's compiled step into a worker before its jobs (speed)",
    "physval/readings/bench.py": "times the reference's solvers and narrow phase (`physval bench`)",
    "physval/readings/oracle.py": "solves the reference's contact problems with Pinocchio's (`physval bench oracle`)",
}


def _is_engine_code(f: Path) -> bool:
    f = f.resolve()
    return f.is_relative_to(ROOT) and any(fnmatch.fnmatchcase(str(f.relative_to(ROOT)), g) for g in ENGINE_CODE)


def project_files() -> list[Path]:
    """Every source file of the project's packages."""
    return [f for pkg in PACKAGES for f in sorted((ROOT / pkg).rglob("*.py"))]


def fingerprint(extra_files=()) -> str:
    """SHA-256 (16 hex digits) of the project's source files but engine code (ENGINE_CODE),
    and `extra_files` (the known-deviation files are not source: they change verdicts, not
    measurements, and have their own part of the cache key, KNOWN_PART)."""
    return digest([f for f in project_files() if not _is_engine_code(f)] + [Path(f) for f in extra_files])


def engine_code(adapter) -> list[Path]:
    """The engine code (ENGINE_CODE) that `adapter` runs: the modules of its class and of the
    classes it derives from, of the adapters it wraps (`inner`: a planted fault's), and,
    transitively, the engine code, the user modules and an outside adapter's own package
    import (a plug-in's subclass of a built-in adapter takes that adapter's module, as does
    one that imports a helper of it)."""
    starts, a = [], adapter
    while a is not None:
        starts += [Path(f) for c in type(a).__mro__ if (f := getattr(sys.modules.get(c.__module__), "__file__", None))]
        starts += [f for f in adapter_sources(a) if f.is_file() and not _in_project(f)]
        a = getattr(a, "inner", None)
    first = {f.resolve() for f in starts}
    seen, todo, out = set(), sorted(first), []
    while todo:
        f = todo.pop()
        if f in seen or not f.is_file():
            continue
        seen.add(f)
        if _is_engine_code(f):
            out.append(f)
            package = f.parent.relative_to(ROOT)
            todo += sorted(f.parent.glob("*.py")) if str(package) in ENGINE_PACKAGES else []
        if _is_engine_code(f) or f in first and not _in_project(f) or _user_module(f):
            todo += [m.resolve() for m in _imports(f, f.stat().st_mtime_ns) if m.suffix == ".py"]
    return sorted(out)


KNOWN_PART = "|known="  # a cache key: the code's part, then this, then the known deviations' part


def code_part(cache_key: str) -> str:
    """The part of a cache key that says what was measured (KNOWN_PART's left)."""
    return cache_key.split(KNOWN_PART, 1)[0]


def digest(files) -> str:
    """SHA-256 (16 hex digits) of the files' names and contents (those that exist; one that
    cannot be read counts by its name and the reason)."""
    h = hashlib.sha256()
    for f in files:
        if f.is_file():
            h.update(str(f.relative_to(ROOT) if f.is_relative_to(ROOT) else f).encode())
            try:
                h.update(f.read_bytes())
            except OSError as exc:
                h.update(f"unreadable: {exc.strerror}".encode())
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
        # job key -> rows whose measurement is current and whose verdicts may not be (only
        # the known-deviation part of their cache key differs): `rejudge` makes them rows
        self.verdicts_stale: dict[str, list[dict]] = {}
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
        return how many. Jobs whose key differs in its known-deviation part alone
        (KNOWN_PART) wait in `verdicts_stale` for `rejudge`. The file is rewritten without
        cut-short or stale jobs, nor those waiting (rejudge appends them judged anew),
        unless `rewrite` is False: a look that changes nothing, as `physval run --plan`'s."""
        if not self.path.exists() or not self.path.stat().st_size:
            return 0
        with held(self.path):  # another command's appends wait until the file is read and rewritten
            return self._load(cache_key_of, rewrite)

    def _load(self, cache_key_of, rewrite: bool) -> int:
        text = whole_rows(self.path.read_text())  # a write cut short by a kill: its tail dropped
        by_job = defaultdict(list)
        records = read_knobs(self.knobs_file) if self.knobs_file is not None else {}
        for r in expand_knobs(list(csv.DictReader(io.StringIO(text))), records):
            by_job[r["job"]].append(r)
        for key, rows in by_job.items():
            try:
                whole = len(rows) == int(rows[0]["job_rows"]) and not any(unresolved(r) for r in rows)
            except ValueError:
                whole = False
            if not whole:
                continue
            stored, current = rows[0]["cache_key"], cache_key_of(rows[0])
            if stored == current:
                self.rows[key] = rows
            elif code_part(stored) == code_part(current):
                self.verdicts_stale[key] = rows
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
        writer.writerows(stamped)
        with held(self.path), open(self.path, "a", newline="") as fh:  # (held: see load)
            if not fh.tell():
                header = io.StringIO()
                csv.DictWriter(header, self.columns).writeheader()
                fh.write(header.getvalue())
            fh.write(buf.getvalue())
            fh.flush()
            if time.monotonic() - self._synced >= SYNC_EVERY:
                os.fsync(fh.fileno())
                self._synced = time.monotonic()

    def rejudge(self, jobs, judge_again, cache_key_of, write: bool = True) -> int:
        """The jobs of `jobs` waiting in `verdicts_stale`, judged again: `judge_again(job,
        rows)` gives the rows with their verdicts of now, or None where the rows cannot
        say (the job then runs again). Judged rows join `rows` stamped with
        `cache_key_of(job)`, and are appended to the file (unless `write` is False: a look
        that changes nothing). Returns how many jobs were judged again."""
        done = 0
        for job in jobs:
            stale = self.verdicts_stale.pop(job.key, None)
            if stale is None:
                continue
            rows = judge_again(job, stale)
            if rows is None:
                continue
            if write:
                self.append(job.key, rows, cache_key_of(job))
            else:
                self.rows[job.key] = rows
            done += 1
        return done

    def finalize(self, keys: list[str]) -> list[dict]:
        """Rewrite the file with the rows of `keys` only, in that order; return them."""
        rows = [r for k in keys for r in self.rows.get(k, [])]
        with held(self.path):
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


@dataclass(frozen=True)
class CacheKeys:
    """The cache keys of a run: per engine, and per user family (cache_keys). With `find`,
    an engine not yet in `engines` gets its key found when first asked (a reading's waves,
    whose engines are known only as their jobs come)."""
    engines: dict[str, str]
    families: dict[str, str] = field(default_factory=dict)  # a user's family -> its files' fingerprint
    find: Callable[[str], str] | None = None                 # engine -> its key (engine_key_of)

    def of(self, engine: str, family: str) -> str:
        """The cache key of a job of `family` on `engine` ("" for an engine not in the run)."""
        if engine not in self.engines:
            if self.find is None:
                return ""
            self.engines[engine] = self.find(engine)
        own = self.families.get(family)
        if not own:
            return self.engines[engine]
        code, known = self.engines[engine].split(KNOWN_PART, 1)
        return f"{code}+{own}{KNOWN_PART}{known}"

    def of_row(self, row: dict) -> str:
        return self.of(row["engine"], row["case"])

    def of_job(self, job) -> str:
        return self.of(job.engine, job.family)


def cache_keys(ctx, engines: list[str] | None = None) -> CacheKeys:
    """Per engine: the fingerprint of the code that measures (with the --known files, and
    the engine's own source, the user modules it imports and its deviation file when they
    lie outside this project: a plug-in's, an --adapter's), and the engine's version. Per
    family of a user's --cases-dir: the fingerprint of its file and the user modules it
    imports. Without `engines`, each engine's key is found when first asked, the project's
    fingerprint read once."""
    find = engine_key_of(ctx)
    if engines is None:
        return CacheKeys({}, family_keys(ctx), find)
    return CacheKeys({e: find(e) for e in engines}, family_keys(ctx))


def engine_key_of(ctx) -> Callable[[str], str]:
    """engine -> its part of the cache key (as cache_keys), the project's fingerprint read
    once: the code's part, then KNOWN_PART and the fingerprint of its deviation files."""
    resolver = ctx.resolver()
    fp = fingerprint()

    def find(e: str) -> str:
        known = KNOWN_PART + digest(resolver.deviation_files(e))
        try:
            adapter = resolver.adapter(e)
        except Exception:
            return f"{fp}:not installed@{machine_id()}{known}"
        own = [f for f in user_sources(adapter_sources(adapter)) if f.is_file() and not _in_project(f)]
        return (f"{fp}.{digest(engine_code(adapter))}{'+' + digest(own) if own else ''}:{resolver.version(e)}"
                f"@{machine_id()}{known}")
    return find


def family_keys(ctx) -> dict[str, str]:
    """Each loaded family of the run's --cases-dir folders: the fingerprint of its file and
    of the user modules that file imports (user_sources)."""
    from cases.family import CaseFamily
    from cases.registry import case_files
    files = {str(f.resolve()): f for d in ctx.cases_dirs for f in case_files(d)}
    out = {}
    for module in list(sys.modules.values()):  # the family files this process imported
        name = getattr(module, "__file__", None)
        family = getattr(module, "FAMILY", None)
        if name and isinstance(family, CaseFamily) and str(Path(name).resolve()) in files:
            out[family.name] = digest(user_sources([files[str(Path(name).resolve())]]))
    return out


def adapter_sources(adapter) -> list[Path]:
    """The source files of the package (or the lone module) that defines the adapter's
    class: a plug-in's code can change without its version string, and its jobs must run
    again as they do when this project's code changes."""
    module = type(adapter).__module__
    top = sys.modules.get(module.split(".")[0])
    if getattr(top, "__path__", None) and getattr(top, "__file__", None):
        return sorted(Path(top.__file__).parent.rglob("*.py"))
    return [Path(getattr(sys.modules.get(module), "__file__", None) or "")]


def _in_project(f: Path) -> bool:
    """A file of this project's packages (the fingerprint covers it)."""
    f = f.resolve()
    return any(f.is_relative_to(ROOT / pkg) for pkg in PACKAGES)


@functools.cache
def _installed_folders() -> tuple[Path, ...]:
    """Where installed code lives: the standard library and every site-packages folder,
    this interpreter's and those on the import path (a `physval versions` environment sees
    the machine's site-packages through a .pth file, physval.core.envs: read as a user's
    folder, its 2900 modules were parsed for imports in every run there, 38-80 s a run)."""
    import site
    import sysconfig
    found = [sysconfig.get_path(k) for k in ("stdlib", "platstdlib", "purelib", "platlib")]
    found += site.getsitepackages() + ([site.getusersitepackages()] if site.ENABLE_USER_SITE else [])
    found += [p for p in sys.path if p and Path(p).name in ("site-packages", "dist-packages")]
    return tuple(dict.fromkeys(Path(p).resolve() for p in found if p))


def _user_module(f: Path) -> bool:
    """A module a user wrote: neither this project's nor installed (a helper beside an
    --adapter or a family file, a package on PYTHONPATH, an editable install's source)."""
    f = f.resolve()
    return not _in_project(f) and not any(f.is_relative_to(p) for p in _installed_folders())


def _module_file(name: str) -> Path | None:
    """The file of module `name` as this process would import it, found without importing
    it: from sys.modules if imported, else on sys.path (a package's __init__.py, a module's
    .py); None for a built-in or one not found."""
    module = sys.modules.get(name)
    if module is not None:
        found = getattr(module, "__file__", None)
        return Path(found) if found else None
    top, *rest = name.split(".")
    if top in PACKAGES:  # this project's, wherever the path finds it (an editable install's finder)
        return _submodule(ROOT / top / "__init__.py", rest)
    for folder in sys.path:
        base = Path(folder or ".") / top
        for candidate in (base / "__init__.py", base.with_suffix(".py")):
            if candidate.is_file():
                return _submodule(candidate, rest)
    return None


def _submodule(file: Path, parts: list[str]) -> Path | None:
    """The file of `parts` below the package (or module) `file` (None if none)."""
    if not parts:
        return file
    if file.name != "__init__.py":
        return None
    base = file.parent / parts[0]
    for candidate in (base / "__init__.py", base.with_suffix(".py")):
        if candidate.is_file():
            return _submodule(candidate, parts[1:])
    return None


@functools.lru_cache(maxsize=4096)
def _imports(file: Path, mtime_ns: int) -> tuple[Path, ...]:
    """The files of the modules `file`'s import statements name (relative ones resolved
    from its folder), wherever they sit in it (in a function too)."""
    try:
        tree = ast.parse(file.read_bytes(), str(file))
    except (OSError, SyntaxError, ValueError):
        return ()
    found = []
    for node in ast.walk(tree):
        if isinstance(node, ast.Import):
            names = [a.name for a in node.names]
            found += [_module_file(n) for n in names]
        elif isinstance(node, ast.ImportFrom):
            if node.level:  # relative: from the file's folder, up level - 1 folders
                base = file.parent
                for _ in range(node.level - 1):
                    base = base.parent
                init = base / "__init__.py"
                parts = (node.module or "").split(".") if node.module else []
                package = _submodule(init, parts) if init.is_file() else None
                if package is None and parts:  # a lone module beside the file
                    candidate = base.joinpath(*parts).with_suffix(".py")
                    package = candidate if candidate.is_file() else None
                found.append(package)
                found += [_submodule(package, [a.name]) if package else None for a in node.names]
            else:
                found.append(_module_file(node.module))
                found += [_module_file(f"{node.module}.{a.name}") for a in node.names]
    return tuple(dict.fromkeys(f for f in found if f is not None))


def user_sources(files) -> list[Path]:
    """`files` and, transitively, the user modules they import (_user_module): the code of
    a user's adapter or family file that can change without any version string changing."""
    seen, todo, out = set(), [Path(f) for f in files], []
    while todo:
        f = todo.pop(0)
        key = f.resolve() if f.exists() else f
        if key in seen:
            continue
        seen.add(key)
        out.append(f)
        if f.suffix == ".py" and f.is_file() and not _in_project(f):
            todo += [m for m in _imports(key, f.stat().st_mtime_ns) if m.suffix == ".py" and _user_module(m)]
    return out


# Engines' own caches kept in physval's cache folder: environment variable -> subfolder. The
# engine reads its variable itself (adapters never import the harness); a value the user set
# is left as it is.
# Warp's compiled kernels (MuJoCo Warp): ~1 min to build; JAX's compiled programs (MJX): seconds a model shape
ENGINE_CACHES = {"WARP_CACHE_PATH": "warp", "JAX_COMPILATION_CACHE_DIR": "jax"}


def engine_caches() -> None:
    """Point every engine cache of ENGINE_CACHES into cache_dir(), unless already set."""
    for variable, folder in ENGINE_CACHES.items():
        os.environ.setdefault(variable, str(cache_dir() / folder))


@functools.cache
def machine_id() -> str:
    """This machine's id, a random one kept in physval's cache folder (cache_dir): part of
    every cache key, so that a job's rows are reused only where they were measured. Rows
    hold measurements of the machine (its times, and results that can hang on its
    floating-point hardware and thread counts), so the rows of a result folder that came
    from elsewhere (the project's committed reports/, a copied folder) are run again, not
    taken for this machine's. Made once, atomically (the first process to link its file
    wins); where the cache folder cannot be written, the host's name."""
    import uuid
    path = cache_dir() / "machine"
    try:
        return path.read_text().strip()
    except OSError:
        pass
    try:
        path.parent.mkdir(parents=True, exist_ok=True)
        tmp = path.with_name(f".machine.{os.getpid()}")
        tmp.write_text(uuid.uuid4().hex[:16] + "\n")
        try:
            os.link(tmp, path)
        except FileExistsError:
            pass
        finally:
            tmp.unlink()
        return path.read_text().strip()
    except OSError:
        import platform
        return platform.node() or "unknown"


def cache_dir() -> Path:
    """Where engine-wide readings are cached across runs: $PHYSVAL_CACHE_DIR, else
    $XDG_CACHE_HOME/physval, else ~/.cache/physval."""
    if os.environ.get("PHYSVAL_CACHE_DIR"):
        return Path(os.environ["PHYSVAL_CACHE_DIR"])
    base = os.environ.get("XDG_CACHE_HOME") or str(Path.home() / ".cache")
    return Path(base) / "physval"
