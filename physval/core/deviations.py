"""Known deviations: measured engine shortfalls, each bounded by the band it was measured in.

An engine's file (`adapters/xfails/<engine>.txt`, or the file a plug-in adapter ships
beside itself) and a user's `--known FILE` share one format. An entry is a pattern line
with its cause, written by a person, followed by indented band lines, written by
`physval known` from a fresh run:

    central_impact[drop,e=0.5*]:rebound_ratio  # e mapped onto a spring-damper: ratio off by 0.021
        mujoco [drop,e=0.5]:rebound_ratio = 0.47946 +- 5e-06
        mujoco [drop,e=0.5,2D]:rebound_ratio = 0.47946 +- 5e-06
    resting_blocks[n=[45]]:*  # rank-deficient corner LCP: Lemke's pivoting loses the solution
        reference-lemke [n=4]:drift = raises LemkeFailure
    mujoco pair_drop[*]:apex_top  # compliant impacts launch the light top ball higher
        mujoco [e=0.5]:apex_top = 0.060672 +- 3.47e-05

An entry line may begin with an engine name or glob (`mujoco` above, `drake-*`; no
brackets): the entry then applies to those engines only, and its band lines must name
one of them. Without one it applies to every engine its file is read for: an engine's
own file is read for that engine, a user's `--known` file for every engine of the run.

A failing check is a `deviation` only when an entry's pattern matches it AND a band line
records it (engine, exact variant id, metric) AND its measured value lies in the band:
a wildcard covers exactly the checks whose measurements it records. A measurement outside
its band is `fail` ("known deviation changed: recorded 0.479458 +- 5e-06, measured 0.4821"),
so a deviation can neither hide a regression nor an improvement. Bands hold at the
family's default time step and the adapter's default iterations (the settings they were
measured at); elsewhere a failing check is `fail`.

Bands are measured, not proportional. The engines are deterministic: a deviation's value
at a given dt and iteration count repeats to rounding. `physval known` measures every check
REPEATS times (the second time in the reverse order, so each job runs in another worker
process after other jobs: a history dependence shows) and records the middle of the values
+- half their spread plus a rounding floor (`band_of`). A band is at most one tolerance
of its check beyond that floor (the tolerance in the check's units: `tolerance`, or
`tolerance * |expected|` for a relative one): a change of the engine or of its mapping by
more than that is `fail`.

A configuration of an engine that computes what the engine computes wherever its option
does not engage (a continuous-collision configuration off its swept families) may say so in
one line of its file, instead of copying the engine's entries:

    inherit: pybullet

Its checks are then judged, after its own file's entries, by the entries of that engine's
file beside it (`pybullet.txt`), whose bands for that engine count as its own: on every
family but its default ones (`Adapter.default_tags`: the families where its option engages
and its own entries say what it does). The line is valid only where the two configurations
give the same values, which tests/test_bands.py checks on a sample of the inherited checks;
where they differ, an inherited band judges a value it did not measure, and the check
fails ("known deviation changed"). `physval known` writes this file's own entries only.
An inherited entry cites the engine's file and says whose it is ("as pybullet (inherit):").

A file records the engine releases its bands were measured on, machine-readably, in one
header line (`physval known --write` writes it):

    # measured-on: drake 1.51.1, 1.58.0

Its plain band lines hold for the first release. Each further release was measured over
the same checks too, and its bands are the plain ones but where a band line names it
(`ENGINE@RELEASE`): there the release measured another value, or none (`passes`: on that
release the check is within its tolerance):

    resting_blocks[*]:*  # point contact: the stack sinks
        drake [n=4]:drift = 0.00123 +- 1.2e-08
        drake@1.58.0 [n=4]:drift = 0.00125 +- 1.2e-08
        drake@1.58.0 [n=5]:drift = passes

(Python 3.12 resolves Drake 1.58.0 where 3.11 gets 1.51.1, its last release there: both are
installs users make.) A run judges its checks by the bands of the release it runs
(`Deviation.on_release`). A run on a release the header does not name is judged by the
first release's bands all the same, its report says so beside the engine ("bands measured
on drake 1.51.1, this run 1.60.0": `release_notes`), and so does each `fail` of a recorded
deviation there: it may be the release's, not a regression of physval. `physval known
ENGINE --write` on such a release (over all its families) measures it and adds it to the
header, writing band lines of its own only where they differ.

A wider band needs its reason written under the entry, as a `# band:` line:

    stack_strike[*]:stack_displacement  # point contact: the struck stack shuffles sideways
        # band: chaotic: the order of the stack's contact events moves with the rounding
        drake [n=3,m=2.0,h=0.5]:stack_displacement = 0.0412 +- 0.0031

Only then is the measured spread recorded as it is; a band wider than one tolerance
whose entry states no reason makes its check `fail`, naming the file and the band's line
(the tolerance lives beside the check, in the case, so the band and its limit meet where a
check is judged: physval.core.verdicts.judge). `physval known` names the entries that need
a reason when it measures one.
"""
from __future__ import annotations

