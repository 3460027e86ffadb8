"""`physval real`: engines against measured tosses (the real-world tier): 400 cube tosses, or
with --data elbow_toss 541 tosses of a two-link elbow. The measurement and the report are
physval.readings.real; this module holds the options, plans each engine's fit within its
CPU budget, and says what it does as it goes."""
from __future__ import annotations

import argparse
import json
import math
import os
import sys
import tempfile
import time
from dataclasses import replace
from pathlib import Path

import numpy as np
import pandas as pd

from cases import cube_toss as ct
from physval.commands import options
from physval.core.session import Execution
from physval.readings.real import (BATCH, BOOTSTRAP, DEFAULT_OUT, DT, FIT_LIMIT, GENERATIONS, NEUTRAL, NEUTRAL_GRID,
                                   MIN_FIT_TOSSES, POPSIZE, SCORE_LIMIT, SUBSTEPS, TOSSES, Runner, _cost, _flight,
                                   engine_version, engines_3d, fit, fitted_names, noise_rows, nominal, parameter_space,
                                   rounded, sensitivity, simulate_many, toss_cost, write_report)


EPILOG = """examples:
  physval real                                   fit every 3D engine on the training split, score the test split
  physval real --engines mujoco,pybullet --workers 2
  physval real --tosses my_tosses.csv.gz --params reports/real/params.json
  physval real --tosses my_tosses.csv.gz --fit --out /tmp/mine
  physval real --limit 4 --horizon 0.3 --generations 1 --out /tmp/quick
  physval real --data elbow_toss                 the articulated elbow on every engine with revolute joints
  physval real --adapter my_engine.py:MyAdapter --engines my-engine --nominal --limit 20
every toss scored is a job in a worker process (the fit's run {batch} to a job): a job whose
worker crashes or runs over --job-timeout becomes error rows for its tosses; the run goes on.
Each finished job is kept in --cache (a row store per engine): an interrupted run resumes.
exit codes: 0 the run completed (poor agreement is a result); 2 bad input (said before any work);
1 --out could not be written at the end (the results went to the folder the message names);
130 interrupted (finished jobs are kept in --cache: the same command resumes).""".format(
    batch=BATCH)


def add_parser(sub) -> None:
    p = sub.add_parser(
        "real", help="engines against measured tosses (a cube; --data elbow_toss: a hinged elbow): fit, test, rank; "
                     "writes reports/real/",
        formatter_class=argparse.RawDescriptionHelpFormatter, epilog=EPILOG,
        description="Replay motion-captured tosses (a cube, or with --data elbow_toss two bars joined by a hinge) "
                    "on every 3D engine from their measured start states; fit each engine's contact parameters on the training split (even toss ids) and score the test "
                    "split (odd ids) at the fitted and the nominal parameters, against the data's own noise "
                    "floor. Writes real_report.md, real_scores.csv, real_summary.csv, real_fits.csv, params.json "
                    "and plots/ into --out.")
    options.add_engines(p, "engines: names or globs (default: every installed 3D engine)")
    p.add_argument("--data", choices=sorted(TOSSES), default="cube_toss",
                   help="the measured tosses: cube_toss (default; 400 tosses of a cube) or elbow_toss (541 tosses of "
                        "two bars joined by a hinge, on the engines that build revolute joints; its report goes to "
                        f"{ELBOW_OUT} unless --out says otherwise)")
    p.add_argument("--tosses", metavar="FILE",
                   help="a toss CSV (gzipped or not) with the packaged data's columns (default: the packaged data)")
    how = p.add_mutually_exclusive_group()
    how.add_argument("--params", metavar="FILE",
                     help="parameters per engine as JSON {engine: {name: value}} (params.json of a run); no fit. "
                          "With --tosses every toss of the file is scored")
    how.add_argument("--fit", action="store_true", help="fit on the training split (the default without --params)")
    how.add_argument("--nominal", action="store_true", help="score the nominal parameters only (no fit)")
    options.add_execution(p, str(DEFAULT_OUT))
    p.add_argument("--cache", metavar="DIR", help="where finished simulations are kept, a row store per engine, "
                                                  "and read back by the next run (default: real/ in physval's cache "
                                                  "folder, $PHYSVAL_CACHE_DIR or ~/.cache/physval)")
    p.add_argument("--no-cache", action="store_true", help="simulate everything again, keep nothing")
    p.add_argument("--limit", type=options.positive_int, metavar="N",
                   help="only the first N tosses of each split (quick runs)")
    p.add_argument("--horizon", type=options.positive_float, metavar="S",
                   help="simulate at most S seconds from the start (quick runs)")
    p.add_argument("--popsize", type=options.positive_int, default=POPSIZE, metavar="N",
                   help=f"differential evolution popsize (default {POPSIZE})")
    p.add_argument("--generations", type=options.whole_number, default=GENERATIONS, metavar="N",
                   help=f"differential evolution generations after the first (default {GENERATIONS})")
    p.add_argument("--bootstrap", type=options.positive_int, default=BOOTSTRAP, metavar="N",
                   help=f"resamples of the training tosses for the parameters' spread (default {BOOTSTRAP})")
    p.add_argument("--fit-limit", type=_fit_limit, action="append", default=[], metavar="[ENGINE=]S",
                   help=f"CPU seconds per engine for its fit: slower engines fit on an evenly spread subset of the "
                        f"training tosses (at least {MIN_FIT_TOSSES}; else nominal only); default {FIT_LIMIT:g}. "
                        f"ENGINE=S (a name or glob; repeatable) sets the budget of those engines alone, e.g. "
                        f"'reference*=900' for the reference's formulations")
    p.add_argument("--score-limit", type=options.positive_float, default=SCORE_LIMIT, metavar="S",
                   help=f"score an evenly spread subset of the test tosses on engines that would take longer than "
                        f"S CPU seconds per parameter set over all of them (default {SCORE_LIMIT:g})")


