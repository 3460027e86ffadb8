"""The dry run of a user's case family: every variant one step on the reference, observed,
so that a family whose scene, expectations or observer cannot work stops with one line
before a run spends any time on it (`physval check-case`, and `physval run --cases-dir`).
"""
from __future__ import annotations

from adapters import registry
from adapters.base import Settings
from cases.family import CaseError, CaseFamily
from physval.core.jobs import describe
from physval.core.record import simulate

DRY_RUN_ENGINE = "reference"


def dry_run(fam: CaseFamily, where: str, variants=None) -> list[tuple[str, dict]]:
    """Run each variant one step on the reference and observe it: [(variant id, values)].
    Raises CaseError naming `where`, the variant and what went wrong."""
    adapter = registry.get(DRY_RUN_ENGINE)
    out = []
    for v in variants or fam.variants:
        at = f"{where}: {fam.name}[{v.id}]"
        scene = fam.scene(v.params)
        dt = fam.dt_for(v.params)
        checks = fam.expect(v.params, dt)
        if adapter.capabilities.cannot_run(scene):
            out.append((v.id, {}))
            continue
        try:
            with adapter.build(scene, Settings(dt=dt)) as sim:
                traj = simulate(sim, scene, dt, 1, forces="contact_forces" in fam.needs_of(v.params)).trajectory
        except Exception as exc:
            raise CaseError(f"{at}: one step on the reference failed: {describe(exc)}") from None
        try:
            values = fam.observe(traj, v.params)
        except Exception as exc:
            raise CaseError(f"{at}: observe() raised {describe(exc)} on a one-step run: an observer must give "
                            "every check a value whatever the engine did (the check then fails with a size)") from None
        if not hasattr(values, "get"):
            raise CaseError(f"{at}: observe() returned {type(values).__name__}, not a dict of metrics")
        missing = [c.metric for c in checks if c.metric not in values]
        if missing:
            raise CaseError(f"{at}: observe() gives no {', '.join(missing)} (expect() checks it)")
        out.append((v.id, values))
    return out


def dry_run_user_families(ctx) -> None:
    """The dry run of every family loaded from the run's --cases-dir folders."""
    from cases.registry import builtin_families
    builtin = builtin_families()
    for name, fam in ctx.resolver().families.items():
        if name not in builtin:
            dry_run(fam, fam.module_file)


