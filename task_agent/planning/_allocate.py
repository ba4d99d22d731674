"""Who does which part of a goal, decided before any search: :func:`allocate`.

An agent *can* take a part when one of its actions makes one of the part's literals hold (an
add effect for a positive literal, a delete for a negative one). Its *bid* for the part is
how far the part is from its hardware: the hops in the :class:`~._parts.FactGraph` from each
of the part's elements to the agent's robot and devices (a kit box on the robot: one hop; a
gear in a box at the station where the robot stands: three; beyond :data:`FAR` hops or
behind a hub: :data:`FAR`), plus the metres between them when both have a pose, counted as
one hop per :data:`METRES_PER_HOP`. Parts are then assigned by a linear assignment
(``scipy.optimize.linear_sum_assignment``, the Hungarian method): each agent offers as many
slots as there are parts per agent (rounded up, plus one), each further slot dearer by the
mean bid, so the total is least and the work is spread (a goal so large that the matrix
would pass :data:`ASSIGN_CELLS` cells is allocated greedily instead, cheapest parts first,
each to the agent whose bid plus its load is least). Each part gets a ranking: its
assigned agent first, then the others that can take it, cheapest first.

Agents that can take no part are *helpers* (an oven's agent that opens its door for a robot's
pick): a solve that fails with the part's agent alone tries again with the helpers beside it.
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence

import numpy as np
from scipy.optimize import linear_sum_assignment

from ..domain import Lit, PlanningTask
from ..reachability import Typing, Writers, unify
from ._parts import FactGraph

__all__ = ["ASSIGN_CELLS", "FAR", "METRES_PER_HOP", "Allocation", "allocate", "hardware"]

FAR = 8
"""Hops counted for an element the agent's hardware does not reach (or only through a hub)."""
METRES_PER_HOP = 5.0
"""Metres of distance that count as one hop of the fact graph in a bid."""
HUB = 12
"""Facts naming an element beyond which it is a hub for bids (see :mod:`._parts`)."""
_NONE = 1e9
ASSIGN_CELLS = 4_000_000
"""Cells of the assignment's cost matrix (parts x agents x slots, 32 MB) beyond which parts
are allocated greedily: the Hungarian method is cubic in the parts."""

Point = tuple[float, float]


class Allocation:
    """The ranking of agents per part (assigned first) and the helpers."""

    def __init__(self, ranking: list[list[str]], helpers: list[str]) -> None:
        self.ranking = ranking
        self.helpers = helpers


def hardware(task: PlanningTask) -> dict[str, set[str]]:
    """Each agent's robot and devices: the elements its actions are bound to."""
    out: dict[str, set[str]] = {}
    for schema in task.actions.values():
        out.setdefault(schema.agent, set()).update(schema.bound.values())
    return out


def _can_take(writers: Writers, typing: Typing, part: Sequence[Lit]) -> set[str]:
    agents: set[str] = set()
    for lit in part:
        for schema, eff, _ in writers.get(lit.pred, lit.positive, lit.args):
            if unify(eff, lit.args, schema, typing) is not None:
                agents.add(schema.agent)
    return agents


def _bid(
    part: Sequence[Lit], reached: Mapping[str, int], near: Point | None, where: Mapping[str, Point]
) -> float:
    elements = {a for lit in part for a in lit.args}
    hops = sum(min(reached.get(e, FAR), FAR) for e in elements)
    metres = [math.dist(near, where[e]) for e in elements if near is not None and e in where]
    return hops + (min(metres) / METRES_PER_HOP if metres else 0.0)


def allocate(
    task: PlanningTask,
    goal_parts: Sequence[Sequence[Lit]],
    graph: FactGraph,
    where: Mapping[str, Point] | None = None,
) -> Allocation:
    """The agents' ranking for each of ``goal_parts`` (see the module doc); a part no agent
    can take gets an empty ranking."""
    where = where or {}
    kit = hardware(task)
    writers, typing = Writers(task), Typing(task)
    able = [_can_take(writers, typing, p) for p in goal_parts]
    takers = sorted(set().union(*able)) if able else []
    helpers = sorted(set(kit) - set(takers))
    bids: dict[tuple[int, str], float] = {}
    for agent in takers:
        reached = graph.distances(kit[agent], depth=FAR, hub=HUB)
        near = next((where[h] for h in sorted(kit[agent]) if h in where), None)
        for i, part in enumerate(goal_parts):
            if agent in able[i]:
                bids[(i, agent)] = _bid(part, reached, near, where)
    assigned = _assign(len(goal_parts), takers, bids)
    ranking = []
    for i in range(len(goal_parts)):
        others = sorted((a for a in able[i] if a != assigned.get(i)), key=lambda a: bids[(i, a)])
        ranking.append([assigned[i], *others] if i in assigned else others)
    return Allocation(ranking, helpers)


def _assign(
    parts: int, agents: Sequence[str], bids: Mapping[tuple[int, str], float]
) -> dict[int, str]:
    """Part -> agent by a least-cost assignment over slots (see the module doc), or greedily
    beyond :data:`ASSIGN_CELLS` cells of the cost matrix."""
    if not parts or not agents or not bids:
        return {}
    slots = math.ceil(parts / len(agents)) + 1
    load = sum(bids.values()) / len(bids) + 1.0
    if parts * len(agents) * slots > ASSIGN_CELLS:
        return _greedy(parts, bids, load)
    column = {agent: j for j, agent in enumerate(agents)}
    cost = np.full((parts, len(agents) * slots), _NONE)
    for (i, agent), bid in bids.items():
        j = column[agent]
        for k in range(slots):
            cost[i, j * slots + k] = bid + k * load
    rows, cols = linear_sum_assignment(cost)
    return {
        int(i): agents[int(c) // slots]
        for i, c in zip(rows, cols, strict=True)
        if cost[i, c] < _NONE
    }


def _greedy(parts: int, bids: Mapping[tuple[int, str], float], load: float) -> dict[int, str]:
    """Part -> agent, the parts with the cheapest bids first, each to the agent whose bid plus
    ``load`` for each part it has already is least: O(parts x agents)."""
    offers: dict[int, list[tuple[float, str]]] = {}
    for (i, agent), bid in bids.items():
        offers.setdefault(i, []).append((bid, agent))
    taken: dict[str, int] = {}
    out: dict[int, str] = {}
    for i in sorted(offers, key=lambda i: min(offers[i])):
        _, agent = min((bid + taken.get(a, 0) * load, a) for bid, a in offers[i])
        out[i] = agent
        taken[agent] = taken.get(agent, 0) + 1
    return out
