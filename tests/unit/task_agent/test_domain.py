"""Skill descriptions + world model -> planning task: actions per agent, types, predicates,
initial facts, implicit effects, compression and the replayed semantics."""

from __future__ import annotations

import pytest

from skill_agent.protocol import (
    EmptyCond,
    IsTypeCond,
    ParamSpec,
    PropertyCond,
    RelationCond,
    SkillDescription,
)
from task_agent import DomainError, parse_goal
from task_agent.discovery import AgentInfo, agents_from_view
from task_agent.domain import ROOT_TYPE, ForallDelete, Lit, PlanningTask, build_task
from task_agent.reachability import GroundStep, State, apply, relevant_objects, replay
from tests.assets.planning import (
    NAVIGATE,
    OPEN_DOOR,
    PICK,
    PLACE,
    TAKE_OUT,
    KittingScene,
    add_microwave,
    apply_ops,
    kitting_scene,
)
from wm_store.protocol import AddElement, Relation

GRIPPER = ParamSpec(name="gripper", type="Gripper", kind="hardware")
OBJECT = ParamSpec(name="object", type="Part")


def task_for(scene: KittingScene, goal: str) -> PlanningTask:
    return build_task(agents_from_view(scene.view), scene.view, parse_goal(goal, scene.view))


@pytest.fixture(scope="module")
def kitting() -> tuple[KittingScene, PlanningTask]:
    scene = kitting_scene(2, 8)
    return scene, task_for(scene, "contain(KitBox-1, Gear-1) and contain(KitBox-2, Gear-2)")


def test_one_action_per_agent_and_skill(kitting: tuple[KittingScene, PlanningTask]) -> None:
    scene, task = kitting
    assert sorted(task.actions) == [
        "navigate__r1",
        "navigate__r2",
        "pick__r1",
        "pick__r2",
        "place__r1",
        "place__r2",
    ]
    pick1, pick2 = task.actions["pick__r1"], task.actions["pick__r2"]
    assert (pick1.agent, pick1.skill, pick1.family) == ("r1", "pick", "pick")
    # hardware bound to each robot's own devices; the optional platform left out (none)
    assert pick1.bound == {
        "robot": scene.robots[0],
        "arm": "Arm-1",
        "gripper": "Gripper-1",
        "sensor": "Camera-1",
    }
    assert pick2.bound["gripper"] == "Gripper-2" and pick2.bound["robot"] == scene.robots[1]
    assert pick1.params == (
        ("object", "PhysicalObject"),
        ("holder", "PhysicalObject"),
        ("location", "Location"),
    )
    assert Lit("at", (scene.robots[0], "?location")) in pick1.pre
    assert Lit("is_Appliance", ("?holder",), False) in pick1.pre
    assert Lit("contain", ("?holder", "?object")) in pick1.pre  # pre and hold, once
    assert pick1.empty_pre == ((("contain",), "Gripper-1", True),)
    assert pick1.duration == PICK.duration
    assert pick1.runtime_only == ("pre object.mass < 5.0",)
    assert task.actions["place__r1"].runtime_only == ("pre not full(container)",)
    navigate = task.actions["navigate__r1"]
    assert navigate.bound == {"robot": scene.robots[0], "base": "MobileBase-1"}
    assert Lit("has_pose", ("?goal",)) in navigate.pre


def test_types_objects_and_initial_facts(kitting: tuple[KittingScene, PlanningTask]) -> None:
    scene, task = kitting
    assert task.types == {
        "PhysicalObject": ROOT_TYPE,
        "Container": "PhysicalObject",
        "Location": ROOT_TYPE,
    }
    assert task.objects["Gear-1"] == task.objects["Gripper-1"] == "PhysicalObject"
    assert task.objects["KitBox-1"] == task.objects["PartBox-1"] == "Container"
    assert task.objects["Station-1"] == task.objects[scene.depot] == "Location"
    assert "Skill-1" not in task.objects
    assert set(task.predicates) == {"contain", "at", "has_pose", "is_Appliance"}
    assert task.predicates["is_Appliance"].static
    assert not any(f[0] == "is_Appliance" for f in task.init)
    assert ("has_pose", ("Station-1",)) in task.init
    assert ("contain", ("PartBox-1", "Gear-1")) in task.init
    assert ("at", (scene.robots[0], scene.depot)) in task.init
    assert ("contain", ("Station-1", "PartBox-1")) in task.init
    assert task.goal == (
        Lit("contain", ("KitBox-1", "Gear-1")),
        Lit("contain", ("KitBox-2", "Gear-2")),
    )


def test_spatial_effects_delete_the_named_parent(
    kitting: tuple[KittingScene, PlanningTask],
) -> None:
    _, task = kitting
    pick, place = task.actions["pick__r1"], task.actions["place__r1"]
    # pick's precondition names the holder of the object: that fact goes, no forall
    assert pick.add == (Lit("contain", ("Gripper-1", "?object")),)
    assert pick.delete == (Lit("contain", ("?holder", "?object"), False),)
    assert pick.forall_delete == ()
    assert place.add == (Lit("contain", ("?container", "?object")),)
    assert place.delete == (Lit("contain", ("Gripper-1", "?object"), False),)
    assert place.forall_delete == ()


