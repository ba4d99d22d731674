"""Parameters: validation, defaults, partial definitions, ranked inference, load-time checks.

Scenes are built through a real ``WmClient`` over the in-memory transport::

    station contain table contain box-a (PartBox, world pose 1 0 0.5), box-b (PartBox, 3 0 0.5)
    r1 (MobileManipulator, pose 0 0 0) hasA arm hasA gripper; r1 contain kit (KitBox)

Each test adds its gears (poses in the frame of their box) in a second transaction.
"""

from __future__ import annotations

from collections.abc import AsyncIterator, Sequence
from contextlib import asynccontextmanager

import anyio
import msgspec
import pytest

from skill_agent import (
    InferenceError,
    ParameterError,
    ParameterTypeError,
    SkillLoadError,
    UnknownParameterError,
    UnspecifiedParameterError,
)
from skill_agent.conditions import ConditionRegistry
from skill_agent.parameters import (
    VALUE_KINDS,
    check_description,
    check_kind,
    describe_query,
    is_value_kind,
    param_states,
    specify,
    world_position,
)
from skill_agent.parameters import _inference as inference
from skill_agent.protocol import (
    AndCond,
    Condition,
    CustomCond,
    EmptyCond,
    HasPropertyCond,
    IsSpecifiedCond,
    IsTypeCond,
    NotCond,
    ParamSpec,
    PropertyCond,
    RelationCond,
    SkillDescription,
)
from wm_store import InMemoryTransport, WmClient
from wm_store.ontology import Ontology
from wm_store.protocol import (
    AddElement,
    Op,
    Orientation,
    Pose,
    Position,
    PropertyFilter,
    Query,
    Relation,
    SetRelation,
    SizeCylinder,
    UnsetRelation,
    Value,
)
from wm_store.server import WmService, WmStore

pytestmark = pytest.mark.anyio
ONTOLOGY = Ontology.default()

BASE = [
    AddElement(type="Station", ref="$station"),
    AddElement(type="Table", ref="$table", relations=[Relation("$station", "contain", "$")]),
    AddElement(
        type="PartBox",
        label="box-a",
        ref="$box_a",
        properties={"pose": Pose(Position(1.0, 0.0, 0.5))},
        relations=[Relation("$table", "contain", "$")],
    ),
    AddElement(
        type="PartBox",
        label="box-b",
        ref="$box_b",
        properties={"pose": Pose(Position(3.0, 0.0, 0.5))},
        relations=[Relation("$table", "contain", "$")],
    ),
    AddElement(
        type="MobileManipulator", ref="$robot", properties={"pose": Pose(Position(0, 0, 0))}
    ),
    AddElement(type="Arm", ref="$arm", relations=[Relation("$robot", "hasA", "$")]),
    AddElement(type="Gripper", ref="$gripper", relations=[Relation("$arm", "hasA", "$")]),
    AddElement(type="KitBox", ref="$kit", relations=[Relation("$robot", "contain", "$")]),
]


def gear(
    where: str, x: float = 0.0, *, label: str = "", mass: float = 0.2, id: str = ""
) -> AddElement:
    """A gear contained by ``where`` (a ref or id), at ``x`` along that element's frame."""
    return AddElement(
        type="Gear",
        label=label,
        id=id,
        properties={"mass": mass, "pose": Pose(Position(x, 0.0, 0.0), frame=where)},
        relations=[Relation(where, "contain", "$")],
    )


class World(msgspec.Struct):
    wm: WmClient
    ids: dict[str, str]

    def __getitem__(self, name: str) -> str:
        return self.ids[name]

    async def gears(self, *placed: tuple[str, float]) -> list[str]:
        """Add one gear per ``(container short name, x)``; their ids in order."""
        ops: list[Op] = [gear(self[where], x) for where, x in placed]
        reply = await self.wm.transact(ops)
        return [reply.ids[f"#{i}"] for i in range(len(ops))]


@asynccontextmanager
async def world() -> AsyncIterator[World]:
    store = await WmStore.open(ONTOLOGY)
    async with anyio.create_task_group() as tg:
        await tg.start(store.run)
        async with WmClient.connect(InMemoryTransport(WmService(store)), ONTOLOGY) as wm:
            reply = await wm.transact(BASE)
            ids = {k[1:]: v for k, v in reply.ids.items() if k.startswith("$")}
            yield World(wm=wm, ids=ids)
        tg.cancel_scope.cancel()


