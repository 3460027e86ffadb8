"""`physval versions ENGINE RELEASE RELEASE ...`: the same run on several releases of an
engine, each in an environment of its own (physval.core.envs: made once, cached), then
`physval compare` of each consecutive pair of releases and of the first and the last."""
from __future__ import annotations

import argparse
import subprocess
import sys
import time
from pathlib import Path

from physval.commands import options
from physval.commands.compare import add_options, compare_runs
from physval.readings.compare import changed, summary_line

EPILOG = """examples:
  physval versions mujoco 3.3.7 3.12.0 4.0.0 --cases resting_blocks
  physval versions pymunk 7.0.0 7.3.1 --engines pymunk --save-trajectories
  physval versions newton 1.7.0 1.8.0 --engines newton-xpbd --cases conformance
  physval versions drake 1.51.1 1.58.0@3.12 --engines drake --cases central_impact
    (a release on another Python: Drake publishes 1.52 and later for Python 3.12 and newer;
    `--python 3.12` puts every release on it; a version finds python3.12 on PATH, or give a path)
exit codes: 0 nothing changed between the releases; 1 something changed; 2 bad input (an
unknown engine or release, a release outside the adapter's supported range, a release pip
cannot install); 130 interrupted (the same command resumes: environments and finished jobs
are kept)."""


def add_parser(sub) -> None:
    vs = sub.add_parser(
        "versions", help="the same run on several releases of an engine, each in its own environment, compared",
        formatter_class=argparse.RawDescriptionHelpFormatter, epilog=EPILOG,
        description="For each RELEASE of ENGINE's package: a virtual environment holding that release (made once, "
                    "cached under physval's cache folder, envs/), in which `physval run` runs the selection with "
                    "this very physval; then `physval compare` of each consecutive pair of releases (sorted) and of "
                    "the first and the last. Writes OUT/ENGINE/RELEASE/ (each run), OUT/ENGINE/compare/A-vs-B/ and "
                    "OUT/ENGINE/versions.md.")
    vs.add_argument("engine", metavar="ENGINE", help="the engine whose releases to run (e.g. mujoco), or the package "
                                                     "its configurations share (e.g. newton)")
    vs.add_argument("releases", nargs="+", metavar="RELEASE",
                    help="two or more releases of its package (e.g. 3.3.7); RELEASE@PYTHON runs that release on "
                         "another Python (e.g. 1.58.0@3.12)")
    vs.add_argument("--python", metavar="PYTHON",
                    help="make the releases' environments with this Python (a version such as 3.12, found on PATH as "
                         "python3.12, or an interpreter's path) instead of physval's own; physval's requirements are "
                         "installed there too")
    options.add_selection(vs, "case families or variants, the grammar of `physval run --cases` (default: every "
                              "family the engine runs)",
                          "the engine's configurations to run (engines sharing its package, e.g. pybullet-rigid; "
                          "default: all of them)")
    vs.add_argument("--dt", type=options.positive_float, metavar="DT", help="time step in s for every case")
    vs.add_argument("--iterations", type=options.positive_int, metavar="N", help="solver iterations")
    vs.add_argument("--on-demand", action="store_true",
                    help="also the runs the engine declares too slow for a default run, in each release (Newton's "
                         "solvers beyond their core families)")
    vs.add_argument("--save-trajectories", action="store_true",
                    help="save every job's trajectory (OUT/ENGINE/RELEASE/trajectories/) and find where the releases "
                         "part")
    add_options(vs)
    options.add_execution(vs, "reports/versions", scheduler=False)


def pythons_of(texts: list[str], default: str | None) -> tuple[list[str], dict[str, str | None]]:
    """RELEASE@PYTHON words split: the releases, and the Python each names (else `default`)."""
    releases, pythons = [], {}
    for text in texts:
        release, _, python = text.partition("@")
        if _ and not python:
            raise options.UsageError(f"release {text}: name a Python after @ (e.g. {release}@3.12)")
        releases.append(release)
        pythons[release] = python or default
    return releases, pythons


def releases_of(adapter, texts: list[str]) -> list[str]:
    """The releases, sorted, each checked against the adapter's supported range."""
    from packaging.version import InvalidVersion, Version
    from adapters.registry import range_problem
    if adapter.supported is None:
        raise options.UsageError(f"engine {adapter.name} declares no releases of its own (Adapter.supported is "
                                 "None): nothing to install")
    try:
        parsed = {t: Version(t) for t in texts}
    except InvalidVersion as exc:
        raise options.UsageError(f"{exc}: a release reads like 3.3.7") from None
    if len(set(parsed.values())) != len(texts):
        raise options.UsageError(f"releases {' '.join(texts)}: each release once")
    if len(texts) < 2:
        raise options.UsageError("name at least two releases to compare")
    for t in texts:
        problem = range_problem(adapter, t)
        if problem:
            raise options.UsageError(problem)
    return sorted(texts, key=parsed.get)


def packages(ctx) -> dict[str, str]:
    """Each engine installed here, and the package its adapter installs."""
    from adapters import registry
    resolver, found = ctx.resolver(), {}
    for name in registry.engine_names(ctx.adapters):
        try:
            found[name] = resolver.adapter(name).package
        except Exception:  # not installed here
            continue
    return found


