"""What a task claims of the site before its steps run (:func:`claim_of`), and planning
around what other tasks hold (:func:`free_agents`).

A task claims the agents its steps are given to and the objects they act on: every element a
step names by id that is no place (a station, a shelf, a parking spot: places are kept by the
reservations robots take as they drive, ``skill_agent.skills`` navigate) and no agent's own
machine (a robot, its devices). Steps of a task file that leave the agent open claim none
(the step scheduler picks a free one when they start).
"""

from __future__ import annotations

from collections.abc import Iterable, Sequence

from skill_agent import WorldView

from ..discovery import AgentInfo
from ._state import StepSpec

__all__ = ["claim_of", "free_agents"]

_NOT_OBJECTS = ("Location", "Agent", "Robot", "Device")


def claim_of(
    steps: Iterable[StepSpec], agents: Sequence[AgentInfo], view: WorldView
) -> tuple[set[str], set[str]]:
    """(agents, objects) the ``steps`` need for themselves (see the module doc)."""
    steps = list(steps)
    names = {s.agent for s in steps if s.agent}
    machines = {m for a in agents for m in (a.robot, a.id, *a.devices) if m}
    onto = view.ontology
    kinds = {c: onto.subclasses(c) for c in _NOT_OBJECTS if c in onto.classes}
    objects: set[str] = set()
    for step in steps:
        for value in step.params.values():
            if not isinstance(value, str) or value in machines:
                continue
            element = view.find_element(value)
            if element is None or any(element.type in k for k in kinds.values()):
                continue
            objects.add(element.id)
    return names, objects


def free_agents(agents: Sequence[AgentInfo], busy: Iterable[str]) -> list[AgentInfo]:
    """``agents`` but those ``busy`` (held by other tasks)."""
    held = set(busy)
    return [a for a in agents if a.name not in held]
