"""Offline verification of task files against the kitting and meal scenarios' world models and
their agents' real skill descriptions: the good files verify clean (and the symbolic
simulation predicts the kits filled), each crafted bad file is caught for its class of error,
and the finer points of each check."""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path

import msgspec
import pytest

from scenario import load_scenario
from scenario.wm import scenario_ops
from skill_agent.protocol import (
    CustomCond,
    ParamSpec,
    PropertyCond,
    RelationCond,
    SkillDescription,
)
from skill_agent.runtime import SkillRegistry, load_config
from task_agent.discovery import AgentInfo
from task_agent.protocol import Call, Parallel, TaskFile, VerifyProblem
from task_agent.protocol import Sequence as Seq
from task_agent.taskfile import load_task_file, read_task_file
from task_agent.verification import SceneView, check, verify
from wm_store import NameConflictError
from wm_store.ontology import Ontology
from wm_store.protocol import AddElement, Op, Query, Relation, UpdateElement, Value
from wm_store.scene import SceneState, apply_transaction

ROOT = Path(__file__).resolve().parents[3]
TASKS = ROOT / "tests" / "assets" / "tasks"

MEASURE = SkillDescription(
    name="measure",
    doc="A test skill of the 'inspector' agent: a required value, a class with no element.",
    parameters=[
        ParamSpec(name="object", type="PhysicalObject"),
        ParamSpec(name="tray", type="Tray"),
        ParamSpec(name="tolerance", type="float"),
    ],
)


class World(msgspec.Struct):
    view: SceneView
    agents: list[AgentInfo]


def world(scenario: str, extra: Sequence[AgentInfo] = ()) -> World:
    """The scenario's initial scene, and its agents as discovery would see them (robot,
    ``hasA`` devices, the skills of ``configs/agents/<scenario>/*.toml``)."""
    onto = Ontology.default()
    state = SceneState()
    state.set_spatial_predicates(n for n, r in onto.relations.items() if r.spatial)
    ops = scenario_ops(load_scenario(ROOT / "configs" / "scenarios" / scenario / "scenario.toml"))
    apply_transaction(state, onto, ops, revision=1, now=1.0)
    view = SceneView(state, onto)
    agents = list(extra)
    for path in sorted((ROOT / "configs" / "agents" / scenario).glob("*.toml")):
        config = load_config(path)
        registry = SkillRegistry.from_config(config, onto)
        registry.load()
        (robot,) = view.resolve_element(Query(label=config.robot_label))
        devices = sorted(r.object for r in view.query_relation(robot.id, "hasA"))
        skills = tuple(sorted(registry.descriptions(), key=lambda d: d.name))
        agents.append(
            AgentInfo(name=config.name, robot=robot.id, devices=tuple(devices), skills=skills)
        )
    return World(view, agents)


@pytest.fixture(scope="module")
def kitting() -> World:
    return world("kitting", [AgentInfo(name="inspector", skills=(MEASURE,))])


@pytest.fixture(scope="module")
def meal() -> World:
    return world("meal")


def with_ops(w: World, ops: list[Op]) -> World:
    state = w.view.state.copy()
    apply_transaction(state, w.view.ontology, ops, revision=state.revision + 1, now=2.0)
    return World(SceneView(state, w.view.ontology), w.agents)


def problems(w: World, task: TaskFile | str) -> list[tuple[str, str, str]]:
    if isinstance(task, str):
        task = load_task_file(task)
    return [(p.path, p.kind, p.message) for p in verify(task, w.view, w.agents)]


def seq(*children: Call | Seq | Parallel) -> TaskFile:
    return TaskFile(root=Seq(children=list(children)))


def par(*children: Call | Seq | Parallel, id: str = "") -> Parallel:
    return Parallel(children=list(children), id=id)


def call(agent: str, skill: str, id: str = "", **params: Value) -> Call:
    return Call(agent=agent, skill=skill, id=id, params=params)


def contains(view: SceneView, holder: str) -> set[str]:
    return {r.object for r in view.query_relation(holder, "contain")}