import math
import re
import shlex
from dataclasses import dataclass, field, replace
from fnmatch import fnmatchcase
from pathlib import Path

from cases.relations import METRIC_PREFIX as INVARIANCE
from physval.core.tolerance import errors, tolerance_units

# the words a verdict's reason starts with when a known deviation's measured size left its
# band (physval.core.verdicts.judge): away from the closed form, or back onto it
CHANGED = "known deviation changed"
VANISHED = "known deviation vanished"

_ENTRY = re.compile(r"^(?:(?P<engines>[^\s\[#]+)\s+)?(?P<family>\w+)\[(?P<variant>.*)\]:(?P<metric>\S+)\s*#\s*(?P<reason>\S.*)$")
_BAND = re.compile(r"^\s+(?P<engine>[^\s@]+)(?:@(?P<release>\S+))?\s+\[(?P<variant>.*)\]:(?P<metric>[^\s=]+)\s*=\s*(?P<rest>\S.*?)\s*(?:#.*)?$")
_VALUE = re.compile(r"^(?P<value>\S+)\s*\+-\s*(?P<width>\S+)$")
_RAISES = re.compile(r"^raises\s+(?P<exc>[\w.]+)$")
PASSES = "passes"  # a release's band line for a check within its tolerance on that release
_BAND_REASON = re.compile(r"^\s*#\s*band:\s*(?P<why>.*?)\s*$")
_MEASURED_ON = re.compile(r"^#\s*measured-on:\s*(?P<package>\S+)\s+(?P<releases>[^\s,]+(?:\s*,\s*[^\s,]+)*)\s*$")
_FAMILIES_MEASURED = re.compile(r"^#\s*families-measured:(?P<names>.*)$")
_INHERIT = re.compile(r"^inherit:\s*(?P<engine>[^\s#]+)\s*(?:#.*)?$")

# The band `physval known` records: the measured values' middle +- half their spread plus a
# floor. The floor is what float64 rounding can move a value by on another machine (another
# BLAS, libm or SIMD path): ROUNDING of the value (1e-9 = 4.5e6 ulps, the rounding of 1e5
# steps amplified 45-fold) or FLOOR_OF_TOLERANCE of the check's tolerance, whichever is
# larger. A hundredth of a tolerance is far below one (a move the band hides changes no
# verdict's margin by more than 1 %: physval compare's threshold) and far above what repeats
# move a deterministic engine by (DART, the one history-dependent engine here, moves its
# friction scenes by up to 3.5e-5 tolerances between two runs).
REPEATS = 2
ROUNDING = 1e-9
FLOOR_OF_TOLERANCE = 0.01
WIDTH_DIGITS = 3  # a band's width is written to 3 significant digits, rounded up
# a band may be one tolerance wide, within the rounding of its written width
WIDEST_WITHOUT_REASON = 1 + 10.0 ** (1 - WIDTH_DIGITS)


class DeviationFileError(ValueError):
    """A line of a known-deviation file that does not parse; the message names file and line."""


def rounding_floor(value: float, tolerance: float) -> float:
    """The smallest band half-width: what rounding moves `value` by across machines, or a
    hundredth of the check's `tolerance` (in the check's units), the larger."""
    return max(ROUNDING * abs(value), FLOOR_OF_TOLERANCE * tolerance)


def round_up(width: float, digits: int = WIDTH_DIGITS) -> float:
    """`width` to `digits` significant digits, never below it (a written band holds what it
    measured) by more than the rounding of the subtraction that measured the spread (1e-12)."""
    if width <= 0 or not math.isfinite(width):
        return width
    rounded = float(f"{width:.{digits}g}")
    if rounded >= width * (1 - 1e-12):
        return rounded
    step = 10.0 ** (math.floor(math.log10(rounded)) - digits + 1)
    return float(f"{rounded + step:.{digits}g}")


