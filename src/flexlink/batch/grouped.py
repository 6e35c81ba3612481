"""A worker's prescribed-joint Lawson cases integrated together where they share their
output times and steps (solvers/lawson_batch.py), before each case's channels are read as in
its own run.

Each case builds its own system and table (`prescribed.prescribed_system`,
`lawson.prepare`) exactly as its single run does; their block exponentials are computed
together, a few numpy calls for the chunk (`lawson_batch.with_propagators`), each the same
as its single run's. Cases with the same output times and steps per interval — variants
of one scenario's numbers (stiffness, masses, damping, a motion's amplitude or timing), each
on its own table — then cross their first pass in one compiled call, groups of at least
`lawson_batch.MIN_GROUP`; the rest run theirs alone. Each
case then finishes alone (its own Richardson check and halvings) and its run takes that
system and solution (`simulation.run_scenario`'s ``prescribed``): its channels equal its
single `simulate`'s bit for bit (tests/unit/test_lawson_batch.py).

A case that is not a prescribed Lawson run, that has links made rigid, that equals the one
before it but for its sensors (its run is shared, `runner.CaseRunner`), or whose preparation
raises is left to its own run, which then reports any error as a single run would.
"""

from __future__ import annotations

import time
from collections.abc import Sequence
from typing import TYPE_CHECKING

import numpy as np

from ..model import Scenario
from .runner import Integrated, equal_but_sensors

if TYPE_CHECKING:
    from ..dynamics.prescribed_kernel import CompiledFirstOrderSystem


def integrate_together(scenarios: Sequence[Scenario | None]) -> dict[int, Integrated]:
    """The integrations of the cases (None: a case that failed to build) that can run
    together, by index in ``scenarios``; none if fewer than `lawson_batch.MIN_GROUP` could."""
    from ..simulation import model_path
    from ..simulation.common import output_times
    from ..solvers.lawson_batch import MIN_GROUP

    candidates = [i for i, s in enumerate(scenarios) if s is not None
                  and s.settings.method == "lawson" and not s.controllers
                  and model_path(s) == "prescribed" and not _shares_run(scenarios, i)]
    if len(candidates) < MIN_GROUP:
        return {}
    from ..solvers.lawson import finish, first_pass, prepare
    from ..solvers.lawson_batch import first_passes, groups, with_propagators
    from ..solvers.threads import single_threaded

    prepared = {}
    with single_threaded():
        for i in candidates:
            wall, cpu = time.perf_counter(), time.thread_time()
            scenario = scenarios[i]
            assert scenario is not None
            settings = scenario.settings
            t = output_times(settings.t_end, settings.dt_out)
            try:
                system = _system(scenario, t)
                if system is None:
                    continue
                start = prepare(system, t, settings.rtol, settings.atol, propagators=False)
            except Exception:  # noqa: BLE001, S112 — the case's own run reports it
                continue
            prepared[i] = (system, start, time.perf_counter() - wall, time.thread_time() - cpu)
        keys = list(prepared)
        # every case's block exponentials in a few calls, whether it joins a group or not
        wall, cpu = time.perf_counter(), time.thread_time()
        try:
            ready = with_propagators([prepared[i][1] for i in keys])
        except Exception:  # noqa: BLE001 — each case then runs alone
            return {}
        share = ((time.perf_counter() - wall) / len(keys), (time.thread_time() - cpu) / len(keys))
        for i, start in zip(keys, ready):
            system, _, wall_prepare, cpu_prepare = prepared[i]
            prepared[i] = (system, start, wall_prepare + share[0], cpu_prepare + share[1])
        grouped = groups([prepared[i][1] for i in keys])
        passes = {}
        for members in grouped:
            wall, cpu = time.perf_counter(), time.thread_time()
            indices = [keys[k] for k in members]
            try:
                results = first_passes([prepared[i][1] for i in indices])
            except Exception:  # noqa: BLE001 — each case then runs its first pass alone
                results = [None] * len(indices)
            share = ((time.perf_counter() - wall) / len(indices),
                     (time.thread_time() - cpu) / len(indices))
            passes.update({i: (r, share) for i, r in zip(indices, results)})
        out = {}
        for i, (system, start, wall_prepare, cpu_prepare) in prepared.items():
            wall, cpu = time.perf_counter(), time.thread_time()
            result, share = passes.get(i, (None, (0.0, 0.0)))
            try:
                solution, _ = finish(start, *(result or first_pass(start)))
            except Exception:  # noqa: BLE001, S112 — the case's own run reports it
                continue
            out[i] = Integrated(system, solution,
                                wall_prepare + share[0] + time.perf_counter() - wall,
                                cpu_prepare + share[1] + time.thread_time() - cpu)
    return out


def _system(scenario: Scenario, t: np.ndarray) -> CompiledFirstOrderSystem | None:
    """The case's system as its run builds it, or None where its run takes another way
    (links made rigid, none flexible, too large a run: its own run says so)."""
    from ..simulation.common import check_run_memory
    from ..simulation.prescribed import prescribed_system
    from ..simulation.rigid import quasi_rigid_links

    check_run_memory(scenario)
    if quasi_rigid_links(scenario, t):
        return None
    system = prescribed_system(scenario, t)
    return system if system.n else None


def _shares_run(scenarios: Sequence[Scenario | None], i: int) -> bool:
    """Whether case i equals the case before it but for its sensors (its run is that
    case's, `runner.CaseRunner`)."""
    previous = scenarios[i - 1] if i else None
    current = scenarios[i]
    return previous is not None and current is not None \
        and equal_but_sensors(previous, current)


def warm_up(scenario: Scenario) -> None:
    """Load (or compile) the batched loop by running the first pass of ``scenario`` (a
    prescribed Lawson run) through it: the installation's warm-up (`cli.warmup_run`)."""
    from ..simulation.common import output_times
    from ..simulation.prescribed import prescribed_system
    from ..solvers.lawson import prepare
    from ..solvers.lawson_batch import first_passes

    settings = scenario.settings
    t = output_times(settings.t_end, settings.dt_out)
    first_passes([prepare(prescribed_system(scenario, t), t, settings.rtol, settings.atol)])
