"""`physval known ENGINE`: measure an engine's known deviations and write their bands.

The command runs every variant the engine can represent in a default run (`--full`: also
the full grids; `--on-demand`: also the runs the engine declares too slow for one; or the
`--cases`; with a user's `--file`, the families it names) and the invariance battery (each
relation on those of its default scenes the selection holds), at the family's dt and the adapter's default iterations,
and under each entry of the engine's deviation file (or of the `--file`) records a band
line for every check the entry matches that misses its tolerance (or a `raises EXCEPTION`
line for a run the engine aborts). Every job runs `--repeat` times (default 2), each
repeat in new worker processes and in the reverse order of the one before, so that a
history dependence shows; a band is the values' middle +- half their spread plus a
rounding floor (a hundredth of the check's tolerance), at most one tolerance of its check
unless a `# band: WHY` line under the entry says why it is wider. The cause on the entry
line and its `# band:` reason stay as the person who measured it wrote them. Without
`--write` it only says what would change. It also lists failing checks no entry covers
(write an entry with its cause) and entries that no longer cover anything (remove or
narrow them). A file edited while its engine's jobs ran is not written (exit 1): the same
command again writes from the stored rows. With --write over an engine's own file, the file's `# measured-on: PACKAGE RELEASE[, RELEASE...]`
line names the releases its bands hold for: the first its plain band lines, each further one
its own `ENGINE@RELEASE` lines where it differs. Measured on a release the line lists after
the first (or, over all families, one it does not list yet: it is added), only that
release's own lines are written; on the first, the plain ones.
A file that inherits another engine's entries (`inherit: ENGINE`) gets its own entries'
bands only; the inherited ones are that engine's, measured with `physval known ENGINE`.
With --write over an engine's own file, its `# families-measured:` line adds the families
this run measured (a configuration that runs only some families unless named is checked
against it: every family it can represent must be measured on it).
"""
from __future__ import annotations

import argparse
import math
import sys
from dataclasses import replace
from fnmatch import fnmatchcase
from pathlib import Path


from adapters.planting import Planted
from adapters.registry import installed_release
from cases.relations import RELATIONS
from physval.core.deviations import Band, deviating, measured_bands
from physval.commands import options
from physval.core import deviations
from physval.core import COLUMNS, Job
from physval.core.plan import leaves_out, priced, relation_jobs
from physval.core.session import Execution, run_stored
from physval.core.store import cache_dir
from physval.report import write_atomic


def add_parser(sub) -> None:
    p = sub.add_parser(
        "known", help="measure engines' known deviations and write their bands",
        formatter_class=argparse.RawDescriptionHelpFormatter,
        description=__doc__.split("\n\n", 1)[1],
        epilog="examples:\n  physval known mujoco                 what would change in adapters/xfails/mujoco.txt\n"
               "  physval known mujoco --write         write the bands\n"
               "  physval known 'drake-*' --write\n"
               "  physval known mujoco --file my_known.txt --cases-dir my_cases --write")
    p.add_argument("engines", nargs="+", metavar="ENGINE", help="engines (names or globs)")
    p.add_argument("--file", metavar="FILE", help="a known-deviation file of your own instead of each engine's")
    p.add_argument("--write", action="store_true", help="write the measured bands into the file")
    p.add_argument("--full", action="store_true", help="also variants of the families' full grids")
    p.add_argument("--on-demand", action="store_true",
                   help="also the runs the engine declares too slow for a default run (minutes each)")
    p.add_argument("--cases", nargs="+", metavar="SPEC", help="only these families or variants (the --cases grammar)")
    p.add_argument("--repeat", type=options.positive_int, default=deviations.REPEATS, metavar="N",
                   help=f"run every job N times, each repeat in new workers and in the reverse order of the one "
                        f"before (default {deviations.REPEATS}); a band is what the repeats spread, plus the "
                        "rounding floor")
    p.add_argument("--cases-dir", action="append", metavar="DIR", help="also load case families from DIR")
    p.add_argument("--adapter", action="append", metavar="MODULE:CLASS", help="also use this adapter")
    options.add_execution(p, str(cache_dir()))


