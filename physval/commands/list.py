"""`physval list`: the case families (variants, effects, which engines can run each), or with
--engines one engine per line: its version, where it comes from, the shapes it represents
(cases.scene kinds; a scene with another is `unsupported` there) and its other capabilities."""
from __future__ import annotations

from physval.commands import options


def add_parser(sub) -> None:
    p = sub.add_parser("list", help="list case families and engines", description=__doc__.split(":", 1)[1].strip())
    p.add_argument("--engines", action="store_true", help="list engines and their capabilities")
    p.add_argument("--cases-dir", action="append", metavar="DIR", help="also load case families from DIR")
    p.add_argument("--adapter", action="append", metavar="MODULE:CLASS", help="also list this adapter")


def run(args) -> int:
    from adapters import registry
    ctx = options.context_of(args)
    specs = registry.specs(ctx.adapters)
    if args.engines:
        for name, spec in specs.items():
            try:
                a = registry.get(name, ctx.adapters)
                caps = a.capabilities
                print(f"{name}\t{a.version()}\t{spec.origin}\tshapes: {', '.join(sorted(caps.shapes))}\t"
                      f"{caps.describe()}")
            except registry.EngineError as exc:
                print(f"{name}\tnot installed\t{spec.origin}\tshapes: -\t{exc}")
        return 0
    fams = {n: ctx.resolver().family(n) for n in options.cases_of(args, ctx.resolver())}
    adapters = {}
    for name in specs:
        try:
            adapters[name] = registry.get(name, ctx.adapters)
        except registry.EngineError:
            pass
    for fam in fams.values():
        tags = f" [{', '.join(sorted(fam.tags))}]" if fam.tags else ""
        print(f"{fam.name}{tags}: {fam.summary}")
        print(f"  closed form: {fam.source}; default dt {fam.dt:g} s" if not callable(fam.dt) else
              f"  closed form: {fam.source}; dt per variant")
        for v in fam.variants:
            scene, needs = fam.scene(v.params), fam.needs_of(v.params)  # once a variant, not once an engine
            can = [n for n, a in adapters.items() if a.capabilities.cannot_run(scene, needs) is None]
            print(f"  [{v.id}]  effects: {','.join(sorted(scene.effects))}  engines: {','.join(can) or 'none'}")
        if fam.full_grid:
            print(f"  (+{len(fam.all_variants) - len(fam.variants)} variants with --full)")
    return 0