def test_emptying_a_gripper_deletes_what_it_held() -> None:
    drop_in = SkillDescription(
        name="drop_in",
        parameters=[OBJECT, ParamSpec(name="container", type="Container"), GRIPPER],
        pre=[RelationCond(subject="gripper", predicate="contain", object="object")],
        post=[
            RelationCond(subject="container", predicate="contain", object="object"),
            EmptyCond(param="gripper"),
        ],
    )
    task = task_for(kitting_scene(1, 1, skills=(drop_in,)), "contain(KitBox-1, Gear-1)")
    action = task.actions["drop_in__r1"]
    # a gripper holds one thing at most (ontology): "empty" deletes the one named
    assert action.delete == (Lit("contain", ("Gripper-1", "?object"), False),)
    assert action.forall_delete == ()


def test_unknown_parent_and_unbounded_container_use_conditional_deletes() -> None:
    grab = SkillDescription(
        name="grab",
        parameters=[GRIPPER, OBJECT],
        post=[RelationCond(subject="gripper", predicate="contain", object="object")],
    )
    dump = SkillDescription(
        name="dump",
        parameters=[ParamSpec(name="box", type="Box")],
        pre=[RelationCond(subject="box", predicate="contain", object="box", holds=False)],
        post=[EmptyCond(param="box")],
    )
    scene = kitting_scene(1, 2, skills=(grab, dump))
    task = task_for(scene, "contain(Gripper-1, Gear-1)")
    assert task.actions["grab__r1"].forall_delete == (
        ForallDelete("contain", "contain", "?object", 0),
    )
    assert task.actions["dump__r1"].forall_delete == (
        ForallDelete("contain", "contain", "?box", 1),
    )
    state = State(task.init)
    failed, effects = apply(task, GroundStep("dump__r1", ("PartBox-1",)), state)
    assert not failed
    assert effects.dels == {("contain", ("PartBox-1", "Gear-1"))}
    assert ("contain", ("PartBox-1", "Gear-1")) not in state
    assert effects.patterns == {("contain", ("PartBox-1", None))}


def test_property_values_and_an_appliance_agent() -> None:
    scene = kitting_scene(1, 1, skills=(NAVIGATE, PICK, PLACE, TAKE_OUT))
    oven, gear = add_microwave(scene, skills=(OPEN_DOOR,))
    task = task_for(scene, f"contain(KitBox-1, {gear}) and heating({oven}) = false")
    assert {"doorOpen=true", "doorOpen=false", "heating=false", "hasA"} <= set(task.predicates)
    assert task.predicates["doorOpen=true"].pddl == "doorOpen_eq_true"
    assert ("doorOpen=false", (oven,)) in task.init
    assert ("heating=false", (oven,)) in task.init
    assert ("hasA", (oven, "MicrowaveDoor-1")) in task.init
    open_door = task.actions["open_door__oven_agent"]
    assert (open_door.agent, open_door.bound) == ("oven-agent", {"appliance": oven})
    assert open_door.params == (("door", "Door"),)
    assert open_door.add == (Lit("doorOpen=true", (oven,)),)
    assert open_door.delete == (Lit("doorOpen=false", (oven,), False),)
    take_out = task.actions["take_out__r1"]
    assert Lit("doorOpen=true", ("?appliance",)) in take_out.pre
    assert take_out.params[1] == ("appliance", "Appliance")
    assert task.types["Appliance"] == task.types["Door"] == "PhysicalObject"
    assert ("is_Appliance", (oven,)) in task.init


def test_several_fitting_devices_stay_a_parameter_restricted_to_the_agent() -> None:
    scene = kitting_scene(2, 2)
    apply_ops(
        scene,
        [
            AddElement(
                type="Gripper", label="second", relations=[Relation(scene.robots[0], "hasA", "$")]
            )
        ],
    )
    task = task_for(scene, "contain(KitBox-1, Gear-1)")
    pick1, pick2 = task.actions["pick__r1"], task.actions["pick__r2"]
    assert "gripper" not in pick1.bound and ("gripper", "Gripper") in pick1.params
    assert Lit("owns", (scene.robots[0], "?gripper")) in pick1.pre
    assert pick2.bound["gripper"] == "Gripper-2"
    assert {f for f in task.init if f[0] == "owns"} == {
        ("owns", (scene.robots[0], "Gripper-1")),
        ("owns", (scene.robots[0], "Gripper-3")),
    }