def band_of(values: list[float], tolerance: float) -> tuple[float, float]:
    """(value, half-width) of the band around repeated measurements of one check: their
    middle, and half their spread plus the rounding floor (`tolerance` in the check's units)."""
    lo, hi = min(values), max(values)
    middle = lo + (hi - lo) / 2
    return middle, round_up((hi - lo) / 2 + rounding_floor(middle, tolerance))


@dataclass(frozen=True)
class Band:
    """One check's recorded deviation: its measured value +- width, or the exception its
    run raises; `release`: the further release of the file's header it was measured on
    ("" for the first), where `passes` says the check is within its tolerance there."""
    engine: str
    variant: str
    metric: str
    value: float | None = None
    width: float = 0.0
    raises: str | None = None
    line: int = 0
    release: str = ""
    passes: bool = False

    @property
    def key(self) -> tuple[str, str, str]:
        return self.engine, self.variant, self.metric

    def holds(self, measured: float | None = None, exception: str | None = None) -> bool:
        if self.passes:
            return False
        if self.raises is not None:
            return exception == self.raises
        return (exception is None and measured is not None and math.isfinite(measured)
                and abs(measured - self.value) <= self.width)

    def describe(self) -> str:
        if self.passes:
            return PASSES
        return f"raises {self.raises}" if self.raises else f"{self.value:.6g} +- {self.width:.2g}"

    def text(self) -> str:
        if self.passes:
            what = PASSES
        else:
            what = f"raises {self.raises}" if self.raises else f"{self.value!r} +- {self.width:.{WIDTH_DIGITS}g}"
        at = f"@{self.release}" if self.release else ""
        return f"    {self.engine}{at} [{self.variant}]:{self.metric} = {what}"

    def tolerances(self, tolerance: float) -> float:
        """The band's half-width in tolerances of its check (`tolerance` in the check's units);
        0 for a band of an exception, NaN where the tolerance is 0 or not finite."""
        if self.raises is not None or self.passes:
            return 0.0
        return self.width / tolerance if tolerance > 0 and math.isfinite(tolerance) else math.nan

    def spread_tolerances(self, tolerance: float) -> float:
        """As `tolerances`, of the half-width beyond the floor of rounding across machines
        (ROUNDING of the value): what the repeats spread. The floor has its reason stated
        once (above ROUNDING); it outgrows a tolerance only where the tolerance is itself
        a share of rounding and the value is large, as for a broken invariance (the
        invariance battery's checks promise round-off, 1e-11 of scale, and a turned run that
        parted measures 0.1 of it: its floor is 1e-10)."""
        if self.raises is not None or self.passes:
            return 0.0
        beyond = max(self.width - ROUNDING * abs(self.value), 0.0)
        return beyond / tolerance if tolerance > 0 and math.isfinite(tolerance) else math.nan