ELBOW_OUT = DEFAULT_OUT.parent / "real_elbow"


def _fit_limit(text: str) -> tuple[str | None, float]:
    """--fit-limit's value: (engine glob or None for every engine, CPU seconds)."""
    engine, equals, seconds = text.rpartition("=")
    if equals and not engine:
        raise argparse.ArgumentTypeError(f"{text!r}: give an engine name or glob before '=' (ENGINE=S)")
    return (engine or None), options.positive_float(seconds)


def fit_limit(engine: str, limits: list[tuple[str | None, float]]) -> float:
    """The fit budget of `engine`: the last ENGINE=S whose glob matches it, else the last
    plain S, else FIT_LIMIT."""
    from fnmatch import fnmatchcase
    own = [seconds for glob, seconds in limits if glob is not None and fnmatchcase(engine, glob)]
    return (own or _plain(limits))[-1]


def _plain(limits: list[tuple[str | None, float]]) -> list[float]:
    """The plain --fit-limit values given, or the default."""
    return [seconds for glob, seconds in limits if glob is None] or [FIT_LIMIT]


def _fit_plan(engine: str, nominal_rows: list[dict], train: list[int], args, ctx) -> tuple[str, list[int], int]:
    """(why not fit, or ""; the training tosses to fit on; one in how many training tosses). An engine that fails on most
    tosses at nominal parameters is not fitted (the fit would measure its failures); one
    whose fit over the whole training split would cost more than --fit-limit CPU seconds
    (estimated from its nominal tosses) fits on an evenly spread subset of it, if that
    keeps at least MIN_FIT_TOSSES tosses."""
    if not train:
        return "no training tosses (even ids) to fit on", [], 0
    failed = sum(r["status"] != "ok" for r in nominal_rows)
    if failed > len(nominal_rows) / 2:
        return f"fails on {failed} of {len(nominal_rows)} test tosses at nominal parameters", [], 0
    per_toss = float(np.median([r["elapsed_cpu"] for r in nominal_rows]))
    evaluations = args.popsize * len(fitted_names(engine, ctx)) * (args.generations + 1)
    estimate = per_toss * evaluations * len(train)
    limit = fit_limit(engine, args.fit_limit)
    if estimate <= limit:
        return "", list(train), 1
    every = math.ceil(estimate / limit)
    part = list(train[::every])
    if len(part) < MIN_FIT_TOSSES:
        return (f"one toss costs {per_toss:.2g} CPU s, so even {MIN_FIT_TOSSES} training tosses x {evaluations} "
                f"parameter sets would take {per_toss * evaluations * MIN_FIT_TOSSES / 3600:.2g} h "
                f"(> its --fit-limit {limit:g} s)"), [], every
    return "", part, every


def default_cache() -> Path:
    from physval.core.store import cache_dir
    return cache_dir() / "real"