def test_classes_the_type_tree_cannot_hold_become_static_predicates() -> None:
    wipe = SkillDescription(
        name="wipe",
        parameters=[
            ParamSpec(name="surface", type="Surface"),
            ParamSpec(name="robot", type="Robot", kind="hardware"),
        ],
        pre=[RelationCond(subject="robot", predicate="at", object="surface")],
        post=[PropertyCond(param="surface", property="available", value=True)],
    )
    move = SkillDescription(
        name="shift",
        parameters=[
            ParamSpec(name="thing", type="Furniture"),
            ParamSpec(name="to", type="Location"),
        ],
        pre=[IsTypeCond(param="thing", cls="Furniture")],
        post=[RelationCond(subject="thing", predicate="at", object="to")],
    )
    scene = kitting_scene(1, 1, skills=(wipe, move))
    apply_ops(scene, [AddElement(type="Shelf", label="shelf")])  # a Surface and a Furniture
    task = task_for(scene, "available(Shelf-1) = true")
    # a Shelf is typed Surface (under Location): Furniture parameters check is_Furniture
    assert task.objects["Shelf-1"] == "Surface"
    assert task.types["Surface"] == "Location"
    assert {p for p in task.predicates if p.startswith("is_")} == {"is_Furniture"}
    assert ("is_Furniture", ("Shelf-1",)) in task.init
    shift = task.actions["shift__r1"]
    assert shift.params == (("thing", ROOT_TYPE), ("to", "Location"))
    assert Lit("is_Furniture", ("?thing",)) in shift.pre


def test_skills_the_planner_cannot_use_are_skipped_with_the_reason() -> None:
    posed = SkillDescription(
        name="move_to",
        parameters=[ParamSpec(name="target", type="Pose")],
        post=[RelationCond(subject="x", predicate="at", object="y")],
    )
    nothing = SkillDescription(
        name="wave",
        parameters=[],
        post=[PropertyCond(param="x", property="mass", op="gt", value=1.0)],
    )
    drill = SkillDescription(
        name="drill",
        parameters=[ParamSpec(name="tool", type="ForceTorqueSensor", kind="hardware"), OBJECT],
        post=[RelationCond(subject="tool", predicate="contain", object="object")],
    )
    scene = kitting_scene(1, 1, skills=(PICK, posed, nothing, drill))
    task = task_for(scene, "contain(Gripper-1, Gear-1)")
    assert list(task.actions) == ["pick__r1"]
    text = "\n".join(task.skipped)
    assert "move_to on r1: needs a Pose value for 'target'" in text
    assert "wave on r1: no symbolic post-condition" in text
    assert "drill on r1: agent 'r1' has no ForceTorqueSensor for hardware parameter 'tool'" in text
    with pytest.raises(DomainError, match="no skill can be planned with: wave on r1"):
        build_task(
            [AgentInfo(name="r1", skills=(nothing,))],
            scene.view,
            parse_goal("contain(KitBox-1, Gear-1)", scene.view),
        )
    with pytest.raises(DomainError, match="no available agent"):
        build_task([], scene.view, parse_goal("contain(KitBox-1, Gear-1)", scene.view))


def test_unavailable_agents_get_no_actions() -> None:
    scene = kitting_scene(2, 1)
    agents = [
        a if a.name == "r1" else AgentInfo(name=a.name, available=False)
        for a in agents_from_view(scene.view)
    ]
    task = build_task(agents, scene.view, parse_goal("contain(KitBox-1, Gear-1)", scene.view))
    assert {a.agent for a in task.actions.values()} == {"r1"}


def test_compression_keeps_what_the_goal_can_touch() -> None:
    scene = kitting_scene(2, 8)
    apply_ops(
        scene,
        [AddElement(type="Bolt", label="held", relations=[Relation("Gripper-1", "contain", "$")])],
    )
    task = task_for(scene, "contain(KitBox-1, Gear-1)")
    keep = relevant_objects(task)
    assert {"Gear-1", "KitBox-1", "PartBox-1", "Station-1", "Gripper-1", scene.robots[0]} <= keep
    assert "Bolt-1" in keep  # the gripper must be emptied first
    assert not {"Gear-2", "Gear-3", "Gear-8"} & keep
    small = task.restrict(keep)
    assert set(small.objects) == keep
    assert all(set(args) <= keep for _, args in small.init)


def test_replay_reports_the_first_false_precondition(
    kitting: tuple[KittingScene, PlanningTask],
) -> None:
    scene, task = kitting
    steps = [
        GroundStep("navigate__r1", (scene.depot, "Station-1")),
        GroundStep("pick__r1", ("Gear-1", "PartBox-1", "Station-1")),
        GroundStep("place__r1", ("Gear-1", "KitBox-1")),
    ]
    effects, problem = replay(task, steps)
    assert problem == "the goal does not hold at the end: contain(KitBox-2, Gear-2)"
    assert effects[1].adds == {("contain", ("Gripper-1", "Gear-1"))}
    assert effects[1].dels == {("contain", ("PartBox-1", "Gear-1"))}
    assert ("at", (scene.robots[0], "Station-1")) in effects[1].reads
    _, problem = replay(task, steps[1:])
    assert problem.startswith("step 1 pick__r1")
    assert f"false precondition at({scene.robots[0]}, Station-1)" in problem