@dataclass(frozen=True)
class Deviation:
    """An entry: a pattern over checks, its cause, and the bands of the checks it covers."""
    source: str   # the file it comes from
    family: str
    variant: str  # glob
    metric: str   # glob
    reason: str
    line: int
    bands: tuple[Band, ...] = field(default=())
    user: bool = False  # from a user's --known file: a difference the user expects, not an engine's own
    engines: str = "*"  # the engines it applies to (a name or glob)
    options: tuple[str, ...] = ()  # the --cases-dir and --adapter options of the run that read it
    band_reason: str = ""  # why its bands may be wider than one tolerance (its `# band:` line)
    inherited_from: str = ""  # the engine whose entry and bands this is, read through an `inherit:` line
    off_release: str = ""  # `other_release`'s note where the run's release is none its file was measured on
    other_releases: tuple[str, ...] = ()  # the releases whose own band lines `on_release` left out

    @property
    def cause(self) -> str:
        """The cause as results and reports show it; a user's entry says it is the user's."""
        return f"expected by the user (--known {Path(self.source).name}): {self.reason}" if self.user else self.reason

    def applies_to(self, engine: str) -> bool:
        return fnmatchcase(engine, self.engines)

    def remeasure(self, engine: str) -> str:
        """The command that measures this entry's bands on `engine` again and writes them
        into the file the entry came from (an engine's own file is where `physval known`
        writes without --file)."""
        where = ["--file", self.source] if self.user else []
        return shlex.join(["physval", "known", self.inherited_from or engine, *where, *self.options, "--write"])

    def recorded_as(self, recorded: str, engine: str) -> "Deviation":
        """This entry with the bands recorded for engine `recorded` as `engine`'s (itself
        where the two are one): how an adapter judged by another engine's bands reads them."""
        if recorded == engine:
            return self
        return replace(self, engines=engine, bands=tuple(replace(b, engine=engine) for b in self.bands
                                                          if b.engine == recorded))

    def matches(self, family: str, variant: str, metric: str) -> bool:
        """The entry covers this check. The invariance battery's verdicts (metrics
        invariance_*, cases.relations) are covered only by entries that name them: a
        family's entry with the metric `*` records a shortfall of its closed forms, not a
        broken invariance."""
        if metric.startswith(INVARIANCE) and not self.metric.startswith(INVARIANCE):
            return False
        return family == self.family and fnmatchcase(variant, self.variant) and fnmatchcase(metric, self.metric)

    def band(self, engine: str, variant: str, metric: str) -> Band | None:
        for b in self.bands:
            if b.engine == engine and b.variant == variant and b.metric == metric:
                return b
        return None

    def on_release(self, release: str | None, off_release: str = "") -> "Deviation":
        """This entry with the bands that hold on `release` (None: the file's first): the
        plain ones, but where a band line names that release (its value, or no band where
        it `passes`); band lines of other releases go. `off_release`: the note that the run's
        release is none the file was measured on (`other_release`), for its verdicts' reasons."""
        if not off_release and not any(b.release for b in self.bands):
            return self
        own = {b.key: b for b in self.bands if b.release and b.release == release}
        bands = [own.pop(b.key, b) for b in self.bands if not b.release] + list(own.values())
        others = tuple(dict.fromkeys(b.release for b in self.bands if b.release and b.release != release))
        return replace(self, bands=tuple(b for b in bands if not b.passes), off_release=off_release,
                       other_releases=others)

    @property
    def pattern(self) -> str:
        engines = "" if self.engines == "*" else f"{self.engines} "
        return f"{engines}{self.family}[{self.variant}]:{self.metric}"

    @property
    def where(self) -> str:
        return f"{Path(self.source).name}:{self.line}"

    def too_wide(self, band: Band, tolerance: float) -> str | None:
        """Why `band` may not stand as recorded: wider than one tolerance of its check
        (`tolerance` in the check's units) beyond the rounding floor while the entry gives no
        `# band:` reason; None if it may."""
        over = band.spread_tolerances(tolerance)
        if self.band_reason or not over > WIDEST_WITHOUT_REASON:
            return None
        return (f"the band {band.describe()} ({Path(self.source).name}:{band.line}) is {over:.3g} tolerances wide and "
                f"its entry {self.pattern} ({self.where}) gives no reason: a band is at most one tolerance unless "
                f"a '# band: WHY' line under the entry says why")