def read_params(path: str, engines: list[str], known_engines: list[str], ctx,
                family: str = "cube_toss") -> dict[str, dict]:
    """{engine: parameters} from a --params file for the run's `engines`, every value checked
    against the engine's parameter space before any work; what a fit wrote is taken back as
    it is (inf for a parameter whose range is unbounded, held at that default). The file's
    engines outside the run (another selection, an engine not installed here) are left
    out, named in one line on stderr; a name that is no engine at all stops the command."""
    try:
        given = json.loads(Path(path).read_text())
    except (OSError, ValueError) as exc:
        raise options.UsageError(f"--params {path}: cannot read it as JSON ({exc})") from None
    if not isinstance(given, dict) or not all(isinstance(v, dict) for v in given.values()):
        raise options.UsageError(f"--params {path}: must be a JSON object {{engine: {{parameter: value}}}}")
    for engine in given:
        if engine not in known_engines:
            raise options.UsageError(f"--params {path}: {engine!r} is not an engine: choose from "
                                     f"{', '.join(known_engines)}")
    outside = [e for e in given if e not in engines]
    if outside:
        print(f"physval real: --params {path}: the parameters of {len(outside)} engine(s) outside this run left "
              f"out: {', '.join(outside)}", file=sys.stderr)
    given = {e: p for e, p in given.items() if e in engines}
    for engine, params in given.items():
        space = parameter_space(engine, ctx, family)
        for name, value in params.items():
            at = f"--params {path}: {engine} {name}"
            if name not in space:
                raise options.UsageError(f"{at}: not a parameter of {engine}; it takes {', '.join(space)}")
            t = space[name]
            if isinstance(value, bool) or not isinstance(value, (int, float)) or not t.low <= value <= t.high:
                raise options.UsageError(f"{at} = {value!r}: must be a number in [{t.low:g}, {t.high:g}] "
                                         f"({t.meaning})")
    return {e: rounded(e, p, ctx, family) for e, p in given.items()}


def _cpu_seconds() -> float:
    """CPU time of this process (its workers' is the runner's `worker_cpu_s`: under the
    forkserver start method they are no children of this process)."""
    import resource
    own = resource.getrusage(resource.RUSAGE_SELF)
    return own.ru_utime + own.ru_stime


