"""The agents the world model knows, as the planner needs them (pure: no Zenoh).

Agents register themselves (``wm_store``)::

    Agent "<name>" {available} --controls--> Robot --hasA--> devices (transitively)
          +--hasSkill--> Skill "<skill>" {skillType, description: JSON of a SkillDescription}

:func:`agents_from_view` reads that sub-graph into :class:`AgentInfo` values. A skill whose
description is missing or unreadable is left out and the reason recorded in
``AgentInfo.problems`` (the planner cannot use a skill it cannot see). The Zenoh-facing
discovery service combines this with liveliness (``alive``).
"""

from __future__ import annotations

from collections.abc import Collection

import msgspec

from skill_agent import WorldView
from skill_agent.protocol import SkillDescription
from wm_store.protocol import Element
from wm_store.scene import id_sort_key

from .._errors import DiscoveryError

__all__ = ["AgentInfo", "agents_from_view", "decode_description"]

AGENT, SKILL = "Agent", "Skill"
CONTROLS, HAS_A, HAS_SKILL = "controls", "hasA", "hasSkill"

_decoder = msgspec.json.Decoder(SkillDescription)


class AgentInfo(msgspec.Struct, frozen=True, kw_only=True):
    """One agent: its robot (or appliance), that machine's devices and its skills."""

    name: str
    robot: str | None = None
    """Element id of the machine the agent controls (None: it controls none)."""
    devices: tuple[str, ...] = ()
    """Element ids of the robot's parts reached through ``hasA``, in natural id order."""
    skills: tuple[SkillDescription, ...] = ()
    available: bool = True
    id: str = ""
    """The agent's own element id."""
    problems: tuple[str, ...] = ()
    """Why a registered skill is missing from ``skills``."""

    def skill(self, name: str) -> SkillDescription | None:
        return next((s for s in self.skills if s.name == name), None)

    @property
    def hardware(self) -> tuple[str, ...]:
        """The robot and its devices: what hardware parameters may be bound to."""
        return ((self.robot,) if self.robot else ()) + self.devices


def decode_description(element: Element) -> SkillDescription:
    """The SkillDescription stored on a Skill element; DiscoveryError if there is none."""
    text = element.properties.get("description")
    if not isinstance(text, str) or not text:
        raise DiscoveryError(f"skill {element.id} ({element.label!r}) has no description")
    try:
        desc = _decoder.decode(text)
    except msgspec.DecodeError as exc:
        raise DiscoveryError(
            f"skill {element.id} ({element.label!r}): unreadable description: {exc}"
        ) from None
    if element.label and desc.name != element.label:
        raise DiscoveryError(
            f"skill {element.id}: its label {element.label!r} differs from its description's "
            f"name {desc.name!r}"
        )
    return desc


def _parts(view: WorldView, robot: str) -> tuple[str, ...]:
    found: set[str] = set()
    todo = [robot]
    while todo:
        for rel in view.query_relation(todo.pop(), HAS_A):
            if rel.object not in found and rel.object != robot:
                found.add(rel.object)
                todo.append(rel.object)
    return tuple(sorted(found, key=id_sort_key))


def _agent(view: WorldView, element: Element, alive: Collection[str] | None) -> AgentInfo:
    controls = view.query_relation(element.id, CONTROLS)
    robot = controls[0].object if controls else None
    skills: list[SkillDescription] = []
    problems: list[str] = []
    for rel in view.query_relation(element.id, HAS_SKILL):
        skill = view.find_element(rel.object)
        if skill is None:
            continue
        try:
            skills.append(decode_description(skill))
        except DiscoveryError as exc:
            problems.append(str(exc))
    if len(controls) > 1:
        others = ", ".join(r.object for r in controls[1:])
        problems.append(f"controls several machines; planning with {robot}, not {others}")
    available = element.properties.get("available", True) is not False
    name = element.label or element.id
    if alive is not None and name not in alive:
        available = False
    return AgentInfo(
        name=name,
        robot=robot,
        devices=_parts(view, robot) if robot else (),
        skills=tuple(sorted(skills, key=lambda s: s.name)),
        available=available,
        id=element.id,
        problems=tuple(problems),
    )


def agents_from_view(
    view: WorldView, *, alive: Collection[str] | None = None, include_unavailable: bool = False
) -> list[AgentInfo]:
    """Every agent registered in ``view``, sorted by name.

    ``alive``: names of agents whose liveliness token is present; an agent not in it is
    unavailable. Unavailable agents are left out unless ``include_unavailable``."""
    if AGENT not in view.ontology.classes:
        return []
    agents = [_agent(view, e, alive) for e in view.resolve_element(type=AGENT)]
    if not include_unavailable:
        agents = [a for a in agents if a.available]
    return sorted(agents, key=lambda a: a.name)
