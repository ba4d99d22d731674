"""Does the goal really hold? The demo's check of each goal fact, in the world model and in the
physics of its in-process world.

The check itself is the task layer's (:func:`task_agent.check_goal_facts`, the one the task
agent runs after a goal task succeeds, asking ``skimesh sim`` over the mesh); the demo asks its
own world through the same interface (:class:`mujoco_sim.SimTruth`), after the task ended.
"""

from __future__ import annotations

from collections.abc import Callable

from mujoco_sim import SimTruth, SimWorld
from skill_agent import WorldView
from task_agent import Goal, check_goal_facts
from task_agent.protocol import FactCheck

__all__ = ["FactCheck", "goal_holds", "verify_goal"]

LabelOf = Callable[[str], str]


def goal_holds(checks: list[FactCheck]) -> bool:
    """Every fact holds in the world model, and none is contradicted by the physics."""
    return bool(checks) and all(c.holds for c in checks)


async def verify_goal(
    goal: Goal,
    view: WorldView,
    world: SimWorld,
    label_of: LabelOf,
    *,
    settle: float = 0.5,
    rest_within: float = 5.0,
) -> list[FactCheck]:
    """Check every literal of ``goal`` in ``view`` and in ``world``: after ``settle`` simulated
    seconds, and once every object a ``contain`` fact names is at rest (at most
    ``rest_within`` simulated seconds more)."""
    check = await check_goal_facts(
        goal, view, SimTruth(world), label_of=label_of, settle=settle, rest_within=rest_within
    )
    return check.facts
