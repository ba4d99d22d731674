"""Goal text and Structs -> checked goal literals, with errors that name the fix."""

from __future__ import annotations

import msgspec
import pytest

from skill_agent.conditions import symbolic
from skill_agent.protocol import (
    AndCond,
    Condition,
    EmptyCond,
    NotCond,
    PropertyCond,
    RelationCond,
)
from task_agent import (
    Goal,
    GoalLiteral,
    GoalParseError,
    PropertyGoal,
    RelationGoal,
    check_goal,
    goal_from_conditions,
    literal_atom,
    parse_goal,
)
from tests.assets.planning import KittingScene, add_microwave, kitting_scene
from wm_store import DuplicateLabelError
from wm_store.protocol import AddElement, UpdateElement
from wm_store.scene import apply_transaction


@pytest.fixture(scope="module")
def scene() -> KittingScene:
    scene = kitting_scene(2, 4)
    add_microwave(scene)
    return scene


def test_conjunction_of_relations_by_id_and_label(scene: KittingScene) -> None:
    kit, gears = scene.kits[0], scene.parts
    goal = parse_goal(
        f'contain({kit}, {gears[0]}) and contain("kit-1", gear-2), contain({kit}, "gear-3")',
        scene.view,
    )
    assert goal.literals == (
        RelationGoal(predicate="contain", subject=kit, object=gears[0]),
        RelationGoal(predicate="contain", subject=kit, object=gears[1]),
        RelationGoal(predicate="contain", subject=kit, object=gears[2]),
    )
    assert str(goal) == " and ".join(f"contain({kit}, {g})" for g in gears[:3])
    assert goal.elements() == {kit, *gears[:3]}


def test_negations_and_properties(scene: KittingScene) -> None:
    goal = parse_goal(
        f"not contain({scene.kits[0]}, {scene.parts[0]}) & doorOpen(Microwave-1) = true "
        f"and heating(Microwave-1) and !heating(oven) and contain({scene.kits[1]}, "
        f"{scene.parts[1]}) = false and doorOpen(Microwave-1) != false",
        scene.view,
    )
    assert goal.literals == (
        RelationGoal(predicate="contain", subject="KitBox-1", object="Gear-1", holds=False),
        PropertyGoal(element="Microwave-1", property="doorOpen", value=True),
        PropertyGoal(element="Microwave-1", property="heating", value=True),
        PropertyGoal(element="Microwave-1", property="heating", value=True, holds=False),
        RelationGoal(predicate="contain", subject="KitBox-2", object="Gear-2", holds=False),
        PropertyGoal(element="Microwave-1", property="doorOpen", value=False, holds=False),
    )
    assert str(goal.literals[3]) == "heating(Microwave-1) != true"


def test_text_values(scene: KittingScene) -> None:
    goal = parse_goal('partNumber(Gear-1) = "G-100"', scene.view)
    assert goal.literals == (PropertyGoal(element="Gear-1", property="partNumber", value="G-100"),)


@pytest.mark.parametrize(
    ("text", "message"),
    [
        ("contain(KitBox-1, Gear-33)", "unknown element 'Gear-33'"),
        ("contain(KitBox-1, Gear-33)", "did you mean 'Gear-3'"),
        ('contain(KitBox-1, "gear 1")', "did you mean 'gear-1'"),
        (
            "contian(KitBox-1, Gear-1)",
            "unknown relation or property 'contian'; did you mean 'contain'",
        ),
        ("doorOpem(Microwave-1)", "did you mean 'doorOpen'"),
        (
            "contain(KitBox-1)",
            "'contain' is a relation and takes 2 arguments (subject, object), got 1",
        ),
        ("heating(Microwave-1, Gear-1)", "takes 1 argument (element), got 2"),
        ("contain(Gear-1, KitBox-1)", "cannot relate Gear --contain--> KitBox"),
        ("doorOpen(Microwave-1) = 3", "property 'doorOpen' takes bool"),
        ("doorOpen(Gear-1) = true", "does not apply to a Gear"),
        ("mass(Gear-1) = 0.5", "numeric goals such as 0.5 are not supported"),
        ("contain(KitBox-1, Gear-1) = 2", "a relation is true or false"),
        ("contain(KitBox-1, Gear-1) contain(KitBox-1, Gear-2)", "expected 'and' or ','"),
        ("contain(KitBox-1, Gear-1", "expected ')' or ','"),
        ("contain KitBox-1", "expected '(' after 'contain'"),
        ("contain(KitBox-1, Gear-1) and", "expected a relation or property name"),
        ("contain(KitBox-1; Gear-1)", "unexpected character ';' at column 17"),
        ("   ", "the goal is empty"),
    ],
)
def test_errors_name_the_fix(scene: KittingScene, text: str, message: str) -> None:
    with pytest.raises(GoalParseError, match=message.replace("(", r"\(").replace(")", r"\)")):
        parse_goal(text, scene.view)