def parse(path: Path | str) -> list[Deviation]:
    """Every entry of one file, with its bands."""
    path = Path(path)
    out: list[Deviation] = []
    recorded = measured_releases(path)
    further = recorded[1][1:] if recorded else ()
    for i, raw in enumerate(_text(path).splitlines(), start=1):
        line = raw.rstrip()
        if (why := _BAND_REASON.match(line)) is not None:
            if not out or not why["why"]:
                raise DeviationFileError(f"{path}:{i}: a '# band: WHY' line gives the reason of the entry above it "
                                         f"for bands wider than one tolerance, got {raw!r}")
            out[-1] = replace(out[-1], band_reason=" ".join(filter(None, (out[-1].band_reason, why["why"]))))
            continue
        if not line.strip() or line.lstrip().startswith("#"):
            continue
        if line.startswith("inherit:"):
            if _INHERIT.match(line) is None or any(_INHERIT.match(r) for r in _text(path).splitlines()[:i - 1]):
                raise DeviationFileError(f"{path}:{i}: one 'inherit: ENGINE' line names the engine whose entries "
                                         f"this configuration shares, got {raw!r}")
            continue
        if raw[:1].isspace():
            m = _BAND.match(line)
            if not m or not out:
                raise DeviationFileError(f"{path}:{i}: a band line reads '    ENGINE [VARIANT]:METRIC = VALUE +- "
                                         f"WIDTH' (or '= raises EXCEPTION') under an entry, got {raw!r}")
            rest, release = m["rest"], m["release"] or ""
            if release and release not in further:
                raise DeviationFileError(f"{path}:{i}: {m['engine']}@{release}: a band line names a release only "
                                         f"if the '# measured-on:' line lists it after the first (plain band lines "
                                         f"hold for the first), got {', '.join(recorded[1]) if recorded else 'none'}")
            if rest == PASSES:
                if not release:
                    raise DeviationFileError(f"{path}:{i}: '= {PASSES}' is a further release's line "
                                             f"(ENGINE@RELEASE) for a check within its tolerance there, got {raw!r}")
                band = Band(m["engine"], m["variant"], m["metric"], line=i, release=release, passes=True)
            elif (r := _RAISES.match(rest)) is not None:
                band = Band(m["engine"], m["variant"], m["metric"], raises=r["exc"], line=i, release=release)
            elif (v := _VALUE.match(rest)) is not None:
                try:
                    value, width = float(v["value"]), float(v["width"])
                except ValueError:
                    raise DeviationFileError(f"{path}:{i}: value and width must be numbers, got {rest!r}") from None
                if not (math.isfinite(value) and math.isfinite(width) and width >= 0):
                    raise DeviationFileError(f"{path}:{i}: value and width must be finite, width >= 0: {rest!r}")
                band = Band(m["engine"], m["variant"], m["metric"], value, width, line=i, release=release)
            else:
                raise DeviationFileError(f"{path}:{i}: expected 'VALUE +- WIDTH' or 'raises EXCEPTION', got {rest!r}")
            entry = out[-1]
            if not entry.matches(entry.family, band.variant, band.metric):
                raise DeviationFileError(f"{path}:{i}: [{band.variant}]:{band.metric} is not matched by its "
                                         f"entry {entry.pattern}")
            if not entry.applies_to(band.engine):
                raise DeviationFileError(f"{path}:{i}: engine {band.engine!r} is not one of its entry's "
                                         f"engines {entry.engines!r}")
            out[-1] = replace(entry, bands=entry.bands + (band,))
            continue
        m = _ENTRY.match(line)
        if not m:
            raise DeviationFileError(f"{path}:{i}: expected '[ENGINE-GLOB] family[variant-glob]:metric-glob  # cause', "
                                     f"got {raw!r}")
        out.append(Deviation(str(path), m["family"], m["variant"], m["metric"], m["reason"].strip(), i,
                             engines=m["engines"] or "*"))
    return out


def _text(path: Path) -> str:
    try:
        return path.read_text(encoding="utf-8")
    except UnicodeDecodeError as exc:
        raise DeviationFileError(f"{path}: not UTF-8 text (byte {exc.object[exc.start]:#04x} at offset "
                                 f"{exc.start}); a known-deviation file is UTF-8 text") from None
    except OSError as exc:
        raise DeviationFileError(f"{path}: cannot be read ({exc.strerror or exc})") from None


def measured_releases(path: Path | str | None) -> tuple[str, tuple[str, ...]] | None:
    """(package, releases) of the file's `# measured-on: PACKAGE RELEASE[, RELEASE...]`
    header line: the engine releases its bands were measured on, the first the one its plain
    band lines hold for; None if the file has none (or is missing)."""
    m = _header(path, _MEASURED_ON)
    return None if m is None else (m["package"], tuple(r.strip() for r in m["releases"].split(",")))


def families_measured(path: Path | str | None) -> frozenset[str] | None:
    """The families named by the file's `# families-measured: NAME ...` header line: those
    `physval known ENGINE --write` ran on the engine (its deviating checks then have entries
    and bands, the others passed); None if the file has none (or is missing). A configuration
    whose default run leaves families out (Adapter.default_tags) meets the rest only when
    named, so its file says which it was measured on (tests/test_bands.py)."""
    m = _header(path, _FAMILIES_MEASURED)
    return None if m is None else frozenset(m["names"].split())


def with_families_measured(text: str, families) -> str:
    """`text` of a deviation file with its `# families-measured:` header line naming
    `families` (sorted; replaced where it is, or put after the `# measured-on:` line, else first)."""
    lines = text.splitlines()
    on = _line_of(lines, _MEASURED_ON)
    return _with_header(lines, _FAMILIES_MEASURED, "# families-measured: " + " ".join(sorted(families)),
                        0 if on is None else on + 1)


