"""Finds case families: every module of this package that defines `FAMILY`, plus the
modules of a user's `--cases-dir`."""
from __future__ import annotations

import importlib
import importlib.util
import pkgutil
import sys
from pathlib import Path

import cases
from cases.family import CaseError, CaseFamily

_SKIP = {"scene", "overlap", "trajectory", "family", "registry", "closed_forms", "observables"}


def _families_in(module) -> list[CaseFamily]:
    found = getattr(module, "FAMILY", None)
    if found is None:
        return []
    if not isinstance(found, CaseFamily):
        raise CaseError(f"{module.__name__}.FAMILY is a {type(found).__name__}, not a CaseFamily")
    return [found]


def builtin_families() -> dict[str, CaseFamily]:
    out = {}
    for info in sorted(pkgutil.iter_modules(cases.__path__), key=lambda i: i.name):
        if info.name in _SKIP or info.name.startswith("_"):
            continue
        for fam in _families_in(importlib.import_module(f"cases.{info.name}")):
            out[fam.name] = fam
    return out


def load_dir(path: str | Path) -> dict[str, CaseFamily]:
    """Import every *.py in a user folder and collect its FAMILY, validated."""
    folder = Path(path)
    if not folder.is_dir():
        raise CaseError(f"--cases-dir {path}: not a folder")
    out = {}
    for file in sorted(folder.glob("*.py")):
        if file.name.startswith("_"):
            continue
        name = f"physval_user_cases.{file.stem}"
        spec = importlib.util.spec_from_file_location(name, file)
        module = importlib.util.module_from_spec(spec)
        sys.modules[name] = module
        try:
            spec.loader.exec_module(module)
        except CaseError:
            raise
        except Exception as exc:  # a user file that does not import: say which and why
            raise CaseError(f"{file}: cannot be loaded: {type(exc).__name__}: {exc}") from None
        fams = _families_in(module)
        if not fams:
            raise CaseError(f"{file}: defines no FAMILY (a cases.family.CaseFamily)")
        for fam in fams:
            fam.validate()
            out[fam.name] = fam
    return out


def all_families(cases_dir: str | Path | None = None) -> dict[str, CaseFamily]:
    fams = builtin_families()
    if cases_dir is not None:
        for name, fam in load_dir(cases_dir).items():
            if name in fams:
                raise CaseError(f"{cases_dir}: family {name!r} is already a built-in family: rename it")
            fams[name] = fam
    return fams
