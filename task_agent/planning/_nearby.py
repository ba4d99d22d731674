"""The agents worth building a planning task for: :func:`nearby_agents`.

Building a task reads every skill of every agent (a drafted action per agent and skill), so
for a goal about one kit box in a world of fifty robots the build alone would grow with the
fleet. Before building, the world model's relations are walked from the goal's elements (both
directions, :data:`~._allocate.HUB` rule: an element in more than that many relations, a depot
where every robot stands, is reached but not crossed, up to :data:`~._allocate.FAR` hops);
the agents whose machine (robot or appliance, and its devices) is met are taken in the order
met, until :func:`nearby_agents` has two per part of the goal. The planner builds the task
for those only and, if it has no plan with them, builds it for every agent (so a goal never
fails for want of an agent that was left out). When the goal would need most of the agents
anyway, or no agent is met, the task is built for every agent at once.
"""

from __future__ import annotations

from collections import deque
from collections.abc import Sequence

from skill_agent import WorldView

from .._goals import Goal, RelationGoal
from ..discovery import AgentInfo
from ..domain import Lit
from ._allocate import FAR, HUB
from ._decompose import TRIES
from ._parts import parts

__all__ = ["nearby_agents"]


def _parts_of(goal: Goal) -> int:
    lits = [
        Lit("r", (lit.subject, lit.object))
        if isinstance(lit, RelationGoal)
        else Lit("p", (lit.element,))
        for lit in goal.literals
    ]
    return len(parts(lits))


def nearby_agents(
    agents: Sequence[AgentInfo], view: WorldView, goal: Goal
) -> list[AgentInfo] | None:
    """The agents near ``goal`` (see the module doc), or None: build for all of them."""
    want = TRIES * _parts_of(goal)
    if want * 2 >= len(agents):
        return None
    machine = {m: a for a in agents for m in a.hardware}
    chosen: dict[str, AgentInfo] = {}
    seen = dict.fromkeys(goal.elements(), 0)
    todo = deque(seen)
    while todo and len(chosen) < want:
        element = todo.popleft()
        agent = machine.get(element)
        if agent is not None:
            chosen.setdefault(agent.name, agent)
        hops = seen[element]
        if hops >= FAR:
            continue
        links = view.query_relation(subject=element) + view.query_relation(obj=element)
        if hops > 0 and len(links) > HUB:
            continue
        for link in links:
            other = link.object if link.subject == element else link.subject
            if other not in seen:
                seen[other] = hops + 1
                todo.append(other)
    return list(chosen.values()) or None
