"""Conditions: evaluation of every kind with reasons, predicted effects, symbolic atoms.

Pure tests run against :class:`SceneView`, a WorldView over a ``SceneState`` built with the
store's own transaction code; the effect round trip also runs through a real ``WmClient``.
"""

from __future__ import annotations

from collections.abc import AsyncIterator, Mapping, Sequence
from contextlib import asynccontextmanager
from typing import ClassVar

import anyio
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from skill_agent import SkillLoadError, UnspecifiedParameterError, WorldView
from skill_agent.conditions import (
    Atom,
    Bindings,
    ConditionRegistry,
    Verdict,
    describe,
    effects,
    evaluate,
    evaluate_all,
    parameters_of,
    symbolic,
)
from skill_agent.protocol import (
    AndCond,
    Condition,
    CustomCond,
    EmptyCond,
    HasPropertyCond,
    IsSpecifiedCond,
    IsTypeCond,
    NotCond,
    OrCond,
    PropertyCond,
    RelationCond,
)
from task_agent.verification import SceneView as PrivateScene
from wm_store import InMemoryTransport, WmClient
from wm_store.ontology import Ontology
from wm_store.protocol import (
    AddElement,
    Op,
    Pose,
    Position,
    Relation,
    SetRelation,
    UnsetRelation,
    UpdateElement,
    Value,
)
from wm_store.scene import SceneState, apply_transaction
from wm_store.server import WmService, WmStore

ONTOLOGY = Ontology.default()


class SceneView(PrivateScene):
    """A WorldView over a private SceneState (the task layer's symbolic-simulation view), plus
    a helper to apply ops to it."""

    def __init__(self, ontology: Ontology = ONTOLOGY) -> None:
        state = SceneState()
        state.set_spatial_predicates(n for n, r in ontology.relations.items() if r.spatial)
        super().__init__(state, ontology)

    def apply(self, ops: Sequence[Op]) -> dict[str, str]:
        self.state.revision += 1
        result = apply_transaction(self.state, self.ontology, ops, revision=self.state.revision)
        return result.ids


KITTING = [
    AddElement(type="Table", label="table", ref="$table"),
    AddElement(
        type="PartBox",
        label="gears",
        ref="$box",
        properties={"capacity": 3},
        relations=[Relation("$table", "contain", "$")],
    ),
    AddElement(
        type="Gear",
        label="g1",
        ref="$gear1",
        properties={"mass": 0.2, "pose": Pose(Position(0.1, 0.0, 0.05)), "partNumber": "G-100"},
        relations=[Relation("$box", "contain", "$")],
    ),
    AddElement(
        type="Gear",
        label="g2",
        ref="$gear2",
        properties={"mass": 0.25},
        relations=[Relation("$box", "contain", "$")],
    ),
    AddElement(type="MobileManipulator", label="r1", ref="$robot"),
    AddElement(type="Arm", ref="$arm", relations=[Relation("$robot", "hasA", "$")]),
    AddElement(type="Gripper", ref="$gripper", relations=[Relation("$arm", "hasA", "$")]),
    AddElement(type="KitBox", ref="$kit", relations=[Relation("$robot", "contain", "$")]),
    AddElement(type="Microwave", ref="$oven", properties={"doorOpen": False}),
]


@pytest.fixture
def view() -> SceneView:
    return SceneView()


@pytest.fixture
def ids(view: SceneView) -> dict[str, str]:
    return {k.lstrip("$"): v for k, v in view.apply(KITTING).items() if k.startswith("$")}


def check(cond: Condition, view: WorldView, bindings: Bindings, ok: bool, *parts: str) -> None:
    verdict = evaluate(cond, view, bindings)
    assert verdict.ok is ok, verdict.reason
    for part in parts:
        assert part in verdict.reason


# --------------------------------------------------------------------------- relation


def test_relation_holds_and_not(view: SceneView, ids: dict[str, str]) -> None:
    b = {"box": ids["box"], "gear": ids["gear1"], "gripper": ids["gripper"]}
    check(
        RelationCond(subject="box", predicate="contain", object="gear"),
        view,
        b,
        True,
        "contain(PartBox-1, Gear-1) holds",
    )
    check(
        RelationCond(subject="box", predicate="contain", object="gear", holds=False),
        view,
        b,
        False,
        "holds, expected not",
    )
    check(
        RelationCond(subject="gripper", predicate="contain", object="gear"),
        view,
        b,
        False,
        "contain(Gripper-1, Gear-1) does not hold",
        "Gear-1's spatial parent is PartBox-1",
    )
    check(
        RelationCond(subject="gripper", predicate="contain", object="gear", holds=False),
        view,
        b,
        True,
        "does not hold",
    )


