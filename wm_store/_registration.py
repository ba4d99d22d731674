"""Robot registration (SkiROS ``registerRobot``): an agent puts itself, its robot, the robot's
devices and its skills into the world model in one transaction, so a task agent can discover it.

Resulting sub-graph::

    Agent "<agent>"  --controls-->  Robot  --hasA-->  Device (Arm, Gripper, MobileBase, ...)
         |
         +--hasSkill--> Skill "<skill name>" {skillType, description}

Re-registering (an agent restarted) updates the Agent element and replaces its skills; the
robot and its devices are reused by label, since they are physical things that outlive the
agent. Unregistering removes the Agent and its Skill elements and leaves the robot in place.
"""

from __future__ import annotations

from collections.abc import Mapping

import msgspec

from wm_store.protocol import (
    AddElement,
    Op,
    Relation,
    RemoveElement,
    SetRelation,
    UpdateElement,
    Value,
)
from wm_store.scene import SceneState

__all__ = [
    "DeviceSpec",
    "RobotRegistration",
    "SkillSpec",
    "registration_ops",
    "unregistration_ops",
]

AGENT, ROBOT, SKILL = "Agent", "Robot", "Skill"
CONTROLS, HAS_A, HAS_SKILL = "controls", "hasA", "hasSkill"


class DeviceSpec(msgspec.Struct, frozen=True, kw_only=True):
    type: str
    label: str
    properties: dict[str, Value] = {}


class SkillSpec(msgspec.Struct, frozen=True, kw_only=True):
    name: str
    skill_type: str = ""
    description: str = ""
    """The skill description, encoded as JSON by the skill layer."""


class RobotRegistration(msgspec.Struct, frozen=True, kw_only=True):
    agent: str
    """The agent's name: its liveliness token is ``agents/<agent>``."""
    agent_type: str = "RobotAgent"
    address: str = ""
    hostname: str = ""
    robot_type: str = "Robot"
    robot_label: str = ""
    """The robot (or appliance) this agent controls; reused if one with that label exists."""
    robot_properties: dict[str, Value] = {}
    devices: list[DeviceSpec] = []
    skills: list[SkillSpec] = []


def _one_with_label(state: SceneState, label: str, types: frozenset[str]) -> str | None:
    ids = sorted(i for i in state.ids_with_label(label) if state.elements[i].type in types)
    return ids[0] if ids else None


def registration_ops(
    state: SceneState,
    reg: RobotRegistration,
    *,
    subclasses: Mapping[str, frozenset[str]],
) -> list[Op]:
    """The transaction that registers ``reg`` against the current ``state``.

    ``subclasses`` maps "Agent", "Robot" and "Skill" to their subclass closures (from the
    ontology), so an existing element of a subclass is recognised.
    """
    ops: list[Op] = []
    agent_props: dict[str, Value] = {"available": True, "address": reg.address}
    if reg.hostname:
        agent_props["hostname"] = reg.hostname
    agent_id = _one_with_label(state, reg.agent, subclasses[AGENT])
    if agent_id is None:
        ops.append(
            AddElement(type=reg.agent_type, label=reg.agent, properties=agent_props, ref="$agent")
        )
        agent_ref = "$agent"
    else:
        ops.append(UpdateElement(id=agent_id, properties=agent_props))
        agent_ref = agent_id
        for rel in state.match_relations(agent_id, (HAS_SKILL,)):
            ops.append(RemoveElement(id=rel.object))
    robot_label = reg.robot_label or reg.agent
    robot_id = _one_with_label(state, robot_label, subclasses[ROBOT] | frozenset((reg.robot_type,)))
    if robot_id is None:
        ops.append(
            AddElement(
                type=reg.robot_type,
                label=robot_label,
                properties=dict(reg.robot_properties),
                ref="$robot",
            )
        )
        robot_ref = "$robot"
    else:
        if reg.robot_properties:
            ops.append(UpdateElement(id=robot_id, properties=dict(reg.robot_properties)))
        robot_ref = robot_id
    if (
        agent_id is None
        or robot_id is None
        or not state.has_relation(Relation(agent_id, CONTROLS, robot_id))
    ):
        ops.append(SetRelation(subject=agent_ref, predicate=CONTROLS, object=robot_ref))
    existing_devices = {
        state.elements[r.object].label: r.object
        for r in (state.match_relations(robot_id, (HAS_A,)) if robot_id else ())
    }
    for device in reg.devices:
        device_id = existing_devices.get(device.label)
        if device_id is None:
            ops.append(
                AddElement(
                    type=device.type,
                    label=device.label,
                    properties=dict(device.properties),
                    relations=[Relation(robot_ref, HAS_A, "$")],
                    ref=f"$device:{device.label}",
                )
            )
        elif device.properties:
            ops.append(UpdateElement(id=device_id, properties=dict(device.properties)))
    for skill in reg.skills:
        props: dict[str, Value] = {"skillType": skill.skill_type or skill.name}
        if skill.description:
            props["description"] = skill.description
        ops.append(
            AddElement(
                type=SKILL,
                label=skill.name,
                properties=props,
                relations=[Relation(agent_ref, HAS_SKILL, "$")],
                ref=f"$skill:{skill.name}",
            )
        )
    return ops


def unregistration_ops(state: SceneState, agent: str, *, agent_types: frozenset[str]) -> list[Op]:
    """Remove the agent's element and its skills; the robot and devices stay."""
    agent_id = _one_with_label(state, agent, agent_types)
    if agent_id is None:
        return []
    ops: list[Op] = [
        RemoveElement(id=r.object) for r in state.match_relations(agent_id, (HAS_SKILL,))
    ]
    ops.append(RemoveElement(id=agent_id))
    return ops