def run(args) -> int:
    """Fit and score; write the report."""
    started, started_cpu = time.perf_counter(), _cpu_seconds()

    say = options.teller(args, "physval real")

    ctx = options.context_of(args)
    family, ds = args.data, TOSSES[args.data]
    if family == "elbow_toss" and args.out == str(DEFAULT_OUT):
        args.out = str(ELBOW_OUT)
    source = str(Path(args.tosses).resolve()) if args.tosses else None
    try:
        tosses = ds.load(source)
    except ct.TossError as exc:
        raise options.UsageError(f"--tosses {args.tosses}: {exc}") from None
    except OSError as exc:
        raise options.UsageError(f"--tosses {args.tosses}: cannot be read ({exc.strerror or exc})") from None
    from adapters import registry
    engines, skipped = engines_3d(options.engines_of(args, ctx) if args.engines else None, ctx, family)
    if not engines:
        raise options.UsageError("no engine to score: " + "; ".join(f"{e}: {w}" for e, w in skipped.items()))
    from fnmatch import fnmatchcase
    for glob, seconds in args.fit_limit:  # a budget for no engine of the run is a typo or a wrong selection
        if glob is not None and not any(fnmatchcase(e, glob) for e in engines):
            raise options.UsageError(f"--fit-limit {glob}={seconds:g}: {glob!r} matches none of this run's engines "
                                     f"({', '.join(engines)})")
    given = read_params(args.params, engines, registry.engine_names(ctx.adapters), ctx, family) if args.params else {}
    do_fit = not args.params and not args.nominal
    out = options.held(args, options.output_folder(args.out))  # input checked: the folders, then the work
    cache = None if args.no_cache else str(options.output_folder(args.cache or str(default_cache()), "--cache"))
    options.check_scheduler(args.scheduler)

    usable, unusable = [], {}
    for i in tosses:
        try:
            _flight(source, i, family)
            usable.append(i)
        except ct.TossError as exc:
            unusable[i] = str(exc)
    train, test = ds.split(usable)
    if source and args.params:
        train, test = [], sorted(usable)  # a user's own tosses, scored with saved parameters
    if not test:
        raise options.UsageError(f"no test tosses (odd ids) in {source or ds.DATA}")
    if args.limit:
        train, test = train[:args.limit], test[:args.limit]
    common = {"horizon": args.horizon, "dt": DT, "source": source, "ctx": ctx, "family": family}
    say(f"{len(train)} training and {len(test)} test tosses from {source or 'the packaged data'}; "
        f"engines {', '.join(engines)}" + (f" (skipped: {', '.join(skipped)})" if skipped else ""))

    rows, trajectories, fits, not_fitted, failures, subsets, cost = [], {}, {}, {}, [], {}, []
    # every simulation a job of the core, on one executor for the whole command
    runner = args.held.enter_context(Runner(ctx, replace(Execution.of(args), progress=False), cache))
    for engine in engines:
        runner.store(engine)  # each engine's store read (or refused) before any work
    for engine in engines:
        t0 = time.perf_counter()
        # priced from one toss more than there are workers: at least one runs in a worker
        # that has started the engine already (toss_cost)
        probe = test[:max(1, runner.execution.workers or 1) + 1]
        nom = simulate_many(engine, nominal(engine, ctx, family), probe, runner=runner, keep=True, **common)
        if nom[0]["status"] == "unsupported":
            skipped[engine] = nom[0]["message"]
            say(f"  {engine}: unsupported ({nom[0]['message']})")
            continue
        per_toss = toss_cost(nom)
        scored = test
        if per_toss * len(test) > args.score_limit:
            every = math.ceil(per_toss * len(test) / args.score_limit)
            scored = test[::every]
            subsets[engine] = (f"one toss costs {per_toss:.2g} CPU s: scored on one test toss in {every} "
                               f"({len(scored)} of {len(test)}; --score-limit {args.score_limit:g} s)")
            say(f"  {engine}: {subsets[engine]}")
        nom = [r for r in nom if r["toss"] in scored] + simulate_many(
            engine, nominal(engine, ctx, family), [t for t in scored if t not in probe], runner=runner, keep=True,
            **common)
        params = None
        if engine in given:
            params = given[engine]
        elif do_fit:
            why, part, every = _fit_plan(engine, nom, train, args, ctx)
            if why:
                not_fitted[engine] = why
                say(f"  {engine}: nominal only: {why}")
            else:
                say(f"  {engine}: fitting {', '.join(fitted_names(engine, ctx))} on {len(part)} tosses")
                f = fit(engine, part, runner=runner, popsize=args.popsize, generations=args.generations,
                        **common)
                fits[engine] = {"params": f.params, "names": list(f.names), "loss": f.loss,
                                "nominal_loss": f.nominal_loss, "evaluations": f.evaluations,
                                "tosses": len(f.tosses), "seconds": f.seconds,
                                "spread": f.bootstrap(args.bootstrap),
                                "subset": (f"one training toss in {every}, {len(part)} of {len(train)}: the "
                                           f"whole split would cost more than --fit-limit" if every > 1 else "")}
                cost.append(f.cost)
                params = f.params
        else:
            not_fitted[engine] = "no parameters given for it" if args.params else "--nominal"
        for r in nom:
            r["param_set"] = "nominal"
        sets = [("nominal", nom)]
        if params is not None:
            fitted_rows = simulate_many(engine, params, scored, runner=runner, keep=True, **common)
            for r in fitted_rows:
                r["param_set"] = "fitted"
            sets.append(("fitted", fitted_rows))
            if engine in given:
                fits[engine] = {"params": params, "names": list(params), "spread": []}
        for pset, rs in sets:
            for r in rs:
                tr, fl = _flight(source, r["toss"], family)
                r["t_contact"] = float(tr.t[fl.contact] - fl.t0)
                r["split"] = "test"
            bad = [r for r in rs if r["status"] != "ok"]
            if bad:
                kinds = pd.Series([r["status"] for r in bad]).value_counts().to_dict()
                failures.append(f"{engine} ({pset}): {len(bad)} of {len(rs)} tosses "
                                f"({', '.join(f'{n} {k}' for k, n in kinds.items())}); first, toss "
                                f"{bad[0]['toss']}: {bad[0]['message'][:200]}")
            trajectories[(engine, pset)] = rs
            rows += rs
        # how far the capture's noise in the start state alone carries this engine, on the
        # tosses its simulation from the fitted start completed (the others have no reference)
        best = sets[-1]
        completed = [r["toss"] for r in best[1] if r["status"] == "ok"]
        shaken = simulate_many(engine, params or nominal(engine, ctx, family), completed, runner=runner, keep=True,
                               perturb=True, **common)
        floor = sensitivity(best[1], shaken, source, family)
        trajectories[(engine, "start noise")] = floor
        rows += floor
        cost.append(_cost(nom + sum((rs for p, rs in sets[1:]), []) + shaken))
        say(f"  {engine}: done in {time.perf_counter() - t0:.0f} s")
    runner.close()

    scores = pd.DataFrame([{k: v for k, v in r.items() if k != "trajectory"} for r in rows])
    sims = {k: sum(c[k] for c in cost) for k in ("computed", "cached", "cpu")}
    noise = noise_rows(test, source, args.horizon, family)
    noise_table = _noise_text(pd.DataFrame(noise), len(test), ct.rest_tilt(tosses, test) if ds is ct else None, ds)
    notes = {
        "family": family,
        "intro": _intro(source, train, test, unusable, ds),
        "fit": _fit_text(args, do_fit, ds),
        "not_fitted": not_fitted,
        "subsets": subsets,
        "nominal": {e: nominal(e, ctx, family) for e in engines},
        "noise": noise_table,
        "failures": failures,
        "run": (f"Simulations: {sims['computed'] + sims['cached']} ({sims['computed']} computed in this run, "
                f"{sims['cached']} read back from the row store), costing {sims['cpu']:.0f} CPU s when computed (build and "
                f"stepping, each measured as it ran): about {sims['cpu'] / 2 / 60:.0f} min on two free cores. "
                f"This run: {time.perf_counter() - started:.0f} s with {args.workers} worker(s) "
                f"({_cpu_seconds() - started_cpu:.0f} CPU s in this process, {runner.worker_cpu_s:.0f} in its worker "
                f"processes; "
                f"machine load average {os.getloadavg()[0]:.1f} on {os.cpu_count()} cores at the end)"
                f"{' on ' + args.scheduler if args.scheduler else ''}; dt = {DT * 1e3:.4f} ms ({SUBSTEPS} steps per "
                f"sample); row store {'off' if not cache else 'on'}; engine versions: "
                + ", ".join(f"{e} {engine_version(e, ctx)}" for e in engines if e not in skipped) + "; command: "
                + " ".join(["physval"] + sys.argv[1:])),
    }
    try:
        path = write_report(out, scores, noise, trajectories, fits, skipped, notes, source)
    except OSError as exc:  # --out went away or filled up during the run: keep the results elsewhere
        rescue = Path(tempfile.mkdtemp(prefix="physval-real-"))
        write_report(rescue, scores, noise, trajectories, fits, skipped, notes, source)
        print(f"physval real: error: cannot write to --out {args.out} ({exc.strerror or exc}); the report and "
              f"every result are in {rescue} instead", file=sys.stderr)
        return 1
    say(f"wrote {path} in {time.perf_counter() - started:.0f} s")
    return 0