def test_relation_includes_sub_properties(view: SceneView, ids: dict[str, str]) -> None:
    b = {"box": ids["box"], "gear": ids["gear1"], "robot": ids["robot"], "arm": ids["arm"]}
    check(
        RelationCond(subject="box", predicate="spatialRelation", object="gear"),
        view,
        b,
        True,
        "spatialRelation(PartBox-1, Gear-1) holds (as contain)",
    )
    check(
        RelationCond(subject="robot", predicate="spatialRelation", object="arm"),
        view,
        b,
        True,
        "(as hasA)",
    )


def test_unbound_or_missing_elements_are_false(view: SceneView, ids: dict[str, str]) -> None:
    cond = RelationCond(subject="box", predicate="contain", object="gear", holds=False)
    check(cond, view, {"box": ids["box"]}, False, "parameter 'gear' is not specified")
    check(cond, view, {"box": ids["box"], "gear": None}, False, "'gear' is not specified")
    check(
        cond,
        view,
        {"box": ids["box"], "gear": "Gear-99"},
        False,
        "Gear-99 (parameter 'gear') is not in the world model",
    )
    check(cond, view, {"box": ids["box"], "gear": 3.0}, False, "is 3.0, not an element id")
    check(EmptyCond(param="box"), view, {"box": "Box-9"}, False, "not in the world model")
    check(NotCond(item=EmptyCond(param="box")), view, {"box": "Box-9"}, True, "negation holds")


def test_unknown_names_give_a_false_verdict_with_the_closest(
    view: SceneView, ids: dict[str, str]
) -> None:
    b = {"box": ids["box"], "gear": ids["gear1"]}
    check(
        RelationCond(subject="box", predicate="contian", object="gear"),
        view,
        b,
        False,
        "invalid condition",
        "did you mean 'contain'",
    )
    check(PropertyCond(param="gear", property="mas", op="exists"), view, b, False, "'mass'")
    check(IsTypeCond(param="gear", cls="Gera"), view, b, False, "did you mean 'Gear'")


# --------------------------------------------------------------------------- property


@pytest.mark.parametrize(
    ("op", "value", "ok", "part"),
    [
        ("eq", 0.2, True, "Gear-1.mass is 0.2, as required == 0.2"),
        ("eq", 0.25, False, "Gear-1.mass is 0.2, expected == 0.25"),
        ("ne", 0.25, True, "as required != 0.25"),
        ("ne", 0.2, False, "expected != 0.2"),
        ("lt", 0.3, True, "< 0.3"),
        ("lt", 0.2, False, "expected < 0.2"),
        ("le", 0.2, True, "<= 0.2"),
        ("le", 0.1, False, "expected <= 0.1"),
        ("gt", 0.1, True, "> 0.1"),
        ("gt", 0.2, False, "expected > 0.2"),
        ("ge", 0.2, True, ">= 0.2"),
        ("ge", 0.21, False, "expected >= 0.21"),
        ("ge", 0, True, ">= 0"),  # an int compares with a float
        ("gt", True, False, "expected > True"),  # a bool is not a number
        ("exists", None, True, "Gear-1.mass is 0.2"),
    ],
)
def test_property_compare(
    view: SceneView, ids: dict[str, str], op: str, value: Value, ok: bool, part: str
) -> None:
    cond = PropertyCond(param="gear", property="mass", op=op, value=value)  # type: ignore[arg-type]
    check(cond, view, {"gear": ids["gear1"]}, ok, part)


