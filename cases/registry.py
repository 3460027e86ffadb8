"""Finds case families: every module of the `cases` package and its subpackages that
defines `FAMILY` (a module that does not is a library: scene, observables, the robustness
package's shared invariants), plus the modules of a user's `--cases-dir` folders. A user's file is checked when it is loaded:
any error in it (an exception while importing, in `scene`, `duration` or `expect` of a
variant, a name already taken) stops with a one-line `CaseError` naming the file, the
family and the field.
"""
from __future__ import annotations

import functools
import importlib
import importlib.util
import pkgutil
import sys
from pathlib import Path

import cases
from cases.family import CaseError, CaseFamily


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


def _load_file(file: Path):
    name = f"physval_user_cases.{file.parent.name}_{file.stem}"
    spec = importlib.util.spec_from_file_location(name, file)
    module = importlib.util.module_from_spec(spec)
    sys.modules[name] = module
    try:
        spec.loader.exec_module(module)
    except CaseError as exc:
        raise CaseError(f"{file}: {exc}") from None
    except (Exception, SystemExit) as exc:  # a user file that does not import: say which and why
        what = f"SystemExit({exc.code!r}) raised" if isinstance(exc, SystemExit) else \
            f"{type(exc).__name__}: {str(exc).splitlines()[0] if str(exc) else ''}"
        raise CaseError(f"{file}: cannot be loaded: {what}") from None
    return module


def validate_family(fam: CaseFamily, where: str, full: bool = False) -> None:
    """fam.validate(), with any exception the family's own code raises turned into a
    one-line CaseError naming `where` (the file) and the family."""
    try:
        fam.validate(full=full)
    except CaseError as exc:
        raise CaseError(f"{where}: {exc}") from None
    except (Exception, SystemExit) as exc:
        raise CaseError(f"{where}: family {fam.name!r}: its code raised {type(exc).__name__}: "
                        f"{str(exc).splitlines()[0] if str(exc) else ''} (while building a variant's scene, "
                        "duration or checks)") from None


def load_dir(path: str | Path) -> dict[str, CaseFamily]:
    """Import every *.py in a user folder and collect its FAMILY, validated."""
    folder = Path(path)
    if not folder.is_dir():
        raise CaseError(f"--cases-dir {path}: not a folder")
    out, origin = {}, {}
    for file in sorted(folder.glob("*.py")):
        if file.name.startswith("_"):
            continue
        fams = _families_in(_load_file(file), str(file))
        if not fams:
            raise CaseError(f"{file}: defines no FAMILY (a cases.family.CaseFamily)")
        for fam in fams:
            if fam.name in out:
                raise CaseError(f"{file}: family {fam.name!r} is also defined in {origin[fam.name]}: "
                                "family names must be unique")
            validate_family(fam, str(file))
            out[fam.name], origin[fam.name] = fam, file
    return out


def all_families(cases_dirs=()) -> dict[str, CaseFamily]:
    """The built-in families and those of the user folders `cases_dirs` (one path or several)."""
    if isinstance(cases_dirs, (str, Path)):
        cases_dirs = (cases_dirs,)
    fams = dict(builtin_families())
    where: dict[str, str] = {}
    for folder in cases_dirs or ():
        for name, fam in load_dir(folder).items():
            if name in fams:
                other = where.get(name, "a built-in family")
                raise CaseError(f"{fam.module_file}: family {name!r} is already {other}: rename it")
            fams[name] = fam
            where[name] = f"defined in {fam.module_file}"
    return fams