def engine_of(name: str, ctx) -> str:
    """ENGINE as named: an engine, or the package its configurations share (`newton`:
    newton-xpbd, newton-vbd, ...), for which the first of them stands; an unknown name is
    returned as it is, for the resolver to say so with the engines to choose from."""
    from adapters import registry
    if name in registry.engine_names(ctx.adapters):
        return name
    return next((e for e, package in packages(ctx).items() if package == name), name)


def configurations(engine: str, ctx) -> list[str]:
    """The engines whose adapter installs the same package as `engine`'s."""
    package = ctx.resolver().adapter(engine).package
    return [e for e, p in packages(ctx).items() if p == package]


def run_command(args, engines: list[str], out: Path) -> list[str]:
    """The `physval run` arguments of one release's run into `out`."""
    words = ["-m", "physval", "run", "--engines", *engines, "--out", str(out.resolve()), "--readings", "none",
             "--workers", str(args.workers), "--job-timeout", str(args.job_timeout)]
    if args.cases:
        words += ["--cases", *args.cases]
    for flag, values in (("--cases-dir", args.cases_dir), ("--known", args.known), ("--adapter", args.adapter)):
        for v in values or []:
            words += [flag, str(Path(v).resolve()) if flag != "--adapter" else v]
    for flag, value in (("--dt", args.dt), ("--iterations", args.iterations), ("--start-method", args.start_method)):
        if value is not None:
            words += [flag, str(value)]
    if args.on_demand:
        words.append("--on-demand")
    if args.save_trajectories:
        words += ["--save-trajectories", str((out / "trajectories").resolve())]
    return words + (["--quiet"] if args.quiet else [])


def check_release(folder: Path, release: str, engines: list[str]) -> None:
    """Every row of the run in `folder` names `release` in its engine_version (the
    environment ran the release it was made for)."""
    from packaging.version import InvalidVersion, Version
    from physval.readings.compare import load

    def names(text: str) -> bool:
        for word in text.replace("(", " ").replace(")", " ").split():
            try:
                if Version(word) == Version(release):
                    return True
            except InvalidVersion:
                continue
        return False
    df = load(folder)
    wrong = df[df.engine.isin(engines) & ~df.engine_version.map(names)]
    if len(wrong):
        first = wrong.iloc[0]
        raise options.UsageError(f"the run in {folder} reports {first.engine} {first.engine_version!r}, "
                                 f"not release {release}")


def run(args) -> int:
    from physval.core import envs
    from physval.core.selection import select_engines, select_variants
    from physval.readings import versions
    ctx = options.context_of(args)
    resolver = ctx.resolver()
    engine = engine_of(args.engine, ctx)
    adapter = resolver.adapter(engine)  # EngineError: unknown, or not installed here
    texts, pythons = pythons_of(args.releases, args.python)
    releases = releases_of(adapter, texts)
    try:  # each Python named exists and starts, before any environment is made
        interpreters = {p: envs.interpreter(p) for p in set(pythons.values())}
    except envs.EnvError as exc:
        raise options.UsageError(str(exc)) from None
    known = configurations(engine, ctx)
    engines = select_engines(args.engines, known, known)
    if args.cases:
        select_variants(resolver.families, args.cases)  # a spec that selects nothing stops here
    if args.dt is not None:
        from adapters.base import Settings
        Settings(dt=args.dt)
    out = options.held(args, options.output_folder(str(Path(args.out) / args.engine)))
    say = options.teller(args, "physval versions")
    rows = []
    for release in releases:
        started = time.monotonic()
        try:
            env = envs.ensure(adapter.release_requirements(release), say, interpreters[pythons[release]])
        except envs.EnvError as exc:
            raise options.UsageError(str(exc)) from None
        say(f"{adapter.package} {release} (Python {env.python.short}): environment "
            f"{'made' if env.created else 'from the cache'} in "
            f"{time.monotonic() - started:.1f} s; running {', '.join(engines)}")
        folder = out / release
        started = time.monotonic()
        done = subprocess.run(env.command(*run_command(args, engines, folder)), env=env.environ())
        if done.returncode:
            print(f"physval versions: the run on {adapter.package} {release} stopped with exit code "
                  f"{done.returncode}; the same command resumes it", file=sys.stderr)
            return done.returncode if done.returncode in (2, 130) else 2
        check_release(folder, release, engines)
        rows.append(versions.Release(release, env, time.monotonic() - started, folder))
    pairs = list(zip(releases, releases[1:])) + ([(releases[0], releases[-1])] if len(releases) > 2 else [])
    compared = []
    for a, b in pairs:
        trajectories = (out / a / "trajectories", out / b / "trajectories") if args.save_trajectories else None
        table, parts, _ = compare_runs(out / a, out / b, str(out / "compare" / f"{a}-vs-{b}"), args.threshold,
                                       trajectories, options.command_line())
        compared.append((a, b, table, parts))
    versions.write(out, adapter.package, engines, rows, compared, args.threshold, options.command_line())
    for a, b, table, _ in compared:
        print(f"{a} -> {b}: {summary_line(table, args.threshold)}")
    print(f"wrote {out / 'versions.md'}")
    return 1 if any(changed(t) for _, _, t, _ in compared) else 0