def test_property_missing_strings_bools_and_near(view: SceneView, ids: dict[str, str]) -> None:
    g1, g2, oven = {"g": ids["gear1"]}, {"g": ids["gear2"]}, {"g": ids["oven"]}
    check(
        PropertyCond(param="g", property="graspWidth", op="exists"),
        view,
        g1,
        False,
        "Gear-1 has no 'graspWidth', expected one",
    )
    check(
        PropertyCond(param="g", property="mass", op="lt", value=1.0),
        view,
        {"g": ids["table"]},
        False,
        "Table-1 has no 'mass', expected < 1.0",
    )
    check(
        PropertyCond(param="g", property="graspWidth", op="ne", value=0.1),
        view,
        g1,
        True,
        "has no 'graspWidth', as required != 0.1",
    )
    check(PropertyCond(param="g", property="partNumber", value="G-100"), view, g1, True)
    check(PropertyCond(param="g", property="partNumber", op="lt", value="H"), view, g1, True)
    check(PropertyCond(param="g", property="partNumber", op="lt", value=3), view, g1, False)
    check(PropertyCond(param="g", property="doorOpen", value=False), view, oven, True)
    check(
        PropertyCond(param="g", property="doorOpen", value=0),
        view,
        oven,
        False,
        "doorOpen is False, expected == 0",
    )
    check(PropertyCond(param="g", property="mass", value=None), view, g2, False)
    here = Position(0.12, 0.0, 0.05)
    check(
        PropertyCond(param="g", property="pose", op="near", value=here, tolerance=0.05),
        view,
        g1,
        True,
        "0.02 away; within 0.05",
    )
    check(
        PropertyCond(param="g", property="pose", op="near", value=here, tolerance=0.01),
        view,
        g1,
        False,
        "expected within 0.01",
    )
    elsewhere = Position(0.1, 0.0, 0.05, frame="Table-1")
    check(
        PropertyCond(param="g", property="pose", op="near", value=elsewhere, tolerance=1.0),
        view,
        g1,
        False,
        "not comparable",
    )
    check(
        PropertyCond(param="g", property="mass", op="near", value=0.26, tolerance=0.02),
        view,
        g2,
        True,
    )


def test_has_property(view: SceneView, ids: dict[str, str]) -> None:
    b = {"g": ids["gear1"]}
    check(HasPropertyCond(param="g", property="mass"), view, b, True, "Gear-1.mass is 0.2")
    check(HasPropertyCond(param="g", property="mass", holds=False), view, b, False, "expected none")
    check(
        HasPropertyCond(param="g", property="color"),
        view,
        b,
        False,
        "Gear-1 has no 'color', expected it",
    )
    check(HasPropertyCond(param="g", property="color", holds=False), view, b, True)


def test_is_type_counts_subclasses(view: SceneView, ids: dict[str, str]) -> None:
    b = {"g": ids["gear1"]}
    check(IsTypeCond(param="g", cls="Gear"), view, b, True, "Gear-1 is a Gear")
    check(IsTypeCond(param="g", cls="PhysicalObject"), view, b, True, "so a PhysicalObject")
    check(
        IsTypeCond(param="g", cls="Container"),
        view,
        b,
        False,
        "Gear-1 is a Gear, expected a Container",
    )


# --------------------------------------------------------------------------- empty / full


def test_empty_and_full(view: SceneView, ids: dict[str, str]) -> None:
    b = {"box": ids["box"], "gripper": ids["gripper"], "kit": ids["kit"], "table": ids["table"]}
    check(EmptyCond(param="gripper"), view, b, True, "Gripper-1 is empty")
    check(
        EmptyCond(param="box"), view, b, False, "PartBox-1 contains Gear-1, Gear-2, expected empty"
    )
    check(EmptyCond(param="box", holds=False), view, b, True, "contains Gear-1, Gear-2")
    check(EmptyCond(param="gripper", holds=False), view, b, False, "expected not empty")
    check(
        EmptyCond(param="box", full=True),
        view,
        b,
        False,
        "PartBox-1 holds 2 of 3 (its 'capacity'): not full, expected full",
    )
    check(EmptyCond(param="box", full=True, holds=False), view, b, True)
    view.apply(
        [
            UnsetRelation(subject=ids["box"], predicate="contain", object=ids["gear2"]),
            SetRelation(subject=ids["gripper"], predicate="contain", object=ids["gear2"]),
        ]
    )
    check(EmptyCond(param="gripper"), view, b, False, "Gripper-1 contains Gear-2, expected empty")
    # The gripper has no capacity property: the ontology's "contains one thing at most" counts.
    check(
        EmptyCond(param="gripper", full=True),
        view,
        b,
        True,
        "Gripper-1 holds 1 of 1 (the ontology's maximum for a Gripper): full",
    )
    check(EmptyCond(param="table", full=True), view, b, False, "never full")
    check(EmptyCond(param="table", full=True, holds=False), view, b, True, "never full")
    check(EmptyCond(param="gripper", predicate="hasA"), view, b, True, "Gripper-1 is empty")