# --------------------------------------------------------------------------- good files


def test_the_good_kitting_file_verifies_and_predicts_the_kits_filled(kitting: World) -> None:
    before = kitting.view.state.to_snapshot()
    report = check(read_task_file(TASKS / "kitting_good.toml"), kitting.view, kitting.agents)
    assert report.ok and report.problems == [] and report.warnings == []
    assert kitting.view.state.to_snapshot() == before, "the caller's world model is untouched"
    final = report.final
    assert contains(final, "KitBox-1") == {"Gear-1", "Shaft-1"}
    assert contains(final, "KitBox-2") == {"Bracket-2", "Bolt-2"}
    assert contains(final, "Gripper-1") == contains(final, "Gripper-2") == set()
    assert "Gear-1" not in contains(final, "PartBox-1")
    assert final.query_relation("MobileManipulator-1", "at", "Station-1")
    assert final.query_relation("MobileManipulator-2", "at", "Station-2")
    steps = {s.path: s for s in report.steps}
    assert len(steps) == 10
    gear = steps["root.0.1"]
    assert (gear.agent, gear.params["holder"], gear.params["location"]) == (
        "r1",
        "PartBox-1",
        "Station-1",
    )
    assert "holder" in gear.inferred and "object" not in gear.inferred
    assert gear.locks == ["Arm-1", "Camera-2", "Gripper-1", "MobileManipulator-1"]
    bolt = steps["root.1.3"]
    assert bolt.agent == "r2" and bolt.params["gripper"] == "Gripper-2"
    assert steps["root.1.4"].params["container"] == "KitBox-2"  # label:KitBox-2 resolved
    notes = [n.message for n in report.notes if n.path == "root.0.1 (gear)"]
    assert any("'holder' will be inferred: PartBox-1" in n for n in notes)
    assert not any("'gripper'" in n for n in notes), "device bindings are not notes"


@pytest.mark.parametrize(("scenario", "file"), [("kitting", "kitting"), ("meal", "meal")])
def test_the_example_task_files_verify(scenario: str, file: str) -> None:
    w = world(scenario)
    report = check(read_task_file(ROOT / "configs" / "tasks" / f"{file}.toml"), w.view, w.agents)
    assert report.problems == [] and report.warnings == []
    final = report.final
    if scenario == "kitting":
        assert contains(final, "KitBox-1") == {"Gear-1"}
        assert contains(final, "KitBox-2") == {"Bracket-1", "Bolt-1"}
    else:
        assert contains(final, "Tray-1") == {"MealBox-1"}
        microwave = final.get_element("Microwave-1").properties
        assert microwave["doorOpen"] is False and microwave["heating"] is False


# --------------------------------------------------------------------------- bad files