PICK_PRE: list[Condition] = [
    RelationCond(subject="box", predicate="contain", object="gear"),
    EmptyCond(param="gripper"),
]
PICK = SkillDescription(
    name="pick",
    parameters=[
        ParamSpec(name="gripper", type="Gripper", kind="hardware"),
        ParamSpec(name="gear", type="Gear"),
        ParamSpec(name="box", type="PartBox"),
        ParamSpec(name="speed", type="float", kind="offline", default=0.5),
        ParamSpec(name="note", type="str", kind="offline", optional=True),
    ],
    pre=PICK_PRE,
    post=[
        RelationCond(subject="gripper", predicate="contain", object="gear"),
        RelationCond(subject="box", predicate="contain", object="gear", holds=False),
    ],
)


def with_params(*params: ParamSpec, pre: Sequence[Condition] = PICK_PRE) -> SkillDescription:
    return msgspec.structs.replace(PICK, parameters=list(params), pre=list(pre))


# --------------------------------------------------------------------------- ranking


async def test_a_false_precondition_loses_before_distance() -> None:
    async with world() as w:
        near_on_table, in_box = await w.gears(("table", 0.1), ("box_a", 0.4))
        spec = specify(PICK, {"box": w["box_a"]}, w.wm, robot=w["robot"])
        assert spec.values == {
            "gripper": w["gripper"],
            "gear": in_box,
            "box": w["box_a"],
            "speed": 0.5,
            "note": None,
        }
        reason = spec.inferred["gear"]
        assert reason.startswith(f"{in_box}: chosen from 2 Gear candidates")
        assert f"runner-up {near_on_table}" in reason
        assert f"decided by pre-conditions ({near_on_table}: contain(PartBox-1, Gear-1) " in reason
        assert "Gear-1's spatial parent is Table-1" in reason
        assert spec.inferred["gripper"] == "Gripper-1: this agent's only Gripper"
        assert set(spec.inferred) == {"gear", "gripper"}


async def test_distance_breaks_ties_and_ids_break_the_rest() -> None:
    async with world() as w:
        far, near = await w.gears(("box_a", 0.1), ("box_a", -0.1))  # box-a is at x = 1
        spec = specify(PICK, {"box": w["box_a"]}, w.wm, robot=w["robot"])
        assert spec.values["gear"] == near
        assert spec.inferred["gear"] == (
            f"{near}: chosen from 2 Gear candidates; runner-up {far}; decided by distance to "
            f"{w['robot']} ({near} 1.030 m, {far} 1.208 m)"
        )
        no_robot = specify(PICK, {"box": w["box_a"], "gripper": w["gripper"]}, w.wm)
        assert no_robot.values["gear"] == far
        assert no_robot.inferred["gear"].endswith(
            f"runner-up {near}; decided by natural id order "
            "(tied on pre-conditions; no robot given to measure distance)"
        )
        assert "gripper" not in no_robot.inferred  # given, not inferred


async def test_natural_id_order_and_missing_poses() -> None:
    async with world() as w:
        await w.wm.transact([gear(w["box_b"], id="Gear-9"), gear(w["box_b"], id="Gear-10")])
        await w.wm.update_element("Gear-10", {"pose": None})
        spec = specify(PICK, {"box": w["box_b"]}, w.wm, robot=w["robot"])
        assert spec.values["gear"] == "Gear-9"
        assert (
            "distance to MobileManipulator-1 (Gear-9 3.041 m, Gear-10 no pose)"
            in (spec.inferred["gear"])
        )
        await w.wm.update_element("Gear-9", {"pose": None})
        spec = specify(PICK, {"box": w["box_b"]}, w.wm, robot=w["robot"])
        assert spec.values["gear"] == "Gear-9"  # natural order: 9 before 10
        assert (
            "natural id order (tied on pre-conditions; neither has a pose)"
            in (spec.inferred["gear"])
        )