# --------------------------------------------------------------------------- the rest


def test_is_specified(view: SceneView) -> None:
    check(IsSpecifiedCond(param="speed"), view, {"speed": 0.5}, True, "'speed' is specified (0.5)")
    check(IsSpecifiedCond(param="speed"), view, {"speed": None}, False, "not specified")
    check(IsSpecifiedCond(param="speed"), view, {}, False, "not specified")


class Heavy:
    """Custom: the element's mass exceeds ``args['limit']``."""

    name: ClassVar[str] = "heavy"

    def evaluate(
        self, view: WorldView, bindings: Bindings, params: Sequence[str], args: Mapping[str, Value]
    ) -> Verdict:
        element = view.get_element(str(bindings[params[0]]))
        mass, limit = element.properties.get("mass"), args["limit"]
        assert isinstance(mass, float) and isinstance(limit, float)
        return Verdict(mass > limit, f"{element.id} weighs {mass} kg (limit {limit})")

    def symbolic(self, params: Sequence[str], args: Mapping[str, Value]) -> list[Atom] | None:
        return [Atom("heavy", tuple(params))]


class Heavy2(Heavy):
    pass


def test_custom_conditions_and_registry(view: SceneView, ids: dict[str, str]) -> None:
    registry = ConditionRegistry()
    registry.register(Heavy)
    registry.register(Heavy)  # the same class again: fine (reload)
    assert "heavy" in registry and registry.names() == ["heavy"]
    cond = CustomCond(name="heavy", params=["g"], args={"limit": 0.22})
    b = {"g": ids["gear2"]}
    assert evaluate(cond, view, b, registry=registry) == Verdict(
        True, "Gear-2 weighs 0.25 kg (limit 0.22)"
    )
    assert not evaluate(cond, view, {"g": ids["gear1"]}, registry=registry).ok
    assert "no condition registry" in evaluate(cond, view, b).reason
    unknown = evaluate(CustomCond(name="haevy"), view, b, registry=registry)
    assert not unknown.ok and "did you mean 'heavy'" in unknown.reason
    with pytest.raises(SkillLoadError, match="already registered by Heavy"):
        registry.register(Heavy2)
    registry.register(Heavy2, replace=True)
    with pytest.raises(SkillLoadError, match="unknown custom condition 'hevy'; did you mean"):
        registry.get("hevy")
    assert symbolic(cond, registry=registry) == [Atom("heavy", ("g",))]
    assert symbolic(cond) is None
    assert ConditionRegistry().names() == []  # registries share nothing


def test_and_or_not_reasons(view: SceneView, ids: dict[str, str]) -> None:
    b = {"gripper": ids["gripper"], "box": ids["box"]}
    empty_gripper, empty_box = EmptyCond(param="gripper"), EmptyCond(param="box")
    check(AndCond(items=[empty_gripper, empty_box]), view, b, False, "PartBox-1 contains")
    check(
        AndCond(items=[empty_gripper, NotCond(item=empty_box)]),
        view,
        b,
        True,
        "Gripper-1 is empty and negation holds",
    )
    check(OrCond(items=[empty_box, empty_gripper]), view, b, True, "Gripper-1 is empty")
    check(
        OrCond(items=[empty_box, NotCond(item=empty_gripper)]),
        view,
        b,
        False,
        "none holds: PartBox-1 contains",
        " | Gripper-1 is empty; expected the opposite",
    )
    check(AndCond(items=[]), view, b, True)
    check(OrCond(items=[]), view, b, False)


def test_evaluate_all_returns_the_first_false(view: SceneView, ids: dict[str, str]) -> None:
    b = {"gripper": ids["gripper"], "box": ids["box"]}
    conds: list[Condition] = [
        EmptyCond(param="gripper"),
        EmptyCond(param="box"),
        IsSpecifiedCond(param="nothing"),
    ]
    verdict = evaluate_all(conds, view, b)
    assert not verdict.ok and verdict.reason.startswith("PartBox-1 contains")
    ok = evaluate_all(conds[:1], view, b)
    assert ok.ok and ok.reason == "all 1 conditions hold; Gripper-1 is empty"


