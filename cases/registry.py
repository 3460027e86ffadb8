"""Finds case families: every module of the `cases` package and its subpackages that
defines `FAMILY` (a module that does not is a library: scene, observables, the robustness
package's shared invariants), plus the files of a user's `--cases-dir` folders.

A user's file is checked when it is loaded: any error in it (an exception or exit while
importing, in `scene`, `duration` or `expect` of a variant, a name already taken) is a
one-line `CaseError` naming the file, the family and the field. Commands load user files
only after physval.core.dry_run has tried them in a worker process; a file that fails
there or here is a `Problem`, left out of runs that do not select it.
"""
from __future__ import annotations

import functools
import importlib
import importlib.util
import pkgutil
import sys
from pathlib import Path
from typing import NamedTuple

import cases
from cases.family import IMPORT_RULE, CaseError, CaseFamily, user_code


def _families_in(module, where: str) -> list[CaseFamily]:
    found = getattr(module, "FAMILY", None)
    if found is None:
        return []
    if not isinstance(found, CaseFamily):
        raise CaseError(f"{where}: FAMILY is a {type(found).__name__}, not a CaseFamily")
    return [found]


@functools.cache
def builtin_families() -> dict[str, CaseFamily]:
    """The families shipped in `cases/` (the conformance battery among them), by name: the
    FAMILY of every module, in the order of the modules' names."""
    out = {}
    for info in sorted(pkgutil.walk_packages(cases.__path__, "cases."), key=lambda i: i.name):
        module = importlib.import_module(info.name)
        for fam in _families_in(module, module.__name__):
            out[fam.name] = fam
    return dict(out)


class Problem(NamedTuple):
    """A user's family file that cannot be used: the file, its family's name ("" if it was
    not found) and the one-line message."""
    file: str
    family: str
    message: str


def case_files(folder: str | Path) -> list[Path]:
    """The family files of a user folder: its *.py but those starting with '_'."""
    return [f for f in sorted(Path(folder).glob("*.py")) if not f.name.startswith("_")]


def load_file(file: Path, where: str | None = None) -> CaseFamily:
    """Import a user's family file and return its FAMILY. CaseError naming `where` (default:
    the file) if importing it raises (an exit included) or it defines no CaseFamily."""
    where = where or str(file)
    name = f"physval_user_cases.{file.parent.name}_{file.stem}"
    spec = importlib.util.spec_from_file_location(name, file)
    module = importlib.util.module_from_spec(spec)
    sys.modules[name] = module
    with user_code(where, "cannot be loaded:", IMPORT_RULE):
        spec.loader.exec_module(module)
    fams = _families_in(module, where)
    if not fams:
        raise CaseError(f"{where}: defines no FAMILY (a cases.family.CaseFamily)")
    return fams[0]


def validate_family(fam: CaseFamily, where: str, full: bool = False) -> None:
    """fam.validate(), its one-line CaseError naming `where` (the file) too."""
    try:
        fam.validate(full=full)
    except CaseError as exc:
        raise CaseError(f"{where}: {exc}") from None


def load_dir(path: str | Path, broken: dict[str, Problem] | None = None,
             taken: dict[str, str] | None = None) -> dict[str, CaseFamily]:
    """Import every family file of a user folder and collect its FAMILY, validated. A file
    that cannot be used (it does not load or validate, or its family's name is in `taken`,
    name -> where it is, or repeats) raises its CaseError; given `broken` (file ->
    Problem), it is recorded there instead and left out, and a file already there is not
    imported. The names found are added to `taken`."""
    folder = Path(path)
    if not folder.is_dir():
        raise CaseError(f"--cases-dir {path}: not a folder")
    taken = {} if taken is None else taken
    out = {}
    for file in case_files(folder):
        if broken is not None and str(file) in broken:
            continue
        fam = None
        try:
            fam = load_file(file)
            if fam.name in taken:
                raise CaseError(f"{file}: family {fam.name!r} is already {taken[fam.name]}: family names must be "
                                "unique, rename it")
            validate_family(fam, str(file))
        except CaseError as exc:
            if broken is None:
                raise
            broken[str(file)] = Problem(str(file), str(fam.name) if fam else "", str(exc))
            continue
        out[fam.name], taken[fam.name] = fam, f"defined in {file}"
    return out


def all_families(cases_dirs=(), broken: dict[str, Problem] | None = None) -> dict[str, CaseFamily]:
    """The built-in families and those of the user folders `cases_dirs` (one path or
    several); `broken` as for load_dir."""
    if isinstance(cases_dirs, (str, Path)):
        cases_dirs = (cases_dirs,)
    fams = dict(builtin_families())
    taken = {name: "a built-in family" for name in fams}
    for folder in cases_dirs or ():
        fams.update(load_dir(folder, broken, taken))
    return fams