def _intro(source, train, test, unusable, ds=ct) -> str:
    if ds is ct:
        data = (f"`{source}`" if source else
                "the packaged ContactNets cube tosses (`cases/data/cube_toss/`: 400 motion-captured tosses of one "
                "acrylic cube, 10.48 cm, 0.37 kg, onto one surface, sampled at 148 Hz; BSD 3-Clause)")
        start = ("its free flight fitted up to the sample just before first contact (a parabola for the centre, a "
                 "constant world-frame spin for the orientation: exact for a free cube), with the ground "
                 f"{abs(ct.SURFACE_Z) * 1e3:.2f} mm below the data's z = 0 (the resting cubes' centres say so)")
    else:
        data = (f"`{source}`" if source else
                "the packaged DAIR elbow tosses (`cases/data/elbow_toss/`: 541 motion-captured tosses of two "
                "10 x 5 x 5 cm bars of 0.37 kg joined by a hinge, onto one surface, sampled at 148 Hz; BSD 3-Clause). "
                "Errors are of the base link's centre and orientation, and of all 16 corners of both links (in bar "
                "lengths, 10 cm); 'right face' means both links end on the measured face")
        start = (f"a quadratic fitted over the {ds.FIT_SAMPLES} samples up to the one just before first contact "
                 "(base position and orientation, hinge angle), with the ground at the data's z = 0 (where every "
                 "toss's final lowest corner lies)")
    text = (f"Data: {data}. Each toss starts from {start}, and runs to the toss's last sample at "
            f"dt = {DT * 1e3:.3f} ms. "
            f"Split: even toss ids train ({len(train)} tosses), odd ids test ({len(test)}). Horizons count "
            f"from the first measured sample in contact.")
    if unusable:
        text += f" Tosses left out ({len(unusable)}): " + "; ".join(f"{i}: {w}" for i, w in unusable.items())
    return text