# Truth tables: leaves are IsSpecifiedCond over four parameters; a leaf is true iff bound.
LEAF_NAMES = ["p0", "p1", "p2", "p3"]
leaves = st.sampled_from(LEAF_NAMES).map(lambda p: IsSpecifiedCond(param=p))
trees: st.SearchStrategy[Condition] = st.recursive(
    leaves,
    lambda sub: st.one_of(
        st.lists(sub, max_size=4).map(lambda items: AndCond(items=items)),
        st.lists(sub, max_size=4).map(lambda items: OrCond(items=items)),
        sub.map(lambda item: NotCond(item=item)),
    ),
    max_leaves=12,
)


def truth(cond: Condition, bound: set[str]) -> bool:
    match cond:
        case IsSpecifiedCond(param=p):
            return p in bound
        case AndCond(items=items):
            return all(truth(i, bound) for i in items)
        case OrCond(items=items):
            return any(truth(i, bound) for i in items)
        case NotCond(item=item):
            return not truth(item, bound)
    raise AssertionError(cond)


@settings(max_examples=300, deadline=None)
@given(cond=trees, bound=st.sets(st.sampled_from(LEAF_NAMES)))
def test_and_or_not_match_the_truth_table(cond: Condition, bound: set[str]) -> None:
    view = SceneView()
    verdict = evaluate(cond, view, dict.fromkeys(bound, 1))
    assert verdict.ok is truth(cond, bound)
    assert verdict.reason
    assert parameters_of(cond) <= set(LEAF_NAMES)


# --------------------------------------------------------------------------- effects

PICK_POST: list[Condition] = [
    RelationCond(subject="gripper", predicate="contain", object="gear"),
    RelationCond(subject="box", predicate="contain", object="gear", holds=False),
    EmptyCond(param="box", holds=False),  # checked only
]


def test_pick_effects_move_the_object_and_skip_what_holds(
    view: SceneView, ids: dict[str, str]
) -> None:
    b = {"gripper": ids["gripper"], "box": ids["box"], "gear": ids["gear1"]}
    ops = effects(PICK_POST, view, b)
    assert ops == [
        UnsetRelation(subject="PartBox-1", predicate="contain", object="Gear-1"),
        SetRelation(subject="Gripper-1", predicate="contain", object="Gear-1"),
    ]
    assert not evaluate_all(PICK_POST, view, b).ok
    view.apply(ops)
    assert evaluate_all(PICK_POST, view, b).ok
    assert effects(PICK_POST, view, b) == []  # every fact holds: nothing to write


def test_place_effects_unset_the_current_spatial_parent(
    view: SceneView, ids: dict[str, str]
) -> None:
    b = {"gripper": ids["gripper"], "kit": ids["kit"], "gear": ids["gear1"]}
    view.apply(effects(PICK_POST, view, {**b, "box": ids["box"]}))
    post: list[Condition] = [
        RelationCond(subject="kit", predicate="contain", object="gear"),
        EmptyCond(param="gripper"),
    ]
    ops = effects(post, view, b)
    assert ops == [
        UnsetRelation(subject="Gripper-1", predicate="contain", object="Gear-1"),
        SetRelation(subject="KitBox-1", predicate="contain", object="Gear-1"),
    ]
    view.apply(ops)
    assert evaluate_all(post, view, b).ok


def test_property_and_negated_effects(view: SceneView, ids: dict[str, str]) -> None:
    b = {"oven": ids["oven"], "box": ids["box"], "gear": ids["gear1"], "g2": ids["gear2"]}
    post: list[Condition] = [
        PropertyCond(param="oven", property="doorOpen", value=True),
        PropertyCond(param="oven", property="heating", value=False),
        PropertyCond(param="gear", property="mass", value=0.2),  # holds already
        PropertyCond(param="gear", property="partNumber", value=None),  # delete
        PropertyCond(param="g2", property="mass", op="gt", value=0.1),  # checked only
        AndCond(
            items=[
                NotCond(item=RelationCond(subject="box", predicate="spatialRelation", object="g2"))
            ]
        ),
    ]
    ops = effects(post, view, b)
    assert ops == [
        UnsetRelation(subject="PartBox-1", predicate="contain", object="Gear-2"),
        UpdateElement(id="Microwave-1", properties={"doorOpen": True, "heating": False}),
        UpdateElement(id="Gear-1", properties={"partNumber": None}),
    ]
    view.apply(ops)
    assert evaluate_all(post, view, b).ok
    assert effects(post, view, b) == []