def measured_on(path: Path | str | None) -> tuple[str, str] | None:
    """(package, release) of the first release the file's `# measured-on:` line names: the
    one its plain band lines hold for; None if the file names none (or is missing)."""
    recorded = measured_releases(path)
    return None if recorded is None else (recorded[0], recorded[1][0])


def inherits(path: Path | str | None) -> str | None:
    """The engine named by the file's `inherit: ENGINE` line (whose entries the
    configuration shares off its default families), or None (no line, or no file)."""
    m = _header(path, _INHERIT)
    return None if m is None else m["engine"]


def inherited_file(path: Path | str | None) -> Path | None:
    """The file of the engine the file's `inherit: ENGINE` line names (ENGINE.txt beside
    it), or None (no such line)."""
    source = inherits(path)
    return Path(path).with_name(f"{source}.txt") if source else None


def inherited(path: Path | str, engine: str, outside) -> list[Deviation]:
    """The entries `engine` inherits through the `inherit:` line of its file `path`: those of
    the named engine's file beside it that apply to that engine, with its bands as `engine`'s,
    on the families `outside(family)` accepts (not the configuration's default families)."""
    other = inherited_file(path)
    if other is None:
        return []
    source = other.stem
    if not other.exists():
        raise DeviationFileError(f"{path}: 'inherit: {source}' names no file beside it ({other.name})")
    if inherits(other) is not None:
        raise DeviationFileError(f"{path}: 'inherit: {source}': {other.name} inherits in turn; name the engine "
                                 "whose own entries these are")
    return [replace(d.recorded_as(source, engine), reason=f"as {source} (inherit): {d.reason}", inherited_from=source)
            for d in parse(other) if d.applies_to(source) and outside(d.family)]


def other_release(recorded: tuple[str, tuple[str, ...] | str] | None, version: str) -> str | None:
    """"bands measured on drake 1.51.1, this run 1.60.0" if the engine's version string
    (`Adapter.version()`: "1.58.0", "pyb2d3 0.11.1", "7.3.1 (Munk2D ...)") names none of the
    releases its bands were measured on (`recorded`: (package, release or releases)); None
    if it names one, or if the file records none."""
    if recorded is None or version in ("", "unknown"):
        return None
    package, releases = recorded[0], recorded[1]
    releases = (releases,) if isinstance(releases, str) else tuple(releases)
    if set(releases) & set(re.findall(r"[\w.+!-]+", version)):
        return None
    return f"bands measured on {package} {' and '.join(releases)}, this run {version}"


def release_notes(df, resolver) -> dict[str, str]:
    """Engine -> `other_release`'s note, for each engine of the run (rows `df`) whose own
    known-deviation file records another release than the one that ran."""
    notes = {}
    for engine, version in df.groupby("engine", sort=False)["engine_version"].first().items():
        try:
            path = resolver.adapter(engine).deviations_file()
        except Exception:  # an engine that is gone since the run: nothing to compare
            continue
        if (note := other_release(measured_releases(path), str(version))) is not None:
            notes[engine] = note
    return notes


def with_measured_on(text: str, package: str, *releases: str) -> str:
    """`text` of a deviation file with its `# measured-on:` header line naming these releases,
    the first the one its plain band lines hold for (replaced where it is, or put first)."""
    return _with_header(text.splitlines(), _MEASURED_ON, f"# measured-on: {package} {', '.join(releases)}", 0)


def _header(path: Path | str | None, pattern: re.Pattern):
    """The match of the file's first line that `pattern` matches (stripped of its
    surrounding spaces), or None (no such line, or no file)."""
    if path is None or not Path(path).exists():
        return None
    lines = _text(Path(path)).splitlines()
    at = _line_of(lines, pattern)
    return None if at is None else pattern.match(lines[at].strip())


def _line_of(lines: list[str], pattern: re.Pattern) -> int | None:
    """The index of the first of `lines` that `pattern` matches (stripped), or None."""
    return next((i for i, raw in enumerate(lines) if pattern.match(raw.strip())), None)