EXPECTED: dict[str, list[tuple[str, str]]] = {
    "unknown": [
        ("root.0", "no agent 'r-1'; did you mean 'r1'? Agents: inspector, r1, r2"),
        ("root.1", "agent r1 has no skill 'pik'; did you mean 'pick'? Its skills: locate,"),
        ("root.2", "no agent offers skill 'weld'. Skills offered: locate, measure,"),
        ("root.3", "locate on r1: skill locate has no parameter 'objet'; did you mean 'object'?"),
    ],
    "dataflow": [
        ("root.0.1 (look-2)", "step 'look-1' may run at the same time as this one"),
        ("root.1 (look-3)", "step 'look-4' runs after this one"),
        ("root.2 (look-4)", "a step cannot take a value from itself"),
        ("root.3", "there is no step 'look-5'; did you mean 'look-4'"),
        ("root.4", "step 'look-1' (skill locate) has no parameter 'objet'; did you mean 'object'?"),
        ("root.5", "'@look-1' is not a reference; write '@<step id>.<param>'"),
        ("root.6", "parameter 'tray' (Tray) has no value and cannot be inferred: the world model"),
        ("root.6", "parameter 'tolerance' (float) has no value and no default"),
    ],
    "types": [
        (
            "root.0 (go)",
            "parameter 'goal': no element 'Station-9' in the world model; did you mean",
        ),
        ("root.1", "parameter 'goal': the label 'Station 1' names no element; did you mean"),
        ("root.2", "parameter 'goal' takes a Location; Gear-1 is a Gear (Gear < Part <"),
        ("root.3", "parameter 'speed' takes a float value, got string 'fast'"),
        ("root.4", "parameter 'object' takes an element id or 'label:<label>' (a PhysicalObject)"),
        (
            "root.5",
            "r2-camera (Camera-3) is not a device of agent r1; its Sensor devices: "
            "r1-camera (Camera-2)",
        ),
        ("root.6", "'container' = '@go.goal': the source is a Location, 'container' takes a"),
    ],
    "resources": [
        (
            "root.2.1 (drive)",
            "may run at the same time as root.2.0 (place) (both lock "
            "r1 (MobileManipulator-1)): an agent runs one skill per device at a time",
        ),
        ("root.2.2 (look)", "as root.2.0 (place) (both lock r1-camera (Camera-2))"),
    ],
    "preconditions": [
        (
            "root.0",
            "pre-condition contain(gripper, object) [gripper=Gripper-1, object=Gear-1] "
            "does not hold when the step starts: contain(Gripper-1, Gear-1) does not hold",
        ),
        (
            "root.1 (bolt)",
            "pre-condition at(robot, location) [location=Station-2, "
            "robot=MobileManipulator-2] does not hold",
        ),
        (
            "root.4 (race)",
            "branches root.4.0 and root.4.1 may run at the same time and both "
            "change where Gear-2 goes (root.4.0: into Gripper-1 (contain); root.4.1: into "
            "Gripper-2 (contain))",
        ),
        (
            "root.5",
            "pre-condition not at(robot, goal) [goal=Station-1, "
            "robot=MobileManipulator-2] does not hold",
        ),
    ],
    "structure": [
        ("root.0 (nothing)", "an empty sequence block: add calls or drop it"),
        ("root.3 (look)", "id 'look' is also used by root.2 (look); ids must be unique"),
    ],
}
KIND = {"types": "type", "resources": "resource", "preconditions": "precondition"}


@pytest.mark.parametrize("name", sorted(EXPECTED))
def test_each_crafted_file_is_caught_for_its_class_of_error(kitting: World, name: str) -> None:
    task = read_task_file(TASKS / f"{name}.toml")
    found = problems(kitting, task)
    kind = KIND.get(name, name)
    assert {k for _, k, _ in found} == {kind}, found
    assert len(found) == len(EXPECTED[name]), found
    for (path, _, message), (want_path, text) in zip(found, EXPECTED[name], strict=True):
        assert path == want_path and text in message, (path, message)


def test_a_parallel_block_with_one_child_is_only_a_warning(kitting: World) -> None:
    report = check(read_task_file(TASKS / "structure.toml"), kitting.view, kitting.agents)
    (warning,) = report.warnings
    assert (warning.path, warning.kind) == ("root.1 (alone)", "structure")
    assert "runs like a sequence" in warning.message
    assert all(p.path != "root.1 (alone)" for p in report.problems)


def test_problems_come_in_a_deterministic_document_order(kitting: World) -> None:
    task = read_task_file(TASKS / "preconditions.toml")
    first = verify(task, kitting.view, kitting.agents)
    assert first == verify(task, kitting.view, kitting.agents)
    assert [p.path for p in first] == sorted((p.path for p in first), key=lambda s: s.split("."))


# --------------------------------------------------------------------------- unknown


def test_unavailable_agents(kitting: World) -> None:
    gone = [
        msgspec.structs.replace(a, available=False) if a.name == "r2" else a for a in kitting.agents
    ]
    task = seq(call("r2", "locate", object="Gear-1"), call("", "locate", object="Gear-1"))
    found = [(p.path, p.kind, p.message) for p in verify(task, kitting.view, gone)]
    assert found == [("root.0", "unknown", "agent 'r2' is registered but not available")]


