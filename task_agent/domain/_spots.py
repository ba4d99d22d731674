"""Room for robots: a place that holds one robot is never planned for two at once.

A location's ``robotCapacity`` (ontology; absent means one) says how many robots may stand at
it. For every location of the task that holds one robot (a *spot*: a station's work spot, a
home, a narrow passage) the task gets the fact ``free_spot(x)``, true in the initial state
when no robot is ``at`` it. Every action that moves the agent's own robot (its effects add
``at(robot, goal)`` and delete ``at(robot, start)``: navigate) then

- needs ``free_spot(goal)`` and deletes it (the robot takes the spot),
- adds ``free_spot(start)`` (it leaves the spot it stood at).

So a second robot's arrival at a spot is planned after the first robot's departure, and the
partial order keeps that (the arrival reads ``free_spot``, which the departure adds). A
location with a larger capacity (or 0: no limit) is *open*: the planner does not count
robots there; the navigate skill's reservation enforces its capacity at run time. When the
task has both kinds, a moving action comes in two variants: one for spots (static
``spot(goal)``) and one for open places (``not spot(goal)``), named ``<action>__open``.
"""

from __future__ import annotations

from collections.abc import Iterable

import msgspec

from skill_agent import WorldView
from skill_agent.skills import robot_capacity
from wm_store.ontology import Cls, Rel

from ._model import ActionSchema, GroundFact, Lit
from ._vocabulary import Vocabulary

__all__ = ["FREE", "SPOT", "holds_one_robot", "room_for_robots"]

FREE = "free_spot"
"""The fact ``free_spot(x)``: no robot stands at (or is planned into) the spot ``x``."""
SPOT = "spot"
"""The static fact ``spot(x)``: ``x`` holds one robot (only when the task also has open
places)."""


def holds_one_robot(view: WorldView, location: str) -> bool:
    """The location holds one robot at a time (its ``robotCapacity`` is 1 or absent)."""
    return robot_capacity(view, location) == 1


def _moves(schema: ActionSchema, robot: str) -> tuple[list[str], list[str]]:
    """The goals (added ``at``) and starts (deleted ``at``) of ``robot`` in ``schema``."""
    goals = [lit.args[1] for lit in schema.add if lit.pred == Rel.at and lit.args[0] == robot]
    starts = [lit.args[1] for lit in schema.delete if lit.pred == Rel.at and lit.args[0] == robot]
    return goals, starts


def _with(
    schema: ActionSchema, name: str, pre: Iterable[Lit], delete: Iterable[Lit], add: Iterable[Lit]
) -> ActionSchema:
    return msgspec.structs.replace(
        schema,
        name=name,
        pre=(*schema.pre, *pre),
        delete=(*schema.delete, *delete),
        add=(*schema.add, *add),
    )


def room_for_robots(
    vocab: Vocabulary, actions: dict[str, ActionSchema], robots: dict[str, str]
) -> tuple[dict[str, ActionSchema], set[GroundFact]]:
    """``actions`` with the spot rules (module doc) and the initial ``free_spot`` / ``spot``
    facts (their predicates are declared in ``vocab``). ``robots``: action name -> the
    agent's robot."""
    view = vocab.view
    places = [o for o in vocab.objects if _is_location(view, o)]
    spots = {o for o in places if holds_one_robot(view, o)}
    if not spots or Rel.at not in vocab.relations:
        return actions, set()
    mixed = len(spots) < len(places)
    occupied = {
        rel.object for rel in view.query_relation(predicate=Rel.at) if _is_robot(view, rel.subject)
    }
    init: set[GroundFact] = {(FREE, (s,)) for s in spots - occupied}
    vocab.names.declare(FREE, "opaque", 1)
    if mixed:
        spot = vocab.names.declare(SPOT, "opaque", 1)
        vocab.names.predicates[SPOT] = msgspec.structs.replace(spot, static=True)
        init |= {(SPOT, (s,)) for s in spots}
    out: dict[str, ActionSchema] = {}
    for name, schema in actions.items():
        goals, starts = _moves(schema, robots.get(name, ""))
        if not goals:
            out[name] = schema
            continue
        leave = [Lit(FREE, (s,)) for s in starts]
        take = [Lit(FREE, (g,)) for g in goals]
        taken = [Lit(FREE, (g,), False) for g in goals]
        if not mixed:
            out[name] = _with(schema, name, take, taken, leave)
            continue
        out[name] = _with(schema, name, [*take, *(Lit(SPOT, (g,)) for g in goals)], taken, leave)
        open_name = f"{name}__open"
        out[open_name] = _with(
            schema, open_name, [Lit(SPOT, (g,), False) for g in goals], [], leave
        )
    return out, init


def _is_location(view: WorldView, element_id: str) -> bool:
    element = view.find_element(element_id)
    return element is not None and view.ontology.is_a(element.type, Cls.Location)


def _is_robot(view: WorldView, element_id: str) -> bool:
    element = view.find_element(element_id)
    return element is not None and view.ontology.is_a(element.type, Cls.Robot)