def test_error_columns(scene: KittingScene) -> None:
    with pytest.raises(GoalParseError) as info:
        parse_goal("contain(KitBox-1, Gear-1) and contain(KitBox-1, Gear-99)", scene.view)
    assert info.value.column == len("contain(KitBox-1, Gear-1) and contain(KitBox-1, ") + 1


def test_a_label_names_one_element() -> None:
    scene = kitting_scene(1, 1)
    oven, _ = add_microwave(scene, station=0, content="cold gear")
    with pytest.raises(DuplicateLabelError, match=rf"'oven'.*oven \({oven}\)"):
        add_microwave(scene, station=1, content="hot gear")  # the store refuses a namesake
    assert "heating" in str(parse_goal("heating(oven)", scene.view))


def test_suggestions_for_an_element_are_element_names_once() -> None:
    scene = kitting_scene(1, 1)  # r1 registers its skills: elements labelled pick, place, ...
    with pytest.raises(GoalParseError) as info:
        parse_goal("contain(KitBox-1, placee)", scene.view)
    assert "'place'" not in str(info.value), "a skill is no element of a goal"
    state = scene.view.state
    apply_transaction(
        state, scene.view.ontology, [AddElement(type="Bolt", label="Bolt-1")], revision=99
    )
    with pytest.raises(GoalParseError) as info:
        parse_goal("contain(KitBox-1, Bolt-11)", scene.view)
    assert str(info.value).count("'Bolt-1'") == 1, "an id that is also its label, named once"


def test_a_label_an_agent_shares_with_its_robot_means_the_robot() -> None:
    scene = kitting_scene(1, 1)
    state, onto = scene.view.state, scene.view.ontology
    (agent,) = state.ids_with_label("r1")
    robot = next(iter(state.subjects(agent, "controls") | state.objects(agent, "controls")))
    apply_transaction(state, onto, [UpdateElement(id=robot, label="r1")], revision=99)
    goal = parse_goal("at(r1, depot)", scene.view)
    assert goal.literals[0].subject == robot  # type: ignore[union-attr]


def test_goal_structs_are_checked_and_labels_resolved(scene: KittingScene) -> None:
    wire = msgspec.json.encode(
        Goal(literals=(RelationGoal(predicate="contain", subject="kit-2", object="gear-4"),))
    )
    goal = check_goal(msgspec.json.decode(wire, type=Goal), scene.view)
    assert goal.literals == (
        RelationGoal(predicate="contain", subject="KitBox-2", object="Gear-4"),
    )
    bad: list[GoalLiteral] = [PropertyGoal(element="Gear-1", property="contain", value=True)]
    with pytest.raises(GoalParseError, match="'contain' is a relation, not a property"):
        check_goal(bad, scene.view)
    with pytest.raises(GoalParseError, match="numeric goals are not supported"):
        check_goal([PropertyGoal(element="Gear-1", property="mass", value=0.5)], scene.view)  # type: ignore[arg-type]
    with pytest.raises(GoalParseError, match="the goal is empty"):
        check_goal([], scene.view)


def test_goal_from_conditions(scene: KittingScene) -> None:
    goal = goal_from_conditions(
        [
            AndCond(
                items=[
                    RelationCond(subject="KitBox-1", predicate="contain", object="Gear-1"),
                    NotCond(item=PropertyCond(param="Microwave-1", property="heating", value=True)),
                ]
            ),
            PropertyCond(param="Microwave-1", property="doorOpen", op="ne", value=False),
        ],
        scene.view,
    )
    assert goal.literals == (
        RelationGoal(predicate="contain", subject="KitBox-1", object="Gear-1"),
        PropertyGoal(element="Microwave-1", property="heating", value=True, holds=False),
        PropertyGoal(element="Microwave-1", property="doorOpen", value=False, holds=False),
    )
    with pytest.raises(GoalParseError, match="cannot use EmptyCond as a goal"):
        goal_from_conditions([EmptyCond(param="Gripper-1")], scene.view)


def test_atoms_are_named_like_skill_conditions() -> None:
    pairs: list[tuple[Condition, GoalLiteral]] = [
        (
            PropertyCond(param="x", property="doorOpen", value=True),
            PropertyGoal(element="x", property="doorOpen", value=True),
        ),
        (
            PropertyCond(param="x", property="partNumber", op="ne", value="G-1"),
            PropertyGoal(element="x", property="partNumber", value="G-1", holds=False),
        ),
        (
            RelationCond(subject="x", predicate="contain", object="y", holds=False),
            RelationGoal(predicate="contain", subject="x", object="y", holds=False),
        ),
    ]
    for cond, lit in pairs:
        assert symbolic(cond) == [literal_atom(lit)]