def test_an_agent_less_call_must_work_on_every_agent_it_may_get(kitting: World) -> None:
    alone = seq(call("", "pick", object="Bolt-2", gripper="Gripper-2"))
    ((path, kind, message),) = problems(kitting, alone)
    assert (path, kind) == ("root.0", "type")
    assert message.startswith(
        "pick on r1: parameter 'gripper': r2-gripper (Gripper-2) is not a device of"
    )
    # r1 may be busy with the navigation: the locate may get r1 or r2; both can run it
    report = check(
        TaskFile(
            root=par(call("r1", "navigate", goal="Station-1"), call("", "locate", object="Gear-2"))
        ),
        kitting.view,
        kitting.agents,
    )
    assert report.problems == [] and report.steps[1].agent == "r1"
    assert report.steps[1].locks == [], "r1 or r2: no device is certain"
    # with r1's camera named, r2 cannot run it
    task = TaskFile(
        root=par(
            call("r1", "locate", object="Gear-1"),
            call("", "locate", object="Gear-2", sensor="Camera-2"),
        )
    )
    found = problems(kitting, task)
    assert [p[:2] for p in found] == [("root.1", "type"), ("root.1", "resource")]
    assert found[0][2].startswith(
        "no agent named, so the task agent takes the first idle one offering locate (r1, r2); "
        "on r2: parameter 'sensor': r1-camera (Camera-2) is not a device of agent r2"
    )
    assert "(both lock r1-camera (Camera-2))" in found[1][2]


# --------------------------------------------------------------------------- dataflow


def test_data_flow_from_a_step_inside_an_earlier_parallel_block(kitting: World) -> None:
    task = seq(
        par(
            call("r1", "navigate", "go1", goal="Station-1"),
            call("r2", "navigate", "go2", goal="Station-2"),
        ),
        call("r1", "pick", "p", object="Gear-1", location="@go1.goal"),
        call("r1", "place", object="@p.object", container="KitBox-1"),
    )
    assert problems(kitting, task) == []


def test_an_element_parameter_to_infer_needs_a_candidate_when_its_step_starts(
    kitting: World,
) -> None:
    task = seq(call("inspector", "measure", object="Gear-1", tolerance=1))
    (problem,) = problems(kitting, task)
    assert problem[1] == "dataflow" and "holds no Tray when this step starts" in problem[2]
    w = with_ops(kitting, [AddElement(type="Tray", label="tray")])
    report = check(task, w.view, w.agents)
    assert report.problems == []
    assert report.steps[0].params["tray"] == "Tray-1" and report.steps[0].params["tolerance"] == 1.0
    assert "'tray' will be inferred: Tray-1: the only Tray candidate" in report.notes[0].message


def test_an_optional_source_parameter_left_empty_passes_nothing(kitting: World) -> None:
    task = seq(
        call("r1", "locate", "look", object="Gear-1"),
        call("r1", "locate", object="Gear-2", platform="@look.platform"),
    )
    (problem,) = problems(kitting, task)
    assert problem[:2] == ("root.1", "dataflow")
    assert "step 'look' runs without 'platform' (optional and not given)" in problem[2]


def test_a_reference_to_a_block_that_is_not_a_call(kitting: World) -> None:
    task = seq(
        Seq(children=[call("r1", "locate", object="Gear-1")], id="group"),
        call("r1", "locate", object="@group.object"),
    )
    (problem,) = problems(kitting, task)
    assert problem[1] == "dataflow" and "'group' is a sequence block, not a call" in problem[2]


def test_a_reference_to_a_broken_step_reports_the_source_only(kitting: World) -> None:
    task = seq(
        call("r9", "locate", "look", object="Gear-1"), call("r1", "locate", object="@look.object")
    )
    assert [p[:2] for p in problems(kitting, task)] == [("root.0 (look)", "unknown")]


# --------------------------------------------------------------------------- types