def _in_place(old: list, new: list, keep) -> list:
    """An entry's bands after a measurement, in the file's order (so that a re-measured file
    differs only where a band did): a band measured again stays where it was, one `keep`
    refuses goes, one measured for the first time comes last."""
    fresh = {(b.engine, b.variant, b.metric): b for b in new}
    out = []
    for b in old:
        key = (b.engine, b.variant, b.metric)
        if key in fresh:
            out.append(fresh.pop(key))
        elif keep(b):
            out.append(b)
    return out + list(fresh.values())


def _plain_lines(entry, new: list, release, keep, measured) -> list:
    """An entry's bands where the plain band lines were measured (the file's first release, or
    a file that names none): those `_in_place`, and the further releases' lines as they were."""
    return (_in_place([b for b in entry.bands if not b.release], new, keep)
            + [b for b in entry.bands if b.release])


def _release_lines(entry, new: list, release: str, keep, measured) -> list:
    """An entry's bands where a further release was measured: the plain lines and other
    releases' lines as they were, and this release's own lines where it differs from the
    plain band (another value, or `passes` where the check `measured` now is within its
    tolerance), in place of its lines of the checks measured again."""
    plain = {b.key: b for b in entry.bands if not b.release}
    fresh = {b.key for b in new}
    own = [replace(b, release=release) for b in new
           if b.key not in plain or not plain[b.key].holds(b.value, b.raises)]
    own += [Band(b.engine, b.variant, b.metric, release=release, passes=True)
            for b in plain.values() if measured(b) and b.key not in fresh]
    mine = [b for b in entry.bands if b.release == release]
    return ([b for b in entry.bands if b.release != release]
            + _in_place(mine, own, lambda b: not measured(b)))


def _refuse_a_borrowed_file(engine: str, adapter) -> None:
    """A planted engine (adapters.planting.Planted, or any adapter judged by another
    engine's bands) reads the bands of the engine it wraps: its own measured bands would
    overwrite that engine's in the shipped file. They go to a file of the user's own."""
    wrapped = getattr(adapter, "bands_of", None) or (adapter.name if isinstance(adapter, Planted) else None)
    if wrapped:
        raise options.UsageError(f"known {engine} --write: {engine} is judged by the bands of {wrapped} "
                                 f"(a planted or wrapped engine), whose file records {wrapped} itself; "
                                 f"add --file FILE to write {engine}'s bands into a file of your own")


def _measurable(engines: list[str], resolver, given: list[str]) -> list[str]:
    """The engines whose adapter can be made here. One a glob matched that cannot be (not
    installed, or a configuration the installed release lacks: drake-tamsi on Drake 1.58)
    is left out with one line on stderr, as a release outside its range is; one named by its
    name stops the command (registry.EngineError, exit 2) before any work."""
    from adapters import registry
    named = {w.strip() for v in given for w in v.split(",")}
    kept = []
    for e in engines:
        try:
            resolver.adapter(e)
        except registry.EngineError as exc:
            if e in named:
                raise
            print(f"physval: {e} left out: {exc}", file=sys.stderr)
            continue
        kept.append(e)
    return kept


