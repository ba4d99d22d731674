"""Kitting (SkiROS / STAMINA): mobile manipulators carry a kit box each and fill it with parts
taken from part boxes at stations.

Skills, written as the standard library's descriptions will be:

``navigate(robot, start, goal)``
    robot at ``start`` and not at ``goal`` -> at ``goal``, not at ``start``.
``pick(object, box, station, gripper, robot)``
    gripper empty, the box contains the object, box and robot at the station -> the gripper
    contains the object (which leaves the box: ``contain`` is spatial).
``place(object, container, gripper, robot)``
    the gripper holds the object, the robot carries the container -> the container contains
    it and the gripper is empty.
``take_out(object, appliance, station, gripper, robot)``
    like pick, from an appliance whose door is open; ``open_door(appliance, station, robot)``
    opens it.
"""

from __future__ import annotations

from collections.abc import Sequence

import msgspec

from skill_agent.protocol import (
    EmptyCond,
    ParamSpec,
    PropertyCond,
    RelationCond,
    SkillDescription,
)
from wm_store.ontology import Ontology
from wm_store.protocol import AddElement, Element, Op, Query, Relation, SetRelation
from wm_store.query import match_relations, resolve
from wm_store.registration import DeviceSpec, RobotRegistration, SkillSpec, registration_ops
from wm_store.state import SceneState
from wm_store.transactions import apply_transaction

ROBOT = ParamSpec(name="robot", type="Robot", kind="hardware")
GRIPPER = ParamSpec(name="gripper", type="Gripper", kind="hardware")
STATION = ParamSpec(name="station", type="Location")

NAVIGATE = SkillDescription(
    name="navigate",
    doc="Drive the robot to a location.",
    parameters=[
        ROBOT,
        ParamSpec(name="base", type="MobileBase", kind="hardware"),
        ParamSpec(name="start", type="Location"),
        ParamSpec(name="goal", type="Location"),
        ParamSpec(name="speed", type="float", kind="offline", default=0.5),
    ],
    pre=[
        RelationCond(subject="robot", predicate="at", object="start"),
        RelationCond(subject="robot", predicate="at", object="goal", holds=False),
    ],
    post=[
        RelationCond(subject="robot", predicate="at", object="goal"),
        RelationCond(subject="robot", predicate="at", object="start", holds=False),
    ],
    duration=4.0,
)

PICK = SkillDescription(
    name="pick",
    doc="Pick a part out of a box at the robot's station.",
    parameters=[
        ParamSpec(name="object", type="Part"),
        ParamSpec(name="box", type="Box"),
        STATION,
        GRIPPER,
        ROBOT,
    ],
    pre=[
        EmptyCond(param="gripper"),
        RelationCond(subject="box", predicate="contain", object="object"),
        RelationCond(subject="box", predicate="at", object="station"),
        RelationCond(subject="robot", predicate="at", object="station"),
        PropertyCond(param="object", property="mass", op="lt", value=5.0),  # run time only
    ],
    post=[RelationCond(subject="gripper", predicate="contain", object="object")],
    duration=3.0,
)

PLACE = SkillDescription(
    name="place",
    doc="Put the held part into a container the robot carries.",
    parameters=[
        ParamSpec(name="object", type="Part"),
        ParamSpec(name="container", type="Container"),
        GRIPPER,
        ROBOT,
    ],
    pre=[
        RelationCond(subject="gripper", predicate="contain", object="object"),
        RelationCond(subject="robot", predicate="contain", object="container"),
    ],
    post=[
        RelationCond(subject="container", predicate="contain", object="object"),
        EmptyCond(param="gripper"),
    ],
    duration=2.0,
)

TAKE_OUT = SkillDescription(
    name="take_out",
    doc="Take a part out of an appliance whose door is open.",
    parameters=[
        ParamSpec(name="object", type="PhysicalObject"),
        ParamSpec(name="appliance", type="Appliance"),
        STATION,
        GRIPPER,
        ROBOT,
    ],
    pre=[
        EmptyCond(param="gripper"),
        RelationCond(subject="appliance", predicate="contain", object="object"),
        RelationCond(subject="appliance", predicate="at", object="station"),
        RelationCond(subject="robot", predicate="at", object="station"),
        PropertyCond(param="appliance", property="doorOpen", value=True),
    ],
    post=[RelationCond(subject="gripper", predicate="contain", object="object")],
    duration=3.0,
)

OPEN_DOOR = SkillDescription(
    name="open_door",
    doc="Open an appliance's door.",
    parameters=[ParamSpec(name="appliance", type="Appliance"), STATION, ROBOT],
    pre=[
        RelationCond(subject="appliance", predicate="at", object="station"),
        RelationCond(subject="robot", predicate="at", object="station"),
        PropertyCond(param="appliance", property="doorOpen", value=False),
    ],
    post=[PropertyCond(param="appliance", property="doorOpen", value=True)],
    duration=2.0,
)

_json = msgspec.json.Encoder()


class SceneView:
    """A synchronous :class:`skill_agent.skill.WorldView` over a scene (what a WmClient's
    replica offers, without the client)."""

    def __init__(self, state: SceneState, ontology: Ontology) -> None:
        self.state, self._ontology = state, ontology

    @property
    def ontology(self) -> Ontology:
        return self._ontology

    def get_element(self, element_id: str) -> Element:
        element = self.state.get(element_id)
        if element is None:
            raise KeyError(element_id)
        return element

    def find_element(self, element_id: str) -> Element | None:
        return self.state.get(element_id)

    def resolve_element(self, query: Query | None = None, *, type: str = "") -> list[Element]:
        return resolve(self.state, self._ontology, query or Query(type=type))

    def query_relation(
        self, subject: str = "", predicate: str = "", obj: str = ""
    ) -> list[Relation]:
        return match_relations(self.state, self._ontology, subject, predicate, obj)


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
) -> KittingScene:
    """``robots`` agents ``r1..rN`` (mobile manipulators with a gripper, a kit box on board,
    at the depot) and ``parts`` gears spread over part boxes at ``stations`` stations."""
    onto = ontology or Ontology.default()
    state = SceneState()
    state.set_spatial_predicates(n for n, r in onto.relations.items() if r.spatial)
    ops: list[Op] = [AddElement(type="Location", label="depot", ref="$depot")]
    for s in range(stations):
        ops.append(AddElement(type="Station", label=f"station-{s + 1}", ref=f"$s{s}"))
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
    scene: KittingScene, *, station: int = 1, door_open: bool = False, content: str = "hot gear"
) -> tuple[str, str]:
    """A microwave at ``stations[station]`` (door as given) holding a gear labelled
    ``content``; returns (microwave id, gear id)."""
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
                type="Gear", label=content, ref="$g", relations=[Relation("$m", "contain", "$")]
            ),
        ],
    )
    return ids["$m"], ids["$g"]


def apply_ops(scene: KittingScene, ops: Sequence[Op]) -> dict[str, str]:
    """Commit ``ops`` to the scene (validated like a store transaction); the new ids."""
    return _apply(scene.view.state, scene.view.ontology, ops)