def test_labels_must_name_exactly_one_element(kitting: World) -> None:
    with pytest.raises(NameConflictError, match="label 'Gear-1' of the Gear Gear-4 is the id of"):
        with_ops(kitting, [AddElement(type="Gear", label="Gear-1")])  # the store refuses it
    task = seq(
        call("r1", "locate", object="label:Gear-1"), call("r1", "locate", object="label:Gear-9")
    )
    (problem,) = problems(kitting, task)
    assert problem[:2] == ("root.1", "type")
    assert "the label 'Gear-9' names no element; did you mean 'Gear-3' or 'Gear-2' or" in problem[2]


def test_partial_definitions_restrict_literals(kitting: World) -> None:
    desc = SkillDescription(
        name="inspect",
        parameters=[
            ParamSpec(
                name="box",
                type="Container",
                partial=Query(related=[Relation("Shelf-1", "contain", "?")]),
            )
        ],
    )
    w = World(kitting.view, [*kitting.agents, AgentInfo(name="qa", skills=(desc,))])
    (problem,) = problems(w, seq(call("qa", "inspect", box="PartBox-3")))
    assert "PartBox-3 does not match (contain(Shelf-1, ?))" in problem[2]
    assert problems(w, seq(call("qa", "inspect", box="PartBox-2"))) == []


@pytest.mark.parametrize(
    ("source", "target", "kind", "text"),
    [
        ("int", "float", None, ""),
        ("string", "str", None, ""),
        ("SizeSphere", "Size", None, ""),
        ("float", "any", None, ""),
        ("str", "float", "type", "the source is a str, 'y' takes a float"),
        ("Gear", "PhysicalObject", None, ""),
        ("Location", "float", "type", "the source is a Location, 'y' takes a float"),
    ],
)
def test_data_flow_types(
    kitting: World, source: str, target: str, kind: str | None, text: str
) -> None:
    values: dict[str, Value] = {
        "int": 2,
        "string": "a",
        "SizeSphere": None,
        "float": 1.5,
        "str": "x",
    }
    make = SkillDescription(
        name="make", parameters=[ParamSpec(name="x", type=source, optional=True)]
    )
    take = SkillDescription(
        name="take", parameters=[ParamSpec(name="y", type=target, optional=True)]
    )
    w = World(kitting.view, [*kitting.agents, AgentInfo(name="qa", skills=(make, take))])
    given = {"x": values[source]} if values.get(source) is not None else {}
    if source in ("Gear", "Location"):
        given = {"x": "Gear-1" if source == "Gear" else "Station-1"}
    found = problems(w, seq(call("qa", "make", "m", **given), call("qa", "take", y="@m.x")))
    if source == "SizeSphere":  # nothing flows from an empty optional parameter
        assert [p[1] for p in found] == ["dataflow"]
    elif kind is None:
        assert found == []
    else:
        assert [(p[1], text in p[2]) for p in found] == [(kind, True)], found


def test_a_broader_source_class_warns_and_checks_the_predicted_value(kitting: World) -> None:
    make = SkillDescription(name="make", parameters=[ParamSpec(name="x", type="PhysicalObject")])
    take = SkillDescription(name="take", parameters=[ParamSpec(name="y", type="Container")])
    w = World(kitting.view, [*kitting.agents, AgentInfo(name="qa", skills=(make, take))])
    good = check(
        seq(call("qa", "make", "m", x="KitBox-1"), call("qa", "take", y="@m.x")), w.view, w.agents
    )
    assert good.problems == []
    (warning,) = good.warnings
    assert (
        warning.kind == "type"
        and "the source is any PhysicalObject, 'y' takes a Container" in warning.message
    )
    bad = problems(w, seq(call("qa", "make", "m", x="Gear-1"), call("qa", "take", y="@m.x")))
    assert [p[1] for p in bad] == ["type"]
    assert "parameter 'y' (from step 'm') takes a Container; Gear-1 is a Gear" in bad[0][2]


# --------------------------------------------------------------------------- resources