def _fit_text(args, do_fit, ds=ct) -> str:
    if not do_fit:
        return "Parameters were given (--params) or not fitted (--nominal)."
    spread = (f" Uncertainty: {args.bootstrap} bootstrap resamples of the training tosses, each taking the best of "
              "the parameter sets the fit evaluated (their per-toss losses are kept; no further simulation).")
    return (f"Differential evolution (scipy), popsize {args.popsize} per parameter, {args.generations} generations "
            f"after the first, seed 0, the nominal point in the first generation; loss: the mean over training "
            f"tosses of each toss's mean corner error ({ds.UNIT_NAME}); mu and e on a {NEUTRAL_GRID} grid, bounds "
            + ", ".join(f"{n} [{t.low:g}, {t.high:g}]" for n, t in NEUTRAL.items())
            + "; engine-specific ones in their adapter's range (MuJoCo's contact_steps: the contact lasts about "
            "that many steps; its solref follows from it and e). An engine whose fit over the whole training split "
            f"would cost more than {_limits_text(args.fit_limit)} (estimated from its nominal tosses) fits on every "
            f"k-th training toss, if that leaves at least {MIN_FIT_TOSSES}." + spread)


def _limits_text(limits: list[tuple[str | None, float]]) -> str:
    """--fit-limit in words: 'S CPU s' and the engines given budgets of their own."""
    own = {glob: seconds for glob, seconds in limits if glob is not None}
    return f"{_plain(limits)[-1]:g} CPU s" + "".join(
        f" ({glob}: {seconds:g} CPU s)" for glob, seconds in own.items())


def _noise_text(noise: pd.DataFrame, n: int, tilt: float | None, ds=ct) -> str:
    if noise.empty:
        return ""
    def q(column):  # median and 95th percentile over the tosses that have the reading
        v = noise[column].dropna()
        return np.percentile(v, [50, 95]) if len(v) else (math.nan, math.nan)

    unit = ds.UNIT_NAME
    text = (f"The measured trajectory against itself smoothed (a quadratic least-squares fit over 5 samples, "
            f"{4 * ct.SAMPLE_PERIOD * 1e3:.0f} ms: Savitzky-Golay), scored by the same code as the engines over the {n} test tosses: "
            f"mean corner error median {q('corner_mean')[0]:.3g} {unit} (95th percentile {q('corner_mean')[1]:.3g}); "
            f"centre {q('pos_final')[0]:.2g} {unit} and orientation {q('rot_final')[0]:.2g} deg at rest. ")
    if ds is not ct:
        return text + (f"The {ds.FIT_SAMPLES} samples of the start fit depart from it by {q('flight_pos_mm')[0]:.2g} mm "
                       f"and {q('flight_rot_deg')[0]:.2g} deg RMS (median over tosses; 95th percentile "
                       f"{q('flight_pos_mm')[1]:.2g} mm, {q('flight_rot_deg')[1]:.2g} deg): the start state is known "
                       "to about that.")
    return text + (
            f"The free flight before the first contact departs from its exact free-flight fit by "
            f"{q('flight_pos_mm')[0]:.2g} mm and {q('flight_rot_deg')[0]:.2g} deg RMS (median over tosses; 95th "
            f"percentile {q('flight_pos_mm')[1]:.2g} mm, {q('flight_rot_deg')[1]:.2g} deg): the start state is known "
            f"to about that. Resting cubes read {abs(ct.SURFACE_Z) * 1e3:.2f} mm lower than the half-width (the "
            f"surface offset every scene takes) and tilted by {math.degrees(tilt):.2g} deg (median of the final samples), "
            f"so orientation errors at rest below about {math.degrees(tilt):.2g} deg and centre errors below about "
            f"0.01 widths are within the data's precision.")