def _with_header(lines: list[str], pattern: re.Pattern, header: str, where: int) -> str:
    """The text of `lines` with `header` in place of the line `pattern` matches, or inserted
    at index `where` where none does."""
    at = _line_of(lines, pattern)
    if at is None:
        lines.insert(where, header)
    else:
        lines[at] = header
    return "\n".join(lines) + "\n"


def unknown_names(entries: list[Deviation], families, engines: list[str]) -> str | None:
    """What the first entry naming a family or an engine that does not exist names, with
    where it is and what exists; None if every name exists."""
    for e in entries:
        if e.family not in families:
            return f"{e.source}:{e.line}: no family {e.family!r} (families: {', '.join(sorted(families))})"
        if not any(e.applies_to(x) for x in engines):
            return f"{e.source}:{e.line}: engine {e.engines!r} matches no engine (engines: {', '.join(engines)})"
        for b in e.bands:
            if b.engine not in engines:
                return f"{e.source}:{b.line}: no engine {b.engine!r} (engines: {', '.join(engines)})"
    return None


def load(paths) -> list[Deviation]:
    """The entries of several files (missing files have none), in order."""
    out = []
    for p in paths:
        if p is not None and Path(p).exists():
            out += parse(p)
    return out


def find(deviations: list[Deviation], family: str, variant: str, metric: str) -> Deviation | None:
    """The first entry whose pattern matches the check."""
    for d in deviations:
        if d.matches(family, variant, metric):
            return d
    return None


# --- writing bands (physval known) ---------------------------------------------------------

def rewrite(path: Path, bands_of: dict[int, list[Band]]) -> str:
    """The text of `path` with each entry's band lines replaced by `bands_of[entry line]`
    (entries not in `bands_of` keep theirs; a band parsed from the file, `line` > 0, is
    written as its line reads); comments, causes and `# band:` reasons are kept as written,
    a reason right under its entry."""
    lines = _text(Path(path)).splitlines()
    entry_at = [bool(raw.strip()) and not raw.lstrip().startswith("#") and not raw[:1].isspace()
                and _ENTRY.match(raw.rstrip()) is not None for raw in lines]
    out: list[str] = []
    current: int | None = None
    for i, raw in enumerate(lines, start=1):
        if current in bands_of and _BAND_REASON.match(raw):
            continue  # written under its entry
        is_band = raw[:1].isspace() and raw.strip() and not raw.lstrip().startswith("#")
        if is_band:
            if current in bands_of:
                continue  # replaced below the entry
            out.append(raw)
            continue
        out.append(raw)
        if entry_at[i - 1]:
            current = i
            if i in bands_of:
                below = lines[i:next((j for j in range(i, len(lines)) if entry_at[j]), len(lines))]
                # a band kept from the file keeps its line as written (a width of more digits stays)
                out += [r for r in below if _BAND_REASON.match(r)] + [
                    lines[b.line - 1] if b.line and _BAND.match(lines[b.line - 1]) else b.text() for b in bands_of[i]]
    return "\n".join(out) + "\n"


# --- measuring bands, and entries that went stale ----------------------------------------

def deviating(row: dict) -> bool:
    """A judged check whose measurement misses its tolerance."""
    try:
        expected, measured, tol = float(row["expected"]), float(row["measured"]), float(row["tolerance"])
    except (TypeError, ValueError):
        return False
    if not math.isfinite(measured):
        return False
    abs_err, rel_err = errors(expected, measured)
    err = abs_err if row["tolerance_kind"] == "abs" else rel_err
    return not (math.isfinite(err) and err <= tol)


@dataclass
class Measured:
    """What repeated runs measure for one engine under a file's entries."""
    bands: dict[int, list[Band]]  # entry line -> its bands (first matching entry wins)
    tolerance: dict[tuple[str, str], float] = field(default_factory=dict)  # (variant, metric) -> tolerance, in units
    unsteady: list[str] = field(default_factory=list)  # checks whose repeats disagree on raising, one line each

    def too_wide(self, entries: list[Deviation]) -> list[tuple[Deviation, Band, str]]:
        """The bands wider than one tolerance whose entry gives no reason, with why."""
        out = []
        for e in entries:
            for b in self.bands.get(e.line, []):
                why = e.too_wide(b, self.tolerance.get((b.variant, b.metric), math.nan))
                if why is not None:
                    out.append((e, b, why))
        return out