def run(args) -> int:
    ctx = options.context_of(args)
    resolver = ctx.resolver()
    engines = _measurable(options.engines_of(args, ctx, default=[]), resolver, args.engines)
    if args.file and not options.is_a("--file", args.file, Path.is_file):
        raise options.UsageError(f"--file {args.file!r}: not a file")
    options.check_scheduler(args.scheduler)
    if args.write and not args.file:
        for engine in engines:
            _refuse_a_borrowed_file(engine, resolver.adapter(engine))
    out = options.held(args, options.output_folder(args.out))
    families = resolver.families
    # every variant the engines can run (or the --cases), so that failing checks no entry
    # covers show up too; with a user's file, only the families it names
    selected = options.cases_of(args, resolver, full=args.full)
    changed = unwritten = 0
    from physval.readings import cost
    price = cost.pricer(resolver, cost.model_for(None))  # a run measured over the per-job limit: --on-demand
    for engine in engines:
        adapter = resolver.adapter(engine)
        path = Path(args.file) if args.file else adapter.deviations_file()
        if path is None or not path.exists():
            print(f"{engine}: no known-deviation file ({path})")
            continue
        as_read = path.read_bytes()  # the bands go in by the line numbers of this text
        entries = [e for e in deviations.parse(path) if e.applies_to(engine)]
        # the release measured here, and whether its bands are a further release's lines
        # (ENGINE@RELEASE where they differ from the plain ones) or the plain ones
        release = None if args.file else installed_release(adapter)
        recorded = None if args.file else deviations.measured_releases(path)
        further = (recorded is not None and release is not None and release != recorded[1][0]
                   and (release in recorded[1] or args.cases is None))
        here = [e.on_release(release if further else None) for e in entries]  # the bands that judge this release
        for fam_name in dict.fromkeys(e.family for e in entries):
            if fam_name not in families:
                print(f"{engine}: {path.name}: no family {fam_name!r}", file=sys.stderr)
        chosen = selected
        if args.file and args.cases is None:
            chosen = {f: vs for f, vs in chosen.items() if any(e.family == f for e in entries)}
        jobs = []
        for fam_name, variants in chosen.items():
            fam = families[fam_name]
            for v in variants:
                job, scene = Job(fam_name, v, engine), fam.scene(v.params)
                if adapter.capabilities.cannot_run(scene, fam.needs_of(v.params)) is None and not leaves_out(
                        adapter, fam.tags, scene, named=True, on_demand=args.on_demand, **priced(price, job)):
                    jobs.append(job)
        # the invariance battery's verdicts (cases.relations) on its default scenes, those the selection holds
        jobs += [j for j in relation_jobs([r.name for r in RELATIONS], [engine], resolver, True,
                                          on_demand=args.on_demand, price=price)
                 if any(v.id == j.variant.id for v in chosen.get(j.family, ()))]
        repeats = []
        for k in range(args.repeat):
            raised = {}
            order = jobs if k % 2 == 0 else jobs[::-1]  # another order, in new workers: history shows
            store = out / (f"known-{engine}.csv" if k == 0 else f"known-{engine}.repeat{k}.csv")
            res, _ = run_stored(order, ctx, store, COLUMNS, Execution.of(args),
                                label=f"known {engine}" + (f" (repeat {k + 1} of {args.repeat})" if k else ""),
                                on_outcome=lambda o, raised=raised: o.exception and raised.__setitem__(o.job.key,
                                                                                                        o.exception))
            if not res.complete:
                return 130
            repeats.append(({j.key: res.rows[j.key] for j in jobs}, raised))
        rows_by_job = repeats[0][0]
        measured = measured_bands(engine, here, repeats)
        new = measured.bands
        ran = {(j.family, j.variant.id) for j in jobs}
        # bands of checks this run did not measure (other engines, unselected variants) stay;
        # a band of a variant its family no longer has goes (a grid changed since it was measured)
        exists = {(name, v.id) for name, fam in families.items() for v in fam.all_variants}
        written = _release_lines if further else _plain_lines
        bands_of = {e.line: written(e, new[e.line], release,
                                    lambda b, e=e: (e.family, b.variant) in exists
                                    and (b.engine != engine or (e.family, b.variant) not in ran),
                                    lambda b, e=e: b.engine == engine and (e.family, b.variant) in ran)
                    for e in entries}
        print(f"{engine}: {path}" + (f" (release {release}: its own lines where it differs from "
                                     f"{recorded[1][0]}'s)" if further else ""))
        on = f" on {adapter.package} {release}" if further else ""
        for e in here:
            before = {(b.variant, b.metric): b for b in e.bands if b.engine == engine and (e.family, b.variant) in ran}
            # a further release: the bands that will judge it (its own lines where written, else the plain ones)
            now = replace(e, bands=tuple(bands_of[e.line])).on_release(release).bands if further else new[e.line]
            after = {(b.variant, b.metric): b for b in now if b.engine == engine and (e.family, b.variant) in ran}
            moved = [k for k in after if k in before and not before[k].holds(after[k].value, after[k].raises)]
            if not any(f == e.family and fnmatchcase(v, e.variant) for f, v in ran):
                print(f"  line {e.line} {e.pattern}: none of its variants ran here (not selected; in the "
                      "full grid: --full; on demand: --on-demand)")
                continue
            if not after and before:
                print(f"  line {e.line} {e.pattern}: no check deviates any more{on}: remove or narrow the entry")
            elif not after:
                print(f"  line {e.line} {e.pattern}: matches no deviating check on {engine}{on}")
            redrawn = [k for k in after if k in before and before[k].text() != after[k].text()]
            if set(after) != set(before) or redrawn:
                changed += 1
                print(f"  line {e.line} {e.pattern}: {len(before)} -> {len(after)} bands{on}"
                      + (f", {len(redrawn)} re-measured" if redrawn else "")
                      + (f", {len(moved)} moved out of their band" if moved else ""))
        for e, b, _ in measured.too_wide(here):
            over = b.spread_tolerances(measured.tolerance[(b.variant, b.metric)])
            print(f"  line {e.line} {e.pattern}: [{b.variant}]:{b.metric} = {b.describe()} is {over:.3g} tolerances "
                  f"wide over {args.repeat} repeats (beyond its rounding floor): if that spread is the engine's own, write '    # band: WHY' "
                  "under the entry (until then the check fails)")
        for note in measured.unsteady:
            print(f"  unsteady: {note}")
        widths = sorted(w for bs in new.values() for b in bs if b.raises is None
                        and math.isfinite(w := b.tolerances(measured.tolerance[(b.variant, b.metric)])))
        if widths:
            print(f"  {len(widths)} bands over {args.repeat} repeats: median {widths[len(widths) // 2]:.3g}, "
                  f"widest {widths[-1]:.3g} tolerances")
        # the entries the file inherits (`inherit: ENGINE`) cover their checks too: that engine's file records them
        inherited = [] if args.file else [d for d in resolver.known(engine) if d.inherited_from]
        loose = [r for rows in rows_by_job.values() for r in rows
                 if deviating(r) and deviations.find(here + inherited, r["case"], r["variant"], r["metric"]) is None]
        for r in loose:
            print(f"  unrecorded: {r['case']}[{r['variant']}]:{r['metric']} measured {float(r['measured']):.6g}, "
                  f"expected {float(r['expected']):.6g}: write an entry with its cause")
        if args.write and path.read_bytes() != as_read:
            # an edit made while the jobs ran moved the entries' lines: written by the old
            # numbers, bands would land under other entries (measured: 13 lines off)
            print(f"physval known: {path} changed while {engine} was measured: nothing written to it; the "
                  f"same command again writes from the stored rows in {out} (no job runs again)", file=sys.stderr)
            unwritten += 1
            continue
        if args.write:
            text = deviations.rewrite(path, bands_of)
            if further and release not in recorded[1]:  # every band measured on a release of its own
                text = deviations.with_measured_on(text, adapter.package, *recorded[1], release)
            elif release is not None and recorded is None and args.cases is None:  # every band, on this release
                text = deviations.with_measured_on(text, adapter.package, release)
            elif not further and recorded is not None and release is not None and release != recorded[1][0]:
                print(f"  {path.name} keeps its '# measured-on:' line: only the --cases were measured on "
                      f"{adapter.package} {release}")
            if not args.file:  # the families this run measured join those measured before
                ran_families = {j.family for j in jobs}
                text = deviations.with_families_measured(text, (deviations.families_measured(path) or set())
                                                         | ran_families)
            write_atomic(path, text)
    if not args.write and changed:
        print("(nothing written: add --write to record these bands)")
    return 1 if unwritten else 0
