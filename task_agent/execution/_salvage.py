"""What a task that lost an agent can still do, and what it reports (used by
:class:`~task_agent.execution.Executor` when a replan after a lost agent finds no plan for the
whole goal): the goal facts the agents left still reach together (:func:`still_reachable`),
then the :class:`~task_agent.protocol.PartialResult` and the ending it makes
(:func:`partial_result`, :func:`partial_ending`)."""

from __future__ import annotations

from collections.abc import Iterable, Sequence

from .._errors import PlanningError
from .._goals import Goal, GoalLiteral
from .._physics import fact_text
from ..discovery import AgentInfo
from ..protocol import LostAgent, LostFact, PartialResult, TaskOutcome
from ._state import WorldModel, unmet_goal
from ._task_planning import PlanSource

__all__ = ["label_of", "partial_ending", "partial_result", "still_reachable"]


def label_of(wm: WorldModel, element_id: str) -> str:
    element = wm.find_element(element_id)
    return element.label if element is not None and element.label else element_id


async def still_reachable(
    planner: PlanSource,
    agents: Sequence[AgentInfo],
    wm: WorldModel,
    goal: Goal,
    *,
    why: str,
    gone: str,
) -> tuple[list[GoalLiteral], int, list[LostFact]]:
    """The facts to keep (those that hold now, then each open fact a plan with the others
    kept still reaches), how many of them are still to do, and the facts lost with why
    (``gone``: the agents lost; ``why``: the replan's error, where a plan says nothing)."""
    keep: list[GoalLiteral] = []
    open_: list[GoalLiteral] = []
    for lit in goal.literals:
        (open_ if unmet_goal(Goal(literals=(lit,)), wm) else keep).append(lit)
    lost: list[LostFact] = []
    todo = 0
    for lit in open_:
        try:
            await planner.plan(agents, wm, Goal(literals=(*keep, lit)))
        except PlanningError as e:
            detail = str(e).splitlines()[0] if str(e) else why
            lost.append(
                LostFact(
                    fact=fact_text(lit, lambda i: label_of(wm, i)),
                    why=f"unreachable with the agents left ({gone} lost): {detail}",
                )
            )
            continue
        keep.append(lit)
        todo += 1
    return keep, todo, lost


def partial_result(
    goal: Goal, lost: list[LostFact], wm: WorldModel, lost_agents: Iterable[LostAgent]
) -> PartialResult:
    achieved = [
        fact_text(lit, lambda i: label_of(wm, i))
        for lit in goal.literals
        if not unmet_goal(Goal(literals=(lit,)), wm)
    ]
    return PartialResult(achieved=achieved, lost=lost, lost_agents=list(lost_agents))


def partial_ending(goal: Goal, result: PartialResult) -> tuple[TaskOutcome, str]:
    """``partial`` and its summary, or ``failed`` when no goal fact was achieved."""
    agents = "; ".join(
        f"{a.agent} at step {a.step} {a.skill}" if a.step >= 0 else a.agent
        for a in result.lost_agents
    )
    summary = (
        f"{len(result.achieved)} of {len(goal.literals)} goal facts achieved; lost: "
        + "; ".join(f.fact for f in result.lost)
        + f" (agents lost: {agents})"
    )
    if not result.achieved:
        return "failed", f"no goal fact achieved after losing an agent: {summary}"
    return "partial", summary