def test_devices_are_predicted_even_when_the_call_cannot_be_specified(kitting: World) -> None:
    task = TaskFile(
        root=par(call("r1", "navigate", goal="Station-9"), call("r1", "pick", object="Gear-1"))
    )
    found = problems(kitting, task)
    assert [p[:2] for p in found] == [
        ("root.0", "type"),
        ("root.1", "resource"),
        ("root.1", "precondition"),
    ]
    assert "as root.0 (both lock r1 (MobileManipulator-1))" in found[1][2]


def test_an_agent_whose_devices_cannot_be_known_is_locked_whole(kitting: World) -> None:
    grip = SkillDescription(
        name="grip", parameters=[ParamSpec(name="gripper", type="Gripper", kind="hardware")]
    )
    w = World(kitting.view, [*kitting.agents, AgentInfo(name="qa", skills=(grip,))])
    found = problems(w, TaskFile(root=par(call("qa", "grip"), call("qa", "grip"))))
    assert [p[:2] for p in found] == [
        ("root.0", "dataflow"),
        ("root.1", "dataflow"),
        ("root.1", "resource"),
    ]
    assert "agent qa has no such device to bind" in found[0][2]
    assert "(both lock agent qa (its devices for these calls are not known))" in found[2][2]


def test_different_agents_in_parallel_share_nothing(meal: World) -> None:
    task = TaskFile(
        root=par(call("friend", "locate", object="MealBox-1"), call("microwave", "open_door"))
    )
    assert problems(meal, task) == []


# --------------------------------------------------------------------------- preconditions


def test_a_branch_cannot_rely_on_a_parallel_sibling(meal: World) -> None:
    task = seq(
        call("friend", "pick", "take", object="MealBox-1", holder="label:Worktop-1"),
        par(
            call("microwave", "open_door"),
            call("friend", "put_in", object="@take.object", appliance="Microwave-1"),
        ),
    )
    (problem,) = problems(meal, task)
    assert problem[:2] == ("root.1.1", "precondition")
    assert "pre-condition appliance.doorOpen == True [appliance=Microwave-1]" in problem[2]


def test_branches_changing_one_fact_differently_clash(meal: World) -> None:
    heating = SkillDescription(
        name="heating",
        parameters=[ParamSpec(name="a", type="Appliance"), ParamSpec(name="on", type="bool")],
        post=[PropertyCond(param="a", property="heating", value=True)],
    )
    cool = msgspec.structs.replace(
        heating, name="cool", post=[PropertyCond(param="a", property="heating", value=False)]
    )
    park = SkillDescription(
        name="park",
        parameters=[ParamSpec(name="a", type="Appliance"), ParamSpec(name="l", type="Location")],
        post=[RelationCond(subject="a", predicate="at", object="l", holds=False)],
    )
    agents = [AgentInfo(name=n, skills=(heating, cool, park)) for n in ("qa1", "qa2")]
    w = World(meal.view, [*meal.agents, *agents])
    task = seq(
        call("qa1", "heating", a="Microwave-1", on=True),
        par(
            call("qa1", "cool", a="Microwave-1", on=False),
            call("qa2", "heating", a="Microwave-1", on=True),
            call("qa2", "park", a="Microwave-1", l="Location-1"),
            id="p",
        ),
    )
    found = problems(w, task)
    assert found == [], "heating already true: the second branch changes nothing"
    task = seq(
        par(
            call("qa1", "heating", a="Microwave-1", on=True),
            call("qa2", "cool", a="Microwave-1", on=False),
            id="p",
        ),
    )
    w2 = with_ops(w, [UpdateElement(id="Microwave-1", properties={"heating": None})])
    ((path, kind, message),) = problems(w2, task)
    assert (path, kind) == ("root.0 (p)", "precondition")
    assert "both change Microwave-1.heating (root.0.0 sets True, root.0.1 False)" in message
    move = seq(
        call("qa1", "park", a="Microwave-1", l="Location-1"),
        par(
            call("qa1", "heating", a="Microwave-1", on=True),
            call("qa2", "park", a="Microwave-1", l="Location-1"),
        ),
    )
    assert problems(w2, move) == []


