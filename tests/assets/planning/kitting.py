"""Kitting (SkiROS / STAMINA): mobile manipulators carry a kit box each and fill it with parts
taken from part boxes at stations; a smart microwave with its own agent (FRIEND II).

Skills, written as the standard library (``skill_agent.skills``) describes them:

``navigate(robot, base, start, goal)``
    robot at ``start``, not at ``goal``, the goal has a pose -> at ``goal``, not at ``start``.
``pick(object, holder, location, robot, arm, gripper, sensor[, platform])``
    gripper empty, the holder (not an appliance) contains the object, robot and holder at the
    location -> the gripper contains the object (which leaves the holder: ``contain`` is
    spatial). ``mass < 5`` is checked at run time only.
``place(object, container, robot, arm, gripper, sensor[, platform])``
    the gripper holds the object, the robot carries the container (not full: run time only)
    -> the container contains it, the gripper does not.
``take_out(object, appliance, location, ...)``
    like pick, from an appliance whose door is open.
``open_door(appliance, door)``
    the appliance agent's own skill: door closed, not heating -> door open.
"""

from __future__ import annotations

from collections.abc import Sequence

import msgspec

from skill_agent.protocol import (
    EmptyCond,
    HasPropertyCond,
    IsTypeCond,
    NotCond,
    ParamSpec,
    PropertyCond,
    RelationCond,
    SkillDescription,
)
from task_agent.verification import SceneView
from wm_store import DeviceSpec, RobotRegistration, SkillSpec, registration_ops
from wm_store.ontology import Ontology
from wm_store.protocol import (
    AddElement,
    Op,
    Pose,
    Position,
    Relation,
    SetRelation,
    Value,
)
from wm_store.scene import SceneState, apply_transaction

OBJECT = ParamSpec(name="object", type="PhysicalObject")
LOCATION = ParamSpec(name="location", type="Location")
ROBOT = ParamSpec(name="robot", type="Robot", kind="hardware")
ARM = ParamSpec(name="arm", type="Arm", kind="hardware")
GRIPPER = ParamSpec(name="gripper", type="Gripper", kind="hardware")
SENSOR = ParamSpec(name="sensor", type="Sensor", kind="hardware")
PLATFORM = ParamSpec(name="platform", type="SmartPlatform", kind="hardware", optional=True)
DEVICES = [ROBOT, ARM, GRIPPER, SENSOR, PLATFORM]


def contains(holder: str, thing: str, holds: bool = True) -> RelationCond:
    return RelationCond(subject=holder, predicate="contain", object=thing, holds=holds)


def at(thing: str, location: str, holds: bool = True) -> RelationCond:
    return RelationCond(subject=thing, predicate="at", object=location, holds=holds)


def door_is(appliance: str, open_: bool) -> PropertyCond:
    return PropertyCond(param=appliance, property="doorOpen", value=open_)


NAVIGATE = SkillDescription(
    name="navigate",
    skill_type="navigate",
    doc="Drive the robot to a location.",
    parameters=[
        ROBOT,
        ParamSpec(name="base", type="MobileBase", kind="hardware"),
        ParamSpec(name="start", type="Location"),
        ParamSpec(name="goal", type="Location"),
        ParamSpec(name="speed", type="float", kind="offline", default=0.5),
    ],
    pre=[
        at("robot", "start"),
        at("robot", "goal", holds=False),
        HasPropertyCond(param="goal", property="pose"),
    ],
    post=[at("robot", "goal"), at("robot", "start", holds=False)],
    duration=5.0,
)

PICK = SkillDescription(
    name="pick",
    skill_type="pick",
    doc="Grasp an object from what holds it at the robot's location.",
    parameters=[
        OBJECT,
        ParamSpec(name="holder", type="PhysicalObject"),
        LOCATION,
        *DEVICES,
        ParamSpec(name="force", type="float", kind="offline", default=20.0),
    ],
    pre=[
        EmptyCond(param="gripper"),
        contains("holder", "object"),
        NotCond(item=IsTypeCond(param="holder", cls="Appliance")),
        at("robot", "location"),
        at("holder", "location"),
        PropertyCond(param="object", property="mass", op="lt", value=5.0),  # run time only
    ],
    hold=[contains("holder", "object")],
    post=[contains("gripper", "object")],
    duration=4.0,
)