def test_contradicting_predictions_later_wins(view: SceneView, ids: dict[str, str]) -> None:
    b = {"gripper": ids["gripper"], "box": ids["box"], "kit": ids["kit"], "gear": ids["gear1"]}
    moved = RelationCond(subject="gripper", predicate="contain", object="gear")
    back = RelationCond(subject="box", predicate="contain", object="gear")
    kit = RelationCond(subject="kit", predicate="contain", object="gear")
    assert effects([moved, back], view, b) == []  # out and back in: nothing changes
    assert effects([moved, kit], view, b) == [
        UnsetRelation(subject="PartBox-1", predicate="contain", object="Gear-1"),
        SetRelation(subject="KitBox-1", predicate="contain", object="Gear-1"),
    ]


def test_effects_refuse_what_they_cannot_predict(view: SceneView, ids: dict[str, str]) -> None:
    b = {"gripper": ids["gripper"], "gear": ids["gear1"]}
    abstract = RelationCond(subject="gripper", predicate="spatialRelation", object="gear")
    with pytest.raises(SkillLoadError, match="'spatialRelation' is abstract"):
        effects([abstract], view, b)
    with pytest.raises(SkillLoadError, match="did you mean 'contain'"):
        effects([RelationCond(subject="gripper", predicate="contian", object="gear")], view, b)
    with pytest.raises(UnspecifiedParameterError, match="parameter 'gear' is None"):
        effects([PICK_POST[0]], view, {"gripper": ids["gripper"]})


@asynccontextmanager
async def kitting_wm() -> AsyncIterator[tuple[WmClient, dict[str, str]]]:
    store = await WmStore.open(ONTOLOGY)
    async with anyio.create_task_group() as tg:
        await tg.start(store.run)
        async with WmClient.connect(InMemoryTransport(WmService(store)), ONTOLOGY) as wm:
            reply = await wm.transact(KITTING)
            yield wm, {k.lstrip("$"): v for k, v in reply.ids.items() if k.startswith("$")}
        tg.cancel_scope.cancel()


@pytest.mark.anyio
async def test_effects_commit_through_the_world_model_client() -> None:
    async with kitting_wm() as (wm, ids):
        b = {"gripper": ids["gripper"], "box": ids["box"], "gear": ids["gear2"]}
        assert not evaluate_all(PICK_POST, wm, b).ok
        await wm.transact(effects(PICK_POST, wm, b))
        assert evaluate_all(PICK_POST, wm, b).ok
        assert wm.get_parent(ids["gear2"]) == wm.get_element(ids["gripper"])
        assert effects(PICK_POST, wm, b) == []
        place = [RelationCond(subject="kit", predicate="contain", object="gear")]
        await wm.transact(effects(place, wm, {"kit": ids["kit"], "gear": ids["gear2"]}))
        assert [e.id for e in wm.get_children(ids["kit"])] == [ids["gear2"]]
        assert evaluate(EmptyCond(param="gripper"), wm, b).ok


# Random scenes: three parts spread over three containers (or nowhere); random consistent
# predictions. Applying the effects makes every prediction true, and a second time is a no-op.
CONTAINERS, PARTS = ["c0", "c1", "c2"], ["p0", "p1", "p2"]


@st.composite
def scenarios(draw: st.DrawFn) -> tuple[dict[str, int | None], list[Condition]]:
    placement = {p: draw(st.one_of(st.none(), st.integers(0, 2))) for p in PARTS}
    facts: dict[str, Condition] = {}
    for _ in range(draw(st.integers(0, 5))):
        part, box, holds = (
            draw(st.sampled_from(PARTS)),
            draw(st.integers(0, 2)),
            draw(st.booleans()),
        )
        if holds:  # one spatial parent: a positive fact replaces every earlier one on the part
            facts = {k: v for k, v in facts.items() if not k.startswith(part)}
        elif f"{part}{box}" in facts:
            continue  # keep the set consistent
        facts[f"{part}{box}"] = RelationCond(
            subject=CONTAINERS[box], predicate="contain", object=part, holds=holds
        )
    if draw(st.booleans()):
        facts["mass"] = PropertyCond(
            param="p0", property="mass", value=draw(st.sampled_from([0.1, 0.2]))
        )
    return placement, list(facts.values())


