"""A site of many robots: one kitting cell per robot, for planning at scale.

Cell ``i`` (1-based): a station ``station-i`` (one robot's work spot, ``robotCapacity`` 1)
four metres apart along x, holding a part box ``box-i`` with two gears; robot ``robot-i``
(agent ``r<i>``, a mobile manipulator with an arm, a gripper, a base and a camera) carries a
kit box ``kit-i`` and starts at the shared depot (an open place), or, with
``start="cells"``, at its own station. The robots offer the standard library's ``navigate``,
``locate``, ``pick``, ``place`` and ``serve`` skills. The goal :func:`one_gear_each` puts
one gear of each robot's own cell into its kit; :func:`one_gear_each` with ``robots`` a
subset names only those robots' kits.
"""

from __future__ import annotations

from collections.abc import Iterable, Sequence
from typing import Literal

import msgspec

from skill_agent.protocol import SkillDescription
from skill_agent.skills import Locate, Navigate, Pick, Place, Serve
from task_agent import Goal, parse_goal
from task_agent.verification import SceneView
from wm_store import DeviceSpec, RobotRegistration, SkillSpec, registration_ops
from wm_store.ontology import Ontology
from wm_store.protocol import AddElement, Op, Pose, Position, Relation, SetRelation, Value
from wm_store.scene import SceneState, apply_transaction

__all__ = ["Fleet", "fleet_scene", "mobile_manipulator", "one_gear_each", "skill_specs"]

_json = msgspec.json.Encoder()
SKILLS = (Navigate, Locate, Pick, Place, Serve)


class Fleet(msgspec.Struct, kw_only=True):
    view: SceneView
    agents: list[str]
    robots: list[str]
    kits: list[str]
    gears: list[list[str]]
    """The gears of each robot's cell, in robot order."""
    stations: list[str]
    depot: str


def _apply(state: SceneState, onto: Ontology, ops: Sequence[Op]) -> dict[str, str]:
    result = apply_transaction(state, onto, ops, revision=state.revision + 1, now=1.0)
    state.revision += 1
    return result.ids


def skill_specs(descriptions: Iterable[SkillDescription]) -> list[SkillSpec]:
    """The registration form of skill descriptions."""
    return [
        SkillSpec(name=d.name, skill_type=d.family, description=_json.encode(d).decode())
        for d in descriptions
    ]


def mobile_manipulator(i: int, skills: Sequence[SkillSpec]) -> RobotRegistration:
    """Agent ``r<i>`` registering ``robot-<i>``, a mobile manipulator with an arm, a gripper,
    a base and a camera (``arm-<i>`` ...), offering ``skills``."""
    return RobotRegistration(
        agent=f"r{i}",
        robot_type="MobileManipulator",
        robot_label=f"robot-{i}",
        devices=[
            DeviceSpec(type=t, label=f"{t.lower()}-{i}")
            for t in ("Arm", "Gripper", "MobileBase", "Camera")
        ],
        skills=list(skills),
    )


def fleet_scene(
    robots: int, *, start: Literal["depot", "cells"] = "depot", ontology: Ontology | None = None
) -> Fleet:
    """The site of the module doc with ``robots`` cells and robots."""
    onto = ontology or Ontology.default()
    state = SceneState()
    state.set_spatial_predicates(n for n, r in onto.relations.items() if r.spatial)
    depot_pose: dict[str, Value] = {"pose": Pose(Position(0.0, -4.0, 0.0))}
    ops: list[Op] = [
        AddElement(type="Location", label="depot", ref="$depot", properties=depot_pose),
    ]
    for i in range(1, robots + 1):
        pose = Pose(Position(4.0 * i, 0.0, 0.0))
        ops += [
            AddElement(
                type="Station",
                label=f"station-{i}",
                ref=f"$s{i}",
                properties={"pose": pose, "robotCapacity": 1},
            ),
            AddElement(
                type="PartBox",
                label=f"box-{i}",
                ref=f"$b{i}",
                relations=[Relation(f"$s{i}", "contain", "$"), Relation("$", "at", f"$s{i}")],
            ),
            *(
                AddElement(
                    type="Gear",
                    label=f"gear-{i}.{g}",
                    ref=f"$g{i}.{g}",
                    properties={"mass": 0.1},
                    relations=[Relation(f"$b{i}", "contain", "$")],
                )
                for g in (1, 2)
            ),
        ]
    ids = _apply(state, onto, ops)
    subclasses = {c: onto.subclasses(c) for c in ("Agent", "Robot", "Skill")}
    specs = skill_specs(s.description for s in SKILLS)
    fleet = Fleet(
        view=SceneView(state, onto),
        agents=[],
        robots=[],
        kits=[],
        gears=[],
        stations=[],
        depot=ids["$depot"],
    )
    for i in range(1, robots + 1):
        reg = mobile_manipulator(i, specs)
        robot = _apply(state, onto, registration_ops(state, reg, subclasses=subclasses))["$robot"]
        where = ids["$depot"] if start == "depot" else ids[f"$s{i}"]
        kit = _apply(
            state,
            onto,
            [
                AddElement(
                    type="KitBox",
                    label=f"kit-{i}",
                    ref="$kit",
                    relations=[Relation(robot, "contain", "$")],
                ),
                SetRelation(subject=robot, predicate="at", object=where),
            ],
        )["$kit"]
        fleet.agents.append(reg.agent)
        fleet.robots.append(robot)
        fleet.kits.append(kit)
        fleet.gears.append([ids[f"$g{i}.{g}"] for g in (1, 2)])
        fleet.stations.append(ids[f"$s{i}"])
    return fleet


def one_gear_each(fleet: Fleet, robots: Sequence[int] | None = None) -> Goal:
    """One gear of robot ``i``'s cell into its kit, for each ``i`` of ``robots`` (0-based;
    default: every robot)."""
    chosen = range(len(fleet.robots)) if robots is None else robots
    text = " and ".join(f"contain({fleet.kits[i]}, {fleet.gears[i][0]})" for i in chosen)
    return parse_goal(text, fleet.view)