def test_microwave_skills_on_one_device_conflict(meal: World) -> None:
    task = seq(par(call("microwave", "open_door"), call("microwave", "heat", object="MealBox-1")))
    found = [(p[1], p[2]) for p in problems(meal, task) if p[0] == "root.0.1"]
    assert [k for k, _ in found] == ["resource", "precondition", "precondition"]
    assert "may run at the same time as root.0.0 (both lock Microwave-1):" in found[0][1]
    assert "contain(appliance, object)" in found[1][1]  # the meal is not inside


def test_a_sibling_may_break_a_condition_before_or_while_a_step_runs(meal: World) -> None:
    serve_while_closing = read_task_file(ROOT / "configs" / "tasks" / "meal.toml")
    assert problems(meal, serve_while_closing) == []
    take_out_while_closing = seq(
        call("friend", "pick", "take", object="MealBox-1", holder="label:Worktop-1"),
        call("microwave", "open_door"),
        call("friend", "put_in", object="@take.object", appliance="Microwave-1"),
        par(
            call("friend", "take_out", object="MealBox-1", appliance="Microwave-1"),
            call("microwave", "close_door"),
        ),
    )
    found = problems(meal, take_out_while_closing)
    assert [p[:2] for p in found] == [("root.3.0", "precondition")]
    assert found[0][2] == (
        "take_out on friend: pre-condition appliance.doorOpen == True [appliance=Microwave-1] "
        "may be made false by branch root.3.1, which may run at the same time: "
        "Microwave-1.doorOpen is False, expected == True; order them in a sequence"
    )


def test_effects_that_cannot_be_committed_are_reported(kitting: World) -> None:
    task = seq(
        call("r1", "navigate", goal="Station-1"),
        call("r1", "pick", object="Gear-1"),
        call("r1", "pick", object="Gear-2"),  # the gripper is full
    )
    found = problems(kitting, task)
    assert [p[:2] for p in found] == [("root.2", "precondition"), ("root.2", "precondition")]
    assert "empty(gripper) [gripper=Gripper-1]" in found[0][2]
    assert (
        "its predicted effects cannot be committed: op #1 (SetRelation): a Gripper may have"
        in found[1][2]
    )


def test_custom_conditions_are_left_to_run_time(kitting: World) -> None:
    desc = SkillDescription(
        name="probe",
        parameters=[ParamSpec(name="x", type="Gear")],
        pre=[CustomCond(name="reachable", params=["x"])],
    )
    w = World(kitting.view, [*kitting.agents, AgentInfo(name="qa", skills=(desc,))])
    report = check(seq(call("qa", "probe", x="Gear-1")), w.view, w.agents)
    assert report.problems == []
    assert (
        "reachable(x) is a custom condition: checked only when the step runs"
        in report.warnings[0].message
    )
    inferred = check(seq(call("qa", "probe")), w.view, w.agents)  # inference assumes it too
    assert inferred.problems == [] and inferred.steps[0].params["x"] == "Gear-1"


def test_any_world_view_works_and_empty_tasks_are_structure_problems(kitting: World) -> None:
    plain = SceneView(kitting.view.state, kitting.view.ontology)
    task = seq(call("r1", "navigate", goal="Station-1"), call("r1", "pick", object="Gear-1"))
    assert verify(task, plain, kitting.agents) == []
    empty = verify(TaskFile(root=Parallel(children=[])), plain, kitting.agents)
    assert empty == [
        VerifyProblem(
            path="root", kind="structure", message="an empty parallel block: add calls or drop it"
        )
    ]
    nameless = verify(seq(Call(skill="")), plain, kitting.agents)
    assert next((p.kind, p.message[:22]) for p in nameless) == (
        "structure",
        "a call needs a 'skill'",
    )


def test_a_label_an_agent_shares_with_its_robot_means_the_robot(kitting: World) -> None:
    w = with_ops(kitting, [AddElement(type="RobotAgent", label="r1")])  # as registration does
    task = seq(call("r1", "navigate", goal="label:Station-1", robot="label:r1"))
    assert problems(w, task) == []
