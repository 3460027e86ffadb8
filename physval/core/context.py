"""What a process needs to turn names into things: the user's case folders, ad-hoc
adapters and known-deviation files of a run. A `Context` is small and picklable, so every
worker (a local process under any start method, or a Dask worker) rebuilds the same
families, adapters and deviations from it; `Resolver` does that once per process.
"""
from __future__ import annotations

import functools
from dataclasses import dataclass, replace
from pathlib import Path

from adapters import registry
from adapters.base import Adapter
from adapters.planting import Fault, Planted
from cases.family import CaseFamily
from physval.core import deviations
from physval.core.store import engine_caches


@dataclass(frozen=True)
class Context:
    cases_dirs: tuple[str, ...] = ()   # --cases-dir folders
    adapters: tuple[str, ...] = ()     # --adapter module:Class specs
    known_files: tuple[str, ...] = ()  # --known files (deviations a user expects)
    broken: tuple = ()                 # cases.registry.Problem of each user file the dry run refused
    planted: Fault | None = None       # a fault planted in every engine (adapters.planting: bench faults, catches)

    def resolver(self) -> "Resolver":
        return _resolver(self)

    @property
    def options(self) -> tuple[str, ...]:
        """The command-line options that extend the library: --cases-dir and --adapter."""
        return (*(x for d in self.cases_dirs for x in ("--cases-dir", d)),
                *(x for a in self.adapters for x in ("--adapter", a)))


class Resolver:
    """Families, adapters and known deviations of one Context, each made once per process."""

    def __init__(self, ctx: Context):
        self.ctx = ctx
        self._families: dict[str, CaseFamily] | None = None
        self.broken = {p.file: p for p in ctx.broken}  # user files that cannot be used -> cases.registry.Problem
        self._adapters: dict[str, Adapter | registry.EngineError] = {}
        self._known: dict[str, list[deviations.Deviation]] = {}
        self._versions: dict[str, str] = {}

    @property
    def families(self) -> dict[str, CaseFamily]:
        """The built-in families and the user's usable ones (a user file that is not is
        left out, in `broken`)."""
        if self._families is None:
            from cases.registry import all_families
            self._families = all_families(self.ctx.cases_dirs, self.broken)
        return self._families

    def family(self, name: str) -> CaseFamily:
        return self.families[name]

    def provide(self, engine: str | None = None, adapter: Adapter | None = None,
                known: list[deviations.Deviation] | None = None, family: CaseFamily | None = None) -> "Resolver":
        """Use these objects in this process instead of resolving names (scripts, tests)."""
        if family is not None:
            self.families[family.name] = family
        if adapter is not None:
            self._adapters[engine] = adapter
            self._versions.pop(engine, None)
        if known is not None:
            self._known[engine] = list(known)
        return self

    def adapter(self, name: str) -> Adapter:
        """The engine's adapter; raises registry.EngineError (remembered) if unavailable."""
        if name not in self._adapters:
            engine_caches()  # before any engine starts, in every process that runs jobs
            try:
                self._adapters[name] = self._planted(registry.get(name, self.ctx.adapters))
            except registry.EngineError as exc:
                self._adapters[name] = exc
        found = self._adapters[name]
        if isinstance(found, Exception):
            raise found
        return found

    def version(self, name: str) -> str:
        """The engine's version string, asked once per process ("unknown" if the adapter
        cannot say): most adapters read it from the installed distribution's metadata
        (importlib.metadata), 6 ms of CPU and up to 60 ms of file reads on a loaded machine,
        which every job paid before."""
        if name not in self._versions:
            try:
                self._versions[name] = self.adapter(name).version()
            except Exception:
                self._versions[name] = "unknown"
        return self._versions[name]

    def _planted(self, adapter: Adapter) -> Adapter:
        """The adapter with the Context's planted fault, under the engine's own name (so its
        bands judge it); adapters.planting.NotPlantable (an EngineError) where the fault
        needs an engine-internal change the adapter does not make."""
        if self.ctx.planted is None:
            return adapter
        return Planted(adapter, self.ctx.planted)

    def known(self, engine: str) -> list[deviations.Deviation]:
        """The entries for this engine of its own deviation file, then of the user's --known files."""
        if engine not in self._known:
            own, recorded = None, engine
            try:
                adapter = self.adapter(engine)
                own, recorded = adapter.deviations_file(), adapter.bands_of or engine
            except registry.EngineError:
                pass
            # an adapter judged by another engine's bands (a planted engine named anew): that
            # engine's entries, their bands as this engine's
            mine = [d.recorded_as(recorded, engine) for d in deviations.load([own]) if d.applies_to(recorded)]
            if own is not None and Path(own).exists():  # then those it inherits (deviations.inherited)
                mine = self._on_release(engine, own, mine) + self._on_release(
                    engine, deviations.inherited_file(own),
                    deviations.inherited(own, engine, self._off_default_families(engine)))
            users = [replace(d, user=True) for d in deviations.load(self.ctx.known_files) if d.applies_to(engine)]
            self._known[engine] = [replace(d, options=self.ctx.options) for d in mine + users]
        return self._known[engine]

    def _on_release(self, engine: str, own: Path | None, entries: list[deviations.Deviation]) -> list[deviations.Deviation]:
        """The engine's own (and inherited) entries with the bands of the release installed
        (deviations.Deviation.on_release): a further release of the file's `# measured-on:`
        line has band lines of its own where it differs; on a release the line does not
        name, the first release's bands, with a note that says so in each verdict they fail."""
        recorded = deviations.measured_releases(own)
        if recorded is None:
            return entries
        release = registry.installed_release(self.adapter(engine))
        off = deviations.other_release(recorded, release) if release else None
        return [d.on_release(release, off or "") for d in entries]

    def _off_default_families(self, engine: str):
        """Whether a family lies outside the engine's default families (Adapter.default_tags;
        every family where it names none): where an inheriting configuration's option does
        not engage."""
        tags = self.adapter(engine).default_tags

        def outside(family: str) -> bool:
            return not (tags and family in self.families and self.family(family).tags & tags)
        return outside

    def deviation_files(self, engine: str) -> list[Path]:
        """The files whose entries judge the engine: its own, the one its own inherits, the
        user's --known files."""
        try:
            own = self.adapter(engine).deviations_file()
        except registry.EngineError:
            own = None
        return [Path(p) for p in [own, deviations.inherited_file(own), *self.ctx.known_files] if p is not None]


@functools.cache
def _resolver(ctx: Context) -> Resolver:
    return Resolver(ctx)


def forget() -> None:
    """Drop the resolvers made so far: a command run again in the same process (a script,
    a test) reads deviation files, user cases and adapters afresh, as its workers do."""
    _resolver.cache_clear()