@settings(max_examples=200, deadline=None)
@given(scenario=scenarios())
def test_effects_make_random_predictions_true(
    scenario: tuple[dict[str, int | None], list[Condition]],
) -> None:
    placement, post = scenario
    view = SceneView()
    ops: list[Op] = [AddElement(type="Box", ref=f"${c}") for c in CONTAINERS]
    for part, where in placement.items():
        rel = [] if where is None else [Relation(f"$c{where}", "contain", "$")]
        ops.append(AddElement(type="Gear", ref=f"${part}", relations=rel, properties={"mass": 0.1}))
    b = {k.lstrip("$"): v for k, v in view.apply(ops).items() if k.startswith("$")}
    made = effects(post, view, b)
    view.apply(made)
    assert evaluate_all(post, view, b).ok, (made, evaluate_all(post, view, b).reason)
    assert effects(post, view, b) == []


# --------------------------------------------------------------------------- symbolic


@pytest.mark.parametrize(
    ("cond", "atoms"),
    [
        (RelationCond(subject="b", predicate="contain", object="g"), [Atom("contain", ("b", "g"))]),
        (
            RelationCond(subject="b", predicate="contain", object="g", holds=False),
            [Atom("contain", ("b", "g"), False)],
        ),
        (PropertyCond(param="m", property="doorOpen", value=True), [Atom("doorOpen=true", ("m",))]),
        (
            PropertyCond(param="m", property="doorOpen", op="ne", value=False),
            [Atom("doorOpen=false", ("m",), False)],
        ),
        (
            PropertyCond(param="g", property="partNumber", value="G-100"),
            [Atom("partNumber=G-100", ("g",))],
        ),
        (PropertyCond(param="b", property="capacity", value=6), [Atom("capacity=6", ("b",))]),
        (PropertyCond(param="g", property="mass", op="exists"), [Atom("has_mass", ("g",))]),
        (PropertyCond(param="g", property="mass", value=0.2), None),
        (PropertyCond(param="g", property="mass", op="lt", value=1), None),
        (
            HasPropertyCond(param="g", property="pose", holds=False),
            [Atom("has_pose", ("g",), False)],
        ),
        (IsTypeCond(param="g", cls="Gear"), [Atom("is_Gear", ("g",))]),
        (EmptyCond(param="r"), [Atom("empty_contain", ("r",))]),
        (EmptyCond(param="r", predicate="hasA", holds=False), [Atom("empty_hasA", ("r",), False)]),
        (EmptyCond(param="r", full=True), None),
        (IsSpecifiedCond(param="g"), []),
        (CustomCond(name="anything"), None),
        (
            AndCond(items=[IsTypeCond(param="g", cls="Gear"), EmptyCond(param="r")]),
            [Atom("is_Gear", ("g",)), Atom("empty_contain", ("r",))],
        ),
        (AndCond(items=[IsTypeCond(param="g", cls="Gear"), EmptyCond(param="r", full=True)]), None),
        (OrCond(items=[EmptyCond(param="r")]), [Atom("empty_contain", ("r",))]),
        (OrCond(items=[EmptyCond(param="r"), EmptyCond(param="b")]), None),
        (NotCond(item=EmptyCond(param="r")), [Atom("empty_contain", ("r",), False)]),
        (NotCond(item=AndCond(items=[EmptyCond(param="r"), EmptyCond(param="b")])), None),
    ],
)
def test_symbolic_atoms(cond: Condition, atoms: list[Atom] | None) -> None:
    assert symbolic(cond) == atoms


def test_parameters_of_and_describe() -> None:
    cond = AndCond(
        items=[
            RelationCond(subject="box", predicate="contain", object="gear"),
            NotCond(item=EmptyCond(param="gripper", full=True)),
            OrCond(items=[CustomCond(name="heavy", params=["gear", "scale"], args={"kg": 1.0})]),
            PropertyCond(param="gear", property="mass", op="gt", value=0.3),
        ]
    )
    assert parameters_of(cond) == {"box", "gear", "gripper", "scale"}
    assert describe(cond) == (
        "(contain(box, gear) and not full(gripper) and (heavy(gear, scale, kg=1.0)) "
        "and gear.mass > 0.3)"
    )
