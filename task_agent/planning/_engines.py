"""The planning engines, called through unified-planning's engine API.

:func:`solve_problem` runs Kairos (in-process) or Fast Downward (a child process per call, with
:data:`FD_SEARCH`) on a unified-planning problem within a time-out. Engines are instantiated
directly (``KairosEngine``, ``FastDownwardPDDLPlanner``): the factory's engine lookup and
credits printing inspect the Python stack on every call (see docs/benchmarks.md, Planning:
Performance problems found). unified-planning is
untyped: ``Any`` stays in this module.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

from unified_planning.engines import PlanGenerationResultStatus as Status
from unified_planning.exceptions import UPException
from up_fast_downward import FastDownwardPDDLPlanner
from up_kairos import KairosEngine

from .._errors import PlanningError
from ._plan import Engine

__all__ = ["FD_SEARCH", "SOLVED", "UNSOLVABLE", "solve_problem"]

# lama-first (Fast Downward's default satisficing alias), except that its heuristics
# over-approximate negated derived facts: ``empty`` preconditions are negated existentials,
# which FD compiles into axioms, and computing their negations exactly multiplies the
# relaxed operators (see docs/benchmarks.md, Planning: Performance problems found). Plans
# are still exact; only guidance changes.
# (No spaces: up-fast-downward splits the configuration on whitespace.)
FD_SEARCH = (
    "let(hlm,eval_modify_costs(landmark_sum(lm_factory=lm_reasonable_orders_hps(lm_rhw()),"
    "pref=false,axioms=approximate_negative),cost_type=one),"
    "let(hff,eval_modify_costs(ff(axioms=approximate_negative),cost_type=one),"
    "lazy_greedy([hff,hlm],preferred=[hff,hlm],cost_type=one,reopen_closed=false)))"
)


class _FastDownward(FastDownwardPDDLPlanner):  # type: ignore[misc]  # untyped
    """Fast Downward with two fixes to how unified-planning 1.3 runs it.

    - Its translator writes ``output.sas`` into the *caller's* working directory, so two
      solves at once from one directory (two planners in threads, two test processes)
      overwrite each other's file: one then fails or answers for the other problem. Here
      the file goes next to the plan file, in the solve's own temporary directory.
    - On a time-out unified-planning kills the process group but neither waits for it nor
      closes its pipes (a zombie and two unclosed files per time-out); :meth:`reap` does both.
    """

    def _base_cmd(self, plan_filename: str) -> list[str]:
        cmd: list[str] = super()._base_cmd(plan_filename)
        return [*cmd, "--sas-file", str(Path(plan_filename).with_name("output.sas"))]

    @property
    def _process(self) -> Any:
        return self.__dict__.get("_current")

    @_process.setter
    def _process(self, process: Any) -> None:
        self.__dict__["_current"] = process
        if process is not None:
            self.__dict__["_started"] = process

    def reap(self) -> None:
        process = self.__dict__.pop("_started", None)
        if process is None:
            return
        for stream in (process.stdout, process.stderr):
            if stream is not None:
                stream.close()
        process.wait(timeout=10)


UNSOLVABLE = {Status.UNSOLVABLE_PROVEN, Status.UNSOLVABLE_INCOMPLETELY}
"""Result statuses saying the goal cannot be reached."""
SOLVED = {Status.SOLVED_SATISFICING, Status.SOLVED_OPTIMALLY}
"""Result statuses with a plan."""


def _engine(engine: Engine) -> Any:
    if engine == "kairos":
        return KairosEngine()
    return _FastDownward(fast_downward_search_config=FD_SEARCH)


def solve_problem(engine: Engine, problem: Any, timeout: float) -> Any:
    """unified-planning's result of ``engine`` on ``problem``; PlanningError when the engine
    fails (no plan found is a result, not an error)."""
    with _engine(engine) as solver:
        try:
            result = solver.solve(problem, timeout=max(timeout, 0.001))
        except UPException as exc:
            raise PlanningError(f"{engine} failed: {exc}") from exc
        finally:
            if isinstance(solver, _FastDownward):
                solver.reap()
    return result
