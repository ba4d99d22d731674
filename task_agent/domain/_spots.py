"""Room for robots: a place that holds one robot is never planned for two at once.

How many robots a location holds is its ``robotCapacity``
(:func:`skill_agent.skills.robot_capacity`: absent, one at a station, none at a surface such
as a shelf, no limit elsewhere). Every action that moves the agent's own robot (its effects
add ``at(robot, goal)`` and delete ``at(robot, start)``: navigate) gets, by the goal's kind of
place:

- a *spot* (holds one robot: a station's work spot, a home, a narrow passage): the fact
  ``free_spot(x)``, true in the initial state when no robot is ``at`` it. The action needs
  ``free_spot(goal)`` and deletes it (the robot takes the spot) and adds ``free_spot(start)``
  (it leaves the spot it stood at). So a second robot's arrival at a spot is planned after
  the first robot's departure, and the partial order keeps that (the arrival reads
  ``free_spot``, which the departure adds);
- an *open* place (holds more than one, or has no limit: a depot, an open floor): a variant
  of the action,
  named ``<action>__open``, needs the static ``open_place(goal)`` and counts nobody (the
  navigate skill's reservation enforces the capacity at run time); it too frees its start;
- a place for no robot (``robotCapacity`` 0, a surface): neither fact holds, so no robot is
  planned there.

When the task has no spot, the action keeps its name and needs ``open_place(goal)``; when it
has neither a spot nor a place for no robot, nothing changes. Adding ``free_spot`` of a start
that is an open place is harmless: any number of robots may go there anyway.
"""

from __future__ import annotations

from collections.abc import Iterable

import msgspec

from skill_agent import WorldView
from skill_agent.skills import robot_capacity
from wm_store.ontology import Cls, Rel

from ._model import ActionSchema, GroundFact, Lit
from ._vocabulary import Vocabulary

__all__ = ["FREE", "OPEN", "room_for_robots"]

FREE = "free_spot"
"""The fact ``free_spot(x)``: no robot stands at (or is planned into) the spot ``x``."""
OPEN = "open_place"
"""The static fact ``open_place(x)``: ``x`` holds several robots."""


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
    """``actions`` with the rules of the module doc and the initial ``free_spot`` /
    ``open_place`` facts (their predicates are declared in ``vocab``). ``robots``: action
    name -> the agent's robot."""
    view = vocab.view
    moving = {name for name, s in actions.items() if _moves(s, robots.get(name, ""))[0]}
    if not moving:
        return actions, set()
    capacity = {o: robot_capacity(view, o) for o in vocab.objects}
    spots = {o for o, c in capacity.items() if c == 1}
    places = {o for o in vocab.objects if _is_location(view, o)}
    opens = {o for o in places if (c := capacity[o]) is None or c > 1}
    if not spots and not any(c == 0 for c in capacity.values()):
        return actions, set()  # nothing to count, nowhere to keep robots from
    occupied = {
        rel.object for rel in view.query_relation(predicate=Rel.at) if _is_robot(view, rel.subject)
    }
    init: set[GroundFact] = {(FREE, (s,)) for s in spots - occupied}
    if spots:
        vocab.names.declare(FREE, "opaque", 1)
    if opens:
        declared = vocab.names.declare(OPEN, "opaque", 1)
        vocab.names.predicates[OPEN] = msgspec.structs.replace(declared, static=True)
        init |= {(OPEN, (o,)) for o in opens}
    out: dict[str, ActionSchema] = {}
    for name, schema in actions.items():
        if name not in moving:
            out[name] = schema
            continue
        goals, starts = _moves(schema, robots[name])
        wide = [Lit(OPEN, (g,)) for g in goals]
        if not spots:
            out[name] = _with(schema, name, wide, [], [])
            continue
        leave = [Lit(FREE, (s,)) for s in starts]
        take = [Lit(FREE, (g,)) for g in goals]
        taken = [Lit(FREE, (g,), False) for g in goals]
        out[name] = _with(schema, name, take, taken, leave)
        if opens:
            out[f"{name}__open"] = _with(schema, f"{name}__open", wide, [], leave)
    return out, init


def _is_location(view: WorldView, element_id: str) -> bool:
    element = view.find_element(element_id)
    return element is not None and view.ontology.is_a(element.type, Cls.Location)


def _is_robot(view: WorldView, element_id: str) -> bool:
    element = view.find_element(element_id)
    return element is not None and view.ontology.is_a(element.type, Cls.Robot)