def measured_bands(engine: str, entries: list[Deviation], repeats: list[tuple[dict, dict]]) -> Measured:
    """The bands the repeats of a fresh run measure for `engine`: `repeats` holds, per
    repeat, (job key -> rows, job key -> the exception its run raised). A check gets a band
    when it misses its tolerance in some repeat (its values' middle +- half their spread
    plus the rounding floor: band_of), or a `raises` band when every repeat raised the same."""
    out = Measured({e.line: [] for e in entries})
    seen: dict[tuple, list] = {}  # (job key, variant, metric) -> [(exception or None, row)] per repeat
    for rows_by_job, raised in repeats:
        for key, rows in rows_by_job.items():
            for r in rows:
                seen.setdefault((key, r["variant"], r["metric"]), []).append((raised.get(key), r))
    for (key, variant, metric), runs in seen.items():
        r = runs[0][1]
        entry = find(entries, r["case"], variant, metric)
        if entry is None:
            continue
        raised = [exc if exc and row["status"] in ("error", "deviation") else None for exc, row in runs]
        judged = [row for _, row in runs if row["status"] in ("pass", "fail", "deviation")
                  and math.isfinite(float(row["measured"]))]
        if all(raised) and len(set(raised)) == 1:
            out.bands[entry.line].append(Band(engine, variant, metric, raises=raised[0]))
        elif any(raised):
            out.unsteady.append(f"{r['case']}[{variant}]:{metric}: the repeats raised "
                                f"{', '.join(x or 'nothing' for x in raised)}: no band recorded")
        elif len(judged) == len(runs) and any(deviating(row) for row in judged):
            tol = tolerance_units(float(r["expected"]), float(r["tolerance"]), r["tolerance_kind"])
            value, width = band_of([float(row["measured"]) for row in judged], tol)
            out.bands[entry.line].append(Band(engine, variant, metric, value, width))
            out.tolerance[(variant, metric)] = tol
        elif any(deviating(row) for row in judged):  # a repeat without a value (its worker died, say)
            lost = next(row for _, row in runs if not any(row is j for j in judged))
            out.unsteady.append(f"{r['case']}[{variant}]:{metric}: {len(runs) - len(judged)} of {len(runs)} repeats "
                                f"gave no value ({lost['status']}: {str(lost['reason'])[:80]}): no band recorded")
    return out


def stale_entries(df, resolver) -> list[str]:
    """Entries whose recorded checks now pass, that have no band, or that match no check of
    a family that ran (at the settings bands are recorded at). An entry whose variants all
    lie outside this run (a full grid's, or another engine's) is not stale: only one that
    matches no variant of its family at all, or none of the variants that ran although
    they are all its family has, is listed as matching nothing."""
    notes = []
    ran_families = set(df.case)
    for engine, mine in df.groupby("engine", sort=False):  # one pass, not a scan of df per engine
        judged = {(r.case, r.variant, r.metric): "pass" if str(r.reason).startswith(VANISHED) else r.status
                  for r in mine.itertuples()}  # a vanished deviation: within its tolerance, the entry can go
        ran_variants = {(c, v) for c, v, _ in judged}
        of_family: dict[str, list[tuple]] = {}  # an entry matches its own family's checks only (Deviation.matches)
        for k in judged:
            of_family.setdefault(k[0], []).append(k)
        for e in resolver.known(engine):
            if e.family not in ran_families:
                continue
            hits = [k for k in of_family.get(e.family, ()) if e.matches(*k)]
            if not hits:
                variants = [v.id for v in resolver.family(e.family).all_variants if fnmatchcase(v.id, e.variant)]
                if not variants or all((e.family, v) in ran_variants for v in variants):
                    notes.append(f"{engine}: `{e.pattern}` ({e.where}) matched no check in this run")
                continue
            bands = [b for b in e.bands if b.engine == engine]
            if not bands and not e.other_releases:  # an entry of another release's checks only is not stale
                notes.append(f"{engine}: `{e.pattern}` ({e.where}) records no band: `{e.remeasure(engine)}`")
            passing = [b for b in bands if judged.get((e.family, b.variant, b.metric)) == "pass"]
            if passing:
                notes.append(f"{engine}: `{e.pattern}` ({e.where}): {len(passing)} recorded checks now pass "
                             f"(e.g. [{passing[0].variant}]:{passing[0].metric}): `{e.remeasure(engine)}`")
    return notes
