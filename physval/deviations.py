"""Known engine deviations: `adapters/xfails/<engine>.txt`.

One entry per line, `family[variant-glob]:metric-glob  # reason (and upstream link)`, for
example

    central_impact[e=0.5,*]:v1_after  # no restitution coefficient: e is mapped onto a spring-damper

A failing check that matches an entry is a `deviation` (a known shortfall, reported with
its measured size), not a `fail`. An entry whose check passes shows up as an unexpected
pass; an entry that matches no check at all is reported as stale, so the file cannot rot.
"""
from __future__ import annotations

import re
from dataclasses import dataclass
from fnmatch import fnmatchcase
from pathlib import Path

XFAIL_DIR = Path(__file__).resolve().parent.parent / "adapters" / "xfails"
_LINE = re.compile(r"^(?P<family>\w+)\[(?P<variant>.*)\]:(?P<metric>\S+)\s*#\s*(?P<reason>\S.*)$")


class DeviationFileError(ValueError):
    pass


@dataclass(frozen=True)
class Deviation:
    engine: str
    family: str
    variant: str  # glob
    metric: str   # glob
    reason: str
    line: int

    def matches(self, family: str, variant: str, metric: str) -> bool:
        return family == self.family and fnmatchcase(variant, self.variant) and fnmatchcase(metric, self.metric)

    @property
    def pattern(self) -> str:
        return f"{self.family}[{self.variant}]:{self.metric}"


def load(engine: str, folder: Path = XFAIL_DIR) -> list[Deviation]:
    path = folder / f"{engine}.txt"
    if not path.exists():
        return []
    out = []
    for i, raw in enumerate(path.read_text().splitlines(), start=1):
        line = raw.strip()
        if not line or line.startswith("#"):
            continue
        m = _LINE.match(line)
        if not m:
            raise DeviationFileError(f"{path}:{i}: expected 'family[variant-glob]:metric-glob  # reason', got {raw!r}")
        out.append(Deviation(engine, m["family"], m["variant"], m["metric"], m["reason"].strip(), i))
    return out


def find(deviations: list[Deviation], family: str, variant: str, metric: str) -> Deviation | None:
    for d in deviations:
        if d.matches(family, variant, metric):
            return d
    return None