async def test_inference_is_rerun_on_every_call() -> None:
    async with world() as w:
        first, second = await w.gears(("box_a", -0.1), ("box_a", 0.1))
        given = {"box": w["box_a"]}
        assert specify(PICK, given, w.wm, robot=w["robot"]).values["gear"] == first
        await w.wm.transact(
            [
                UnsetRelation(subject=w["box_a"], predicate="contain", object=first),
                SetRelation(subject=w["kit"], predicate="contain", object=first),
            ]
        )
        again = specify(PICK, given, w.wm, robot=w["robot"])
        assert again.values["gear"] == second
        assert again.inferred["gear"].startswith(f"{second}: chosen from 2")
        explicit = specify(PICK, {**given, "gear": first}, w.wm, robot=w["robot"])
        assert explicit.values["gear"] == first and "gear" not in explicit.inferred


async def test_inference_backtracks_out_of_a_dead_end() -> None:
    async with world() as w:
        loose, boxed = await w.gears(("table", 0.0), ("box_b", 0.0))
        spec = specify(PICK, {}, w.wm, hardware={"gripper": w["gripper"]})
        assert (spec.values["gear"], spec.values["box"]) == (boxed, w["box_b"])
        assert spec.inferred["gear"].startswith(
            f"{boxed}: chosen from 2 Gear candidates; {loose} ranked higher, but then 'box' has "
            "no viable candidate: every candidate fails a pre-condition: PartBox-1: "
            f"contain(PartBox-1, {loose}) does not hold"
        )
        assert spec.inferred["box"].startswith(f"{w['box_b']}: chosen from 2 PartBox candidates")
        assert "runner-up PartBox-1; decided by pre-conditions" in spec.inferred["box"]


async def test_most_constrained_parameter_is_inferred_first() -> None:
    async with world() as w:
        await w.gears(("box_a", 0.0), ("box_b", 0.0))
        box = ParamSpec(name="box", type="PartBox", partial=Query(label="box-b"))
        desc = with_params(ParamSpec(name="gear", type="Gear"), box)
        spec = specify(desc, {}, w.wm)
        assert spec.values == {"gear": "Gear-2", "box": w["box_b"]}
        assert spec.inferred["box"] == f"{w['box_b']}: the only PartBox candidate"
        assert spec.inferred["gear"].endswith(
            "decided by pre-conditions (Gear-1: "
            "contain(PartBox-2, Gear-1) does not hold: "
            "Gear-1's spatial parent is PartBox-1 (contain))"
        )


# --------------------------------------------------------------------------- no candidate


async def test_empty_inference_explains_each_kind_of_rejection() -> None:
    async with world() as w:
        with pytest.raises(InferenceError) as no_class:
            specify(PICK, {"box": w["box_a"]}, w.wm, robot=w["robot"])
        assert str(no_class.value) == (
            "cannot infer parameter 'gear' (a Gear) of skill 'pick': the world model has no "
            "Gear (nor an element of a subclass). Give 'gear' explicitly (still initialized: "
            "gear, note (optional); specified: gripper, box, speed)"
        )
        assert no_class.value.param_states == {
            "gripper": "specified",
            "gear": "initialized",
            "box": "specified",
            "speed": "specified",
            "note": "initialized",
        }
        await w.gears(("table", 0.0), ("table", 0.5))
        heavy = ParamSpec(
            name="gear",
            type="Gear",
            partial=Query(filters=[PropertyFilter(property="mass", op="gt", value=1.0)]),
        )
        desc = with_params(ParamSpec(name="box", type="PartBox"), heavy)
        with pytest.raises(
            InferenceError,
            match=r"Gear-1, Gear-2 are Gear but none matches its "
            r"partial definition \(mass > 1.0\)",
        ):
            specify(desc, {"box": w["box_a"]}, w.wm)
        with pytest.raises(InferenceError) as blocked:
            specify(PICK, {"box": w["box_a"]}, w.wm, robot=w["robot"])
        assert str(blocked.value) == (
            "cannot infer parameter 'gear' (a Gear) of skill 'pick': every candidate fails a "
            "pre-condition: Gear-1: contain(PartBox-1, Gear-1) does not hold: Gear-1's spatial "
            "parent is Table-1 (contain); Gear-2: contain(PartBox-1, Gear-2) does not hold: "
            "Gear-2's spatial parent is Table-1 (contain). Give 'gear' explicitly (still "
            "initialized: gear, note (optional); specified: gripper, box, speed)"
        )
        none_of_two = with_params(
            ParamSpec(name="gear", type="Gear"), ParamSpec(name="box", type="PartBox")
        )
        with pytest.raises(
            InferenceError, match=r"'box' .*every candidate fails.*\(tried gear = Gear-1, Gear-2\)"
        ):
            specify(none_of_two, {}, w.wm)