PLACE = SkillDescription(
    name="place",
    skill_type="place",
    doc="Put the held object into a container the robot carries.",
    parameters=[OBJECT, ParamSpec(name="container", type="Container"), *DEVICES],
    pre=[
        contains("gripper", "object"),
        contains("robot", "container"),
        EmptyCond(param="container", full=True, holds=False),  # run time only: not full
    ],
    hold=[contains("gripper", "object")],
    post=[contains("container", "object"), contains("gripper", "object", holds=False)],
    duration=4.0,
)

TAKE_OUT = SkillDescription(
    name="take_out",
    skill_type="pick",
    doc="Take an object out of an appliance whose door is open.",
    parameters=[OBJECT, ParamSpec(name="appliance", type="Appliance"), LOCATION, *DEVICES],
    pre=[
        EmptyCond(param="gripper"),
        contains("appliance", "object"),
        door_is("appliance", True),
        at("robot", "location"),
        at("appliance", "location"),
    ],
    hold=[contains("appliance", "object"), door_is("appliance", True)],
    post=[contains("gripper", "object")],
    duration=5.0,
)

OPEN_DOOR = SkillDescription(
    name="open_door",
    skill_type="open_door",
    doc="Open the appliance's door with its own motor.",
    parameters=[
        ParamSpec(name="appliance", type="Appliance", kind="hardware"),
        ParamSpec(name="door", type="Door"),
    ],
    pre=[
        RelationCond(subject="appliance", predicate="hasA", object="door"),
        door_is("appliance", False),
        PropertyCond(param="appliance", property="heating", value=False),
    ],
    post=[door_is("appliance", True)],
    duration=2.0,
)

_json = msgspec.json.Encoder()


class KittingScene(msgspec.Struct, kw_only=True):
    view: SceneView
    robots: list[str]
    """Robot element ids, in agent order (agent ``r<i>`` controls ``robots[i-1]``)."""
    agents: list[str]
    kits: list[str]
    """Kit box element ids, one per robot, same order."""
    parts: list[str]
    stations: list[str]
    depot: str


def _pose(x: float) -> dict[str, Value]:
    return {"pose": Pose(Position(float(x) * 2.0, 0.0, 0.0))}


def _apply(state: SceneState, ontology: Ontology, ops: Sequence[Op]) -> dict[str, str]:
    result = apply_transaction(state, ontology, ops, revision=state.revision + 1, now=1.0)
    state.revision += 1
    return result.ids


