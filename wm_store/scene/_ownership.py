"""Which agent owns which elements, and whether a writer may change them.

An agent **owns** what it registered (``wm_store.RobotRegistration``): its Agent element, its
Skill elements (``hasSkill``), the robot or appliance it controls (``controls``) and that
robot's devices (``hasA`` objects of a Device class). Two agents that control one robot (a
split robot: an arm agent and a base agent) own the robot and its devices together; an agent
joins a robot by adding ``controls`` to it, which the store's ``controllers`` setting can limit
to the agents named for that robot.

A transaction written by an agent (its ``author`` is the label of an Agent element, also one
the transaction itself adds) may not, for anything another agent owns: change its properties
or remove it, add or remove a ``hasA`` / ``hasSkill`` / ``controls`` relation from or to it
(joining a robot aside), nor add an Agent element under another name. Everything else stays
open to it: the facts of the world its skills change (``at``, ``contain``, an object's pose),
whoever owns the other end, because robots work on shared objects.

Writers that are no agent (the task agent, the command line, an operator, the store's own
presence monitor) are not restricted here: whether they may write at all is the router's ACL
(``configs/zenoh/``). Under the ACL an agent can only write through ``wm/write/<its name>``,
so the author the store sees is the agent's authenticated identity; on an open mesh the
author is what the writer claims, and this check protects against mistakes, not attacks.
"""

from __future__ import annotations

from collections.abc import Iterable, Mapping, Sequence
from dataclasses import dataclass, field

from wm_store._errors import ForbiddenError
from wm_store.protocol import Delta, ElementPut, ElementRemoved, RelationAdded, RelationRemoved

from ._state import SceneState

__all__ = ["STRUCTURE", "Ownership", "changes_ownership", "check_writer", "ownership"]

STRUCTURE = frozenset({"controls", "hasA", "hasSkill"})
"""The relations of a registration: only their owners may add or remove them."""


@dataclass
class Ownership:
    """Who owns what, before a transaction."""

    owners: dict[str, set[str]] = field(default_factory=dict)
    """Element id -> the agents that own it."""
    agents: dict[str, str] = field(default_factory=dict)
    """Agent name -> its Agent element's id."""
    devices: dict[str, set[str]] = field(default_factory=dict)
    """Robot id -> its devices' ids."""
    names: dict[str, str] = field(default_factory=dict)
    """Element id -> its label (for messages)."""

    def own(self, element_id: str, agent: str) -> None:
        self.owners.setdefault(element_id, set()).add(agent)


def ownership(
    state: SceneState, agent_types: Iterable[str], device_types: Iterable[str]
) -> Ownership:
    """Who owns what in ``state`` (see the module doc); the types include their subclasses."""
    devices = frozenset(device_types)
    out = Ownership()
    for agent_id in state.ids_of_types(agent_types):
        name = state.elements[agent_id].label or agent_id
        out.agents[name] = agent_id
        out.own(agent_id, name)
        for skill in state.objects(agent_id, "hasSkill"):
            out.own(skill, name)
        for robot in state.objects(agent_id, "controls"):
            out.own(robot, name)
            out.names[robot] = state.elements[robot].label
            parts = out.devices.setdefault(robot, set())
            for part in state.objects(robot, "hasA"):
                element = state.get(part)
                if element is not None and element.type in devices:
                    parts.add(part)
                    out.own(part, name)
                    out.names[part] = element.label
    for element_id in out.owners:
        element = state.get(element_id)
        if element is not None and element.label:
            out.names.setdefault(element_id, element.label)
    return out


def check_writer(
    before: Ownership,
    deltas: Sequence[Delta],
    writer: str,
    *,
    agent_types: frozenset[str],
    controllers: Mapping[str, Sequence[str]] = {},
) -> None:
    """Raise :class:`ForbiddenError` if ``writer``'s ``deltas`` change what another agent owns
    (see the module doc). ``controllers``: robot label -> the agents that may control it (a
    robot not named there may be joined by any agent)."""
    new_agents = {
        d.element.label: d.element.id
        for d in deltas
        if isinstance(d, ElementPut) and d.element.type in agent_types and d.element.label
    }
    mine = new_agents.get(writer) or before.agents.get(writer)
    if mine is None:
        return  # no agent: the ACL decides
    owners = {k: set(v) for k, v in before.owners.items()}
    for delta in deltas:  # joins first: the joined robot's devices are the joiner's too
        if isinstance(delta, RelationAdded) and delta.relation.predicate == "controls":
            robot = delta.relation.object
            if delta.relation.subject != mine or not owners.get(robot):
                continue
            allowed = controllers.get(before.names.get(robot, ""), None)
            if allowed is not None and writer not in allowed:
                raise ForbiddenError(
                    f"agent {writer!r} may not control {before.names.get(robot, robot)!r}: the "
                    f"store's controllers setting names {', '.join(allowed) or 'no agent'} for it"
                )
            for part in (robot, *before.devices.get(robot, ())):
                owners.setdefault(part, set()).add(writer)

    def refuse(element_id: str, what: str) -> None:
        others = owners.get(element_id, set())
        if others and writer not in others:
            raise ForbiddenError(
                f"agent {writer!r} may not {what} {before.names.get(element_id, element_id)!r}: "
                f"it belongs to agent {', '.join(sorted(others))}"
            )

    for delta in deltas:
        match delta:
            case ElementPut(element=e):
                refuse(e.id, "change")
                if e.type in agent_types and e.label != writer and e.id not in before.owners:
                    raise ForbiddenError(
                        f"agent {writer!r} may not register another agent ({e.label!r})"
                    )
            case ElementRemoved(id=element_id):
                refuse(element_id, "remove")
            case RelationAdded(relation=r) | RelationRemoved(relation=r):
                if r.predicate in STRUCTURE:
                    refuse(r.subject, f"change {r.predicate} of")
                    if not (r.predicate == "controls" and r.subject == mine):
                        refuse(r.object, f"change {r.predicate} to")


def changes_ownership(before: Ownership, deltas: Iterable[Delta], types: frozenset[str]) -> bool:
    """Whether ``deltas`` may change who owns what (so an :class:`Ownership` made before them
    is stale): they touch an owned element, add an element of one of ``types`` (agents,
    devices), tie or untie with a registration relation (:data:`STRUCTURE`), or change the
    ontology. Most changes (a skill's effects) do not: the store then keeps its map."""
    for delta in deltas:
        match delta:
            case ElementPut(element=e):
                if e.id in before.owners or e.type in types:
                    return True
            case ElementRemoved(id=element_id):
                if element_id in before.owners:
                    return True
            case RelationAdded(relation=r) | RelationRemoved(relation=r):
                if r.predicate in STRUCTURE:
                    return True
            case _:  # classes, templates, terms: the class hierarchy may change
                return True
    return False