async def test_inference_gives_up_after_its_budget(monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setattr(inference, "BUDGET", 5)
    async with world() as w:
        await w.wm.transact([AddElement(type=t) for t in ["Gear", "Shaft", "Bolt"] for _ in "123"])
        desc = with_params(
            ParamSpec(name="gear", type="Gear"),
            ParamSpec(name="shaft", type="Shaft"),
            ParamSpec(name="bolt", type="Bolt"),
            pre=[
                AndCond(
                    items=[
                        RelationCond(subject="shaft", predicate="attachedTo", object="gear"),
                        RelationCond(subject="bolt", predicate="attachedTo", object="shaft"),
                    ]
                )
            ],
        )
        with pytest.raises(InferenceError) as err:
            specify(desc, {}, w.wm)
        assert str(err.value) == (
            "skill 'pick': inference gave up after 5 trials without finding values of shaft, "
            "bolt for which every pre-condition holds; give some of them explicitly (still "
            "initialized: gear, shaft, bolt; specified: none)"
        )
        assert set(err.value.param_states.values()) == {"initialized"}


# --------------------------------------------------------------------------- partial definitions


async def test_partial_definitions_narrow_given_and_inferred_values() -> None:
    async with world() as w:
        await w.wm.transact([gear(w["box_a"], -0.1), gear(w["box_a"], 0.3, label="big", mass=0.5)])
        big = ParamSpec(name="gear", type="Gear", partial=Query(label="big"))
        desc = with_params(big, ParamSpec(name="box", type="PartBox"))
        spec = specify(desc, {"box": w["box_a"]}, w.wm, robot=w["robot"])
        assert spec.values["gear"] == "Gear-2"  # farther, but the only big one
        assert spec.inferred["gear"] == "Gear-2: the only Gear candidate"
        with pytest.raises(
            ParameterTypeError,
            match=r"Gear-1 does not match its partial "
            r"definition \(label 'big'\)",
        ):
            specify(desc, {"box": w["box_a"], "gear": "Gear-1"}, w.wm)
        in_a = Query(related=[Relation(w["box_a"], "contain", "?")])
        boxed = ParamSpec(
            name="gear", type="Part", partial=msgspec.structs.replace(in_a, type="Gear")
        )
        spec = specify(with_params(boxed, pre=[]), {}, w.wm, robot=w["robot"])
        assert spec.values["gear"] == "Gear-1"
        assert describe_query(in_a) == f"contain({w['box_a']}, ?)"


# --------------------------------------------------------------------------- validation


async def test_unknown_parameter_names_the_closest() -> None:
    async with world() as w:
        with pytest.raises(UnknownParameterError) as err:
            specify(PICK, {"gaer": "Gear-1", "speeed": 1.0}, w.wm)
        assert str(err.value) == (
            "skill 'pick' has no parameter 'gaer' (did you mean 'gear'?), 'speeed' (did you mean "
            "'speed'?). Its parameters: gripper, gear, box, speed, note"
        )


async def test_value_kinds_and_defaults() -> None:
    async with world() as w:
        (g,) = await w.gears(("box_a", 0.0))
        base = {"box": w["box_a"], "gear": g}
        spec = specify(PICK, {**base, "speed": 1, "note": "careful"}, w.wm, robot=w["robot"])
        assert spec.values["speed"] == 1.0 and isinstance(spec.values["speed"], float)
        assert spec.values["note"] == "careful"
        with pytest.raises(ParameterTypeError, match="'speed' takes a float value, got bool True"):
            specify(PICK, {**base, "speed": True}, w.wm, robot=w["robot"])
        with pytest.raises(ParameterTypeError, match="'note' takes a str value, got int 3"):
            specify(PICK, {**base, "note": 3}, w.wm, robot=w["robot"])


@pytest.mark.parametrize(
    ("kind", "value", "ok"),
    [
        ("float", 1, True),
        ("float", 1.5, True),
        ("float", True, False),
        ("float", "1.0", False),
        ("int", 2, True),
        ("int", False, False),
        ("int", 2.0, False),
        ("bool", True, True),
        ("bool", 1, False),
        ("str", "x", True),
        ("string", "x", True),
        ("list", [1, "a"], True),
        ("list", "abc", False),
        ("any", Pose(Position(0, 0, 0)), True),
        ("Pose", Pose(Position(0, 0, 0)), True),
        ("Pose", Position(0, 0, 0), False),
        ("Position", Position(0, 0, 0), True),
        ("Orientation", Orientation(), True),
        ("Size", SizeCylinder(0.1, 0.2), True),
        ("SizeCuboid", SizeCylinder(0.1, 0.2), False),
    ],
)
def test_check_kind(kind: str, value: Value, ok: bool) -> None:
    spec = ParamSpec(name="p", type=kind)
    assert is_value_kind(kind) and kind in VALUE_KINDS
    if ok:
        assert check_kind(spec, value) == value
    else:
        with pytest.raises(ParameterTypeError, match=f"parameter 'p' takes an? {kind} value"):
            check_kind(spec, value)


async def test_element_values_are_checked() -> None:
    async with world() as w:
        (g,) = await w.gears(("box_a", 0.0))
        with pytest.raises(
            ParameterError,
            match="no element 'Gear-99' in the world model; did you mean 'Gear-1'",
        ):
            specify(PICK, {"box": w["box_a"], "gear": "Gear-99"}, w.wm, robot=w["robot"])
        with pytest.raises(ParameterError, match=r"'Zz'.*; elements of class Gear: Gear-1$"):
            specify(PICK, {"box": w["box_a"], "gear": "Zz"}, w.wm, robot=w["robot"])
        with pytest.raises(ParameterTypeError) as wrong:
            specify(PICK, {"box": w["box_a"], "gear": w["box_b"]}, w.wm, robot=w["robot"])
        assert str(wrong.value) == (
            "parameter 'gear' of skill 'pick' takes a Gear; box-b (PartBox-2) is a PartBox "
            "(PartBox < Box < Container < PhysicalObject)"
        )
        with pytest.raises(ParameterTypeError, match="takes an element id \\(a Gear\\), got 3"):
            specify(PICK, {"box": w["box_a"], "gear": 3}, w.wm, robot=w["robot"])
        part = with_params(ParamSpec(name="gear", type="Part"), ParamSpec(name="box", type="Box"))
        spec = specify(part, {"gear": g, "box": w["kit"]}, w.wm)  # subclasses fit
        assert spec.values == {"gear": g, "box": w["kit"]} and spec.inferred == {}


async def test_required_optional_and_defaults() -> None:
    async with world() as w:
        (g,) = await w.gears(("box_a", 0.0))
        desc = with_params(
            ParamSpec(name="gear", type="Gear"),
            ParamSpec(name="box", type="PartBox", optional=True),
            ParamSpec(name="force", type="float"),
            pre=[],
        )
        with pytest.raises(UnspecifiedParameterError) as err:
            specify(desc, {"gear": g}, w.wm)
        assert str(err.value) == (
            "parameter 'force' (float) of skill 'pick' is required and has no default; give it "
            "in the start request's params (still initialized: box (optional), force; "
            "specified: gear)"
        )
        assert err.value.param_states == {
            "gear": "specified",
            "box": "initialized",
            "force": "initialized",
        }
        two = with_params(*desc.parameters, ParamSpec(name="depth", type="int"), pre=[])
        with pytest.raises(UnspecifiedParameterError) as both:
            specify(two, {}, w.wm)  # every missing value is named; gear is not inferred yet
        assert str(both.value) == (
            "parameters 'force' (float), 'depth' (int) of skill 'pick' are required and have "
            "no default; give them in the start request's params (still initialized: gear, "
            "box (optional), force, depth; specified: none)"
        )
        spec = specify(desc, {"force": 2.0, "box": None}, w.wm)
        assert spec.values == {"gear": g, "box": None, "force": 2.0}  # optional: not inferred
        assert param_states(desc, spec.values) == {
            "gear": "specified",  # inferred
            "box": "initialized",  # optional, left without a value
            "force": "specified",
        }
        defaulted = with_params(ParamSpec(name="gear", type="Gear", default=g), pre=[])
        assert specify(defaulted, {}, w.wm).values == {"gear": g}


# --------------------------------------------------------------------------- hardware


async def test_hardware_parameters_come_from_this_agent() -> None:
    async with world() as w:
        (g,) = await w.gears(("box_a", 0.0))
        given = {"box": w["box_a"], "gear": g}
        offered = specify(PICK, given, w.wm, hardware={"gripper": w["gripper"]})
        assert offered.values["gripper"] == w["gripper"]
        assert offered.inferred["gripper"] == "Gripper-1: this agent's 'gripper' device"
        reply = await w.wm.transact(
            [
                AddElement(type="Arm", ref="$arm2", relations=[Relation(w["robot"], "hasA", "$")]),
                AddElement(type="Gripper", relations=[Relation("$arm2", "hasA", "$")]),
                AddElement(type="MobileManipulator", ref="$other"),
                AddElement(type="Gripper", relations=[Relation("$other", "hasA", "$")]),
            ]
        )
        second, foreign = reply.ids["#1"], reply.ids["#3"]
        two = specify(PICK, given, w.wm, robot=w["robot"])
        assert two.values["gripper"] == w["gripper"]
        assert two.inferred["gripper"] == (
            f"Gripper-1: first by id of this agent's 2 Gripper devices (Gripper-1, {second}); "
            f"runner-up {second}; give 'gripper' to choose another"
        )
        chosen = specify(PICK, {**given, "gripper": second}, w.wm, robot=w["robot"])
        assert chosen.values["gripper"] == second
        with pytest.raises(
            ParameterError,
            match=f"{foreign} is not a device of this agent; its "
            f"Gripper devices: Gripper-1, {second}",
        ):
            specify(PICK, {**given, "gripper": foreign}, w.wm, robot=w["robot"])
        with pytest.raises(InferenceError, match="this agent offers no such device") as none:
            specify(PICK, given, w.wm)
        assert none.value.param_states["gripper"] == "initialized"
        assert none.value.param_states["gear"] == "specified"


async def test_world_position_chains_frames() -> None:
    async with world() as w:
        (g,) = await w.gears(("box_a", 0.25))
        assert world_position(w.wm, g) == pytest.approx((1.25, 0.0, 0.5))
        assert world_position(w.wm, w["table"]) is None  # no pose
        await w.wm.update_element(w["box_a"], {"pose": Pose(Position(0, 0, 0), frame=g)})
        assert world_position(w.wm, g) is None  # frames form a cycle


# --------------------------------------------------------------------------- load checks


class Heavy:
    name = "heavy"


def load_problems(desc: SkillDescription, registry: ConditionRegistry | None = None) -> str:
    with pytest.raises(SkillLoadError) as err:
        check_description(desc, ONTOLOGY, registry=registry)
    return str(err.value)


def test_a_valid_description_passes() -> None:
    check_description(PICK, ONTOLOGY)
    full = msgspec.structs.replace(
        PICK,
        hold=[
            AndCond(
                items=[
                    IsTypeCond(param="gear", cls="Part"),
                    NotCond(item=HasPropertyCond(param="gear", property="color")),
                    PropertyCond(param="gear", property="mass", op="lt", value=1),
                    PropertyCond(param="box", property="capacity", value=20),
                    IsSpecifiedCond(param="speed"),
                    RelationCond(subject="box", predicate="spatialRelation", object="gear"),
                ]
            )
        ],
    )
    check_description(full, ONTOLOGY)


def test_misspelt_names_fail_with_the_closest() -> None:
    desc = msgspec.structs.replace(
        PICK,
        parameters=[
            *PICK.parameters[:1],
            ParamSpec(name="gear", type="Gera"),
            *PICK.parameters[2:],
        ],
        pre=[
            RelationCond(subject="box", predicate="contian", object="gear"),
            PropertyCond(param="gear", property="mas", op="gt", value=0.1),
            EmptyCond(param="griper"),
            IsTypeCond(param="gear", cls="Shaftt"),
        ],
    )
    text = load_problems(desc)
    assert text.startswith("skill 'pick' fails its load checks:\n")
    assert (
        "  - parameter 'gear': unknown type 'Gera' (did you mean 'Gear' or 'Camera'?); a type is "
        "an ontology class or a value kind (Color, Frame, Orientation, Pose, Position, Size, "
        "SizeCuboid, SizeCylinder, SizeSphere, any, bool, float, int, list, str, string)" in text
    )
    assert (
        "  - pre[0] contian(box, gear): unknown relation 'contian'; did you mean 'contain'?" in text
    )
    assert "  - pre[1] gear.mas > 0.1: unknown data property 'mas'; did you mean 'mass'" in text
    assert (
        "  - pre[2] empty(griper): unknown parameter 'griper' (did you mean 'gripper' or 'gear'?); "
        "parameters: gripper, gear, box, speed, note" in text
    )
    assert "  - pre[3] gear is a Shaftt: unknown class 'Shaftt'; did you mean 'Shaft'?" in text


def test_condition_parameters_and_kinds_are_checked() -> None:
    desc = msgspec.structs.replace(
        PICK,
        pre=[
            RelationCond(subject="gear", predicate="contain", object="box"),  # swapped
            PropertyCond(param="gear", property="capacity", value=3),  # capacity is a Container's
            EmptyCond(param="speed"),
            IsSpecifiedCond(param="nope"),
            PropertyCond(param="gear", property="mass", value="heavy"),
            PropertyCond(param="gear", property="mass", op="gt", value=True),
            IsTypeCond(param="gear", cls="Container"),
        ],
        post=[RelationCond(subject="box", predicate="spatialRelation", object="gear")],
    )
    text = load_problems(desc)
    assert (
        "pre[0] contain(gear, box): the subject of 'contain' must be Container or Location or "
        "Machine; 'gear' is a Gear" in text
    )
    assert "pre[1] gear.capacity == 3: the element of property 'capacity' must be Container" in text
    assert "pre[2] empty(speed): parameter 'speed' is a float value, not an element" in text
    assert "pre[3] specified(nope): unknown parameter 'nope'" in text
    assert "pre[4] gear.mass == 'heavy': property 'mass' takes float" in text
    assert "pre[5] gear.mass > True: 'gt' compares numbers or strings, not True" in text
    assert "pre[6] gear is a Container: 'gear' is a Gear, never a Container" in text
    assert "post[0] spatialRelation(box, gear): 'spatialRelation' is abstract" in text


def test_custom_conditions_must_be_registered() -> None:
    desc = msgspec.structs.replace(
        PICK, pre=[CustomCond(name="heavy", params=["gear", "wheel"], args={"limit": 1.0})]
    )
    text = load_problems(desc)
    assert "unknown custom condition 'heavy'. Registered: none" in text
    assert "unknown parameter 'wheel'" in text
    registry = ConditionRegistry()

    class Heavvy:
        name = "heavvy"

        def evaluate(self, *args: object) -> object:
            raise NotImplementedError

        def symbolic(self, *args: object) -> object:
            raise NotImplementedError

    registry.register(Heavvy)  # type: ignore[arg-type]
    assert "unknown custom condition 'heavy'; did you mean 'heavvy'?" in load_problems(
        desc, registry
    )


def test_parameter_specs_are_checked() -> None:
    desc = SkillDescription(
        name="bad",
        parameters=[
            ParamSpec(name="a", type="float", default="fast"),
            ParamSpec(name="a", type="int"),
            ParamSpec(name="arm", type="float", kind="hardware"),
            ParamSpec(name="v", type="str", partial=Query(label="x")),
            ParamSpec(name="g", type="Gear", default=3),
            ParamSpec(name="h", type="Gear", partial=Query(type="Box")),
            ParamSpec(
                name="i",
                type="Gear",
                partial=Query(filters=[PropertyFilter(property="weight", op="exists")]),
            ),
            ParamSpec(
                name="j", type="Gear", partial=Query(related=[Relation("A", "contain", "B")])
            ),
        ],
    )
    text = load_problems(desc)
    for expected in [
        "parameter 'a': bad default: parameter 'a' takes a float value, got string 'fast'",
        "parameter 'a' is declared twice",
        "parameter 'arm': a hardware parameter is a device (a class), not a float value",
        "parameter 'v': a partial definition needs an element parameter",
        "parameter 'g': the default of an element parameter is an element id, not 3",
        "parameter 'h': partial type Box can never be a Gear",
        "parameter 'i': partial definition: unknown data property 'weight'",
        "parameter 'j': partial relation Relation(subject='A', predicate='contain', object='B') "
        "needs '?'",
    ]:
        assert expected in text