def kitting_scene(
    robots: int = 2,
    parts: int = 8,
    *,
    stations: int = 2,
    boxes_per_station: int = 2,
    skills: Sequence[SkillDescription] = (NAVIGATE, PICK, PLACE),
    ontology: Ontology | None = None,
    station_capacity: int | None = None,
) -> KittingScene:
    """``robots`` agents ``r1..rN`` (mobile manipulators with a gripper, a kit box on board,
    at the depot: open floor) and ``parts`` gears spread over part boxes at ``stations``
    stations, each with room for every robot (``robotCapacity``: nothing is counted) unless
    ``station_capacity`` says how many robots a station holds."""
    onto = ontology or Ontology.default()
    state = SceneState()
    state.set_spatial_predicates(n for n, r in onto.relations.items() if r.spatial)
    room = max(robots, 2) if station_capacity is None else station_capacity
    ops: list[Op] = [AddElement(type="Location", label="depot", ref="$depot", properties=_pose(0))]
    for s in range(stations):
        ops.append(
            AddElement(
                type="Station",
                label=f"station-{s + 1}",
                ref=f"$s{s}",
                properties={**_pose(s + 1), "robotCapacity": room},
            )
        )
        for b in range(boxes_per_station):
            ops.append(
                AddElement(
                    type="PartBox",
                    label=f"box-{s + 1}.{b + 1}",
                    ref=f"$b{s}.{b}",
                    relations=[Relation(f"$s{s}", "contain", "$"), Relation("$", "at", f"$s{s}")],
                )
            )
    boxes = [f"$b{s}.{b}" for s in range(stations) for b in range(boxes_per_station)]
    for p in range(parts):
        ops.append(
            AddElement(
                type="Gear",
                label=f"gear-{p + 1}",
                ref=f"$p{p}",
                properties={"mass": 0.1},
                relations=[Relation(boxes[p % len(boxes)], "contain", "$")],
            )
        )
    ids = _apply(state, onto, ops)
    subclasses = {c: onto.subclasses(c) for c in ("Agent", "Robot", "Skill")}
    skill_specs = [
        SkillSpec(name=d.name, skill_type=d.family, description=_json.encode(d).decode())
        for d in skills
    ]
    robot_ids, kit_ids, agent_names = [], [], []
    for r in range(robots):
        reg = RobotRegistration(
            agent=f"r{r + 1}",
            robot_type="MobileManipulator",
            robot_label=f"robot-{r + 1}",
            devices=[
                DeviceSpec(type="Arm", label=f"arm-{r + 1}"),
                DeviceSpec(type="Gripper", label=f"gripper-{r + 1}"),
                DeviceSpec(type="MobileBase", label=f"base-{r + 1}"),
                DeviceSpec(type="Camera", label=f"camera-{r + 1}"),
            ],
            skills=skill_specs,
        )
        reg_ids = _apply(state, onto, registration_ops(state, reg, subclasses=subclasses))
        robot = reg_ids["$robot"]
        kit = _apply(
            state,
            onto,
            [
                AddElement(
                    type="KitBox",
                    label=f"kit-{r + 1}",
                    ref="$kit",
                    relations=[Relation(robot, "contain", "$")],
                ),
                SetRelation(subject=robot, predicate="at", object=ids["$depot"]),
            ],
        )["$kit"]
        robot_ids.append(robot)
        kit_ids.append(kit)
        agent_names.append(reg.agent)
    return KittingScene(
        view=SceneView(state, onto),
        robots=robot_ids,
        agents=agent_names,
        kits=kit_ids,
        parts=[ids[f"$p{p}"] for p in range(parts)],
        stations=[ids[f"$s{s}"] for s in range(stations)],
        depot=ids["$depot"],
    )


def add_microwave(
    scene: KittingScene,
    *,
    station: int = 1,
    door_open: bool = False,
    content: str = "hot gear",
    skills: Sequence[SkillDescription] = (),
) -> tuple[str, str]:
    """A microwave (with its door) at ``stations[station]`` holding a gear labelled
    ``content``; with ``skills``, an appliance agent ``oven-agent`` controls it and offers them.
    Returns (microwave id, gear id)."""
    state, onto = scene.view.state, scene.view.ontology
    where = scene.stations[station]
    ids = _apply(
        state,
        onto,
        [
            AddElement(
                type="Microwave",
                label="oven",
                ref="$m",
                properties={"doorOpen": door_open, "heating": False},
                relations=[Relation(where, "contain", "$"), Relation("$", "at", where)],
            ),
            AddElement(
                type="MicrowaveDoor", label="oven door", relations=[Relation("$m", "hasA", "$")]
            ),
            AddElement(
                type="Gear", label=content, ref="$g", relations=[Relation("$m", "contain", "$")]
            ),
        ],
    )
    if skills:
        reg = RobotRegistration(
            agent="oven-agent",
            agent_type="DeviceAgent",
            robot_type="Microwave",
            robot_label="oven",
            skills=[
                SkillSpec(name=d.name, skill_type=d.family, description=_json.encode(d).decode())
                for d in skills
            ],
        )
        subclasses = {c: onto.subclasses(c) for c in ("Agent", "Robot", "Skill")}
        _apply(state, onto, registration_ops(state, reg, subclasses=subclasses))
    return ids["$m"], ids["$g"]


def apply_ops(scene: KittingScene, ops: Sequence[Op]) -> dict[str, str]:
    """Commit ``ops`` to the scene (validated like a store transaction); the new ids."""
    return _apply(scene.view.state, scene.view.ontology, ops)
