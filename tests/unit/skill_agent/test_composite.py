"""Composite skills: sequence, selector, parallel (all / first), retry as sub-runs through the
agent; parameter mappings checked at load; stop reaches the children first."""

from __future__ import annotations

import functools

import anyio
import msgspec
import pytest

from skill_agent import (
    CompositeSkill,
    Node,
    Parallel,
    Retry,
    Selector,
    Sequence,
    SkillLoadError,
    Step,
    check_composite,
)
from skill_agent.protocol import ParamSpec, SkillDescription, StartRun
from skill_agent.runtime import AgentCore, SkillEntry
from tests.assets.skills import (
    ALL,
    Pick,
    PickAndPlace,
    Place,
    Probe,
    entries,
)
from tests.assets.skills.basic import GRIPPER
from tests.assets.skills.kitting import CONTAINER, OBJ
from wm_store.ontology import Ontology

from .conftest import AgentFactory, Kitting

pytestmark = pytest.mark.anyio


def composite(
    name: str, tree: Node, parameters: list[ParamSpec] | None = None
) -> type[CompositeSkill]:
    return type(
        name.title().replace("_", ""),
        (CompositeSkill,),
        {"description": SkillDescription(name=name, parameters=parameters or []), "tree": tree},
    )


def catalog(probe: Probe, *composites: type[CompositeSkill]) -> dict[str, SkillEntry]:
    return entries(probe, *ALL, *composites)


def children_of(core: AgentCore, run_id: str) -> list[tuple[str, str]]:
    return [
        (r.skill, r.result.reason if r.result else r.state)
        for r in core.runs(active_only=False)
        if r.run_id.startswith(f"{run_id}.")
    ]


async def run(core: AgentCore, skill: str, **params: str) -> tuple[str, str, str]:
    started = await core.start(StartRun(skill=skill, params=dict(params)))
    with anyio.fail_after(5):
        result = await core.wait(started.run_id)
    return started.run_id, result.reason, result.message


# --------------------------------------------------------------------------- running


async def test_sequence_runs_children_as_sub_runs_borrowing_the_gripper(
    make_agent: AgentFactory, kitting: Kitting
) -> None:
    async with make_agent() as core:
        run_id, reason, _ = await run(
            core, "pick_and_place", obj=kitting["gear1"], container=kitting["kit"]
        )
        assert reason == "ok"
        assert children_of(core, run_id) == [("pick", "ok"), ("place", "ok")]
        child = core.status(f"{run_id}.1")
        assert child.resources == core.status(run_id).resources == [kitting["left"]]
    assert kitting.wm.get_parent(kitting["gear1"]).id == kitting["kit"]  # type: ignore[union-attr]


async def test_selector_falls_back_and_reports(make_agent: AgentFactory) -> None:
    async with make_agent() as core:
        run_id, reason, _ = await run(core, "fail_then_noop")
        assert reason == "ok"
        assert children_of(core, run_id) == [("fail", "execution"), ("noop", "ok")]
        both_fail = composite("both_fail", Selector([Step("fail"), Step("fail")]))
        core.replace_skills(catalog(Probe(), both_fail))
        _, reason, message = await run(core, "both_fail")
    assert reason == "execution" and message.startswith("every alternative failed")


async def test_parallel_all_overlaps_and_first_stops_the_losers(
    make_agent: AgentFactory, kitting: Kitting, probe: Probe
) -> None:
    both = composite(
        "both",
        Parallel(
            [
                Step("wait", {"gripper": "=" + kitting["left"]}),
                Step("wait", {"gripper": "=" + kitting["right"]}),
            ]
        ),
    )
    first = composite(
        "first",
        Parallel([Step("wait", {"gripper": "=" + kitting["left"]}), Step("noop")], mode="first"),
    )
    async with make_agent(catalog(probe, both, first)) as core:
        started = await core.start(StartRun(skill="both"))
        with anyio.fail_after(5):
            await probe.wait_calls("execute", 2)  # both children execute at once
            probe.open("release")
            result = await core.wait(started.run_id)
        assert result.success
        assert sorted(children_of(core, started.run_id)) == [("wait", "ok"), ("wait", "ok")]
        probe = Probe()
        core.replace_skills(catalog(probe, both, first))
        run_id, reason, _ = await run(core, "first")
        assert reason == "ok"
        assert sorted(children_of(core, run_id)) == [("noop", "ok"), ("wait", "preempted")]
    assert probe.count("on_preempt") == 1  # the loser was brought to a safe state


async def test_parallel_all_fails_when_one_fails_and_never_shares_a_device(
    make_agent: AgentFactory, kitting: Kitting, probe: Probe
) -> None:
    left = "=" + kitting["left"]
    one_fails = composite("one_fails", Parallel([Step("wait", {"gripper": left}), Step("fail")]))
    same_device = composite(
        "same_device", Parallel([Step("wait", {"gripper": left}), Step("slow", {"gripper": left})])
    )
    async with make_agent(catalog(probe, one_fails, same_device)) as core:
        run_id, reason, message = await run(core, "one_fails")
        assert reason == "execution" and "slipped" in message
        assert sorted(children_of(core, run_id)) == [("fail", "execution"), ("wait", "preempted")]
        run_id, reason, message = await run(core, "same_device")
    assert reason == "execution"
    assert f"device r1-left ({kitting['left']}) is busy" in message


async def test_retry_attempts_then_fails(make_agent: AgentFactory, probe: Probe) -> None:
    thrice = composite("thrice", Retry(Step("fail"), times=3))
    async with make_agent(catalog(probe, thrice)) as core:
        run_id, reason, message = await run(core, "thrice")
        assert children_of(core, run_id) == [("fail", "execution")] * 3
    assert reason == "execution" and message.startswith("failed 3 times; last: fail")


async def test_stopping_a_composite_preempts_the_running_child_first(
    make_agent: AgentFactory, probe: Probe
) -> None:
    hold = composite("hold", Sequence([Step("noop"), Step("wait")]))
    async with make_agent(catalog(probe, hold)) as core:
        started = await core.start(StartRun(skill="hold"))
        with anyio.fail_after(5):
            await probe.wait_calls("execute", 2)
            result = await core.stop(started.run_id)
        assert result.reason == "preempted"
        assert children_of(core, started.run_id) == [("noop", "ok"), ("wait", "preempted")]
    assert probe.methods(f"{started.run_id}.2")[-1] == "on_preempt"
    assert core.locks.statistics().held == {}


async def test_pausing_a_composite_holds_its_children(
    make_agent: AgentFactory, kitting: Kitting, probe: Probe
) -> None:
    hold = composite("hold", Sequence([Step("wait"), Step("noop")]))
    async with make_agent(catalog(probe, hold)) as core:
        started = await core.start(StartRun(skill="hold"))
        with anyio.fail_after(5):
            await probe.wait_calls("execute")
            await core.pause(started.run_id)
            probe.open("release")
            await anyio.wait_all_tasks_blocked()
            assert probe.methods(f"{started.run_id}.1")[-1] == "released"  # held in the child
            await core.resume(started.run_id)
            assert (await core.wait(started.run_id)).success


# --------------------------------------------------------------------------- load checks


@pytest.fixture
def skills() -> dict[str, SkillDescription]:
    return {cls.description.name: cls.description for cls in ALL}


PARENT = SkillDescription(name="parent", parameters=[GRIPPER, OBJ, CONTAINER])


@pytest.mark.parametrize(
    ("tree", "error"),
    [
        (Step("pik"), "no skill 'pik'; did you mean 'pick'"),
        (Step("pick", {"objct": "obj"}), "pick has no parameter 'objct'; did you mean 'obj'"),
        (Step("pick", {"obj": "part"}), "maps to 'part', which is no parameter of parent"),
        (Step("pick", {"obj": "container"}), "pick.obj is a Part; parent.container is a Container"),
        (Step("slow", {"steps": "=fast"}), "literal 'fast' is not a int"),
        (Sequence([]), "a Sequence node has no children"),
        (Step("parent"), "composite cycle: parent -> parent"),
    ],
)
def test_bad_mappings_fail_at_load(
    tree: Node, error: str, skills: dict[str, SkillDescription], ontology: Ontology
) -> None:
    with pytest.raises(SkillLoadError, match=error.replace("(", r"\(")):
        check_composite(tree, PARENT, {**skills, "parent": PARENT}, ontology)


def test_unmapped_required_value_parameter_is_a_load_error(
    skills: dict[str, SkillDescription], ontology: Ontology
) -> None:
    speedy = SkillDescription(name="speedy", parameters=[ParamSpec(name="speed", type="float")])
    with pytest.raises(
        SkillLoadError, match=r"speedy.speed \(float\) is not mapped and cannot be inferred"
    ):
        check_composite(Step("speedy"), PARENT, {**skills, "speedy": speedy}, ontology)
    check_composite(Step("speedy", {"speed": "=0.5"}), PARENT, {"speedy": speedy}, ontology)
    # element and hardware parameters left out are inferred by the child: fine
    check_composite(Step("place"), PARENT, skills, ontology)
    subclass = SkillDescription(name="p", parameters=[ParamSpec(name="gear", type="Gear")])
    check_composite(Step("pick", {"obj": "gear"}), subclass, skills, ontology)  # Gear is_a Part


def test_cycles_through_other_composites_are_found(
    skills: dict[str, SkillDescription], ontology: Ontology
) -> None:
    a = SkillDescription(name="a")
    b = SkillDescription(name="b")
    trees: dict[str, Node] = {"a": Step("b"), "b": Sequence([Step("noop"), Step("a")])}
    with pytest.raises(SkillLoadError, match="composite cycle: a -> b -> a"):
        check_composite(trees["a"], a, {**skills, "a": a, "b": b}, ontology, trees=trees)


async def test_agent_refuses_a_bad_composite_and_keeps_its_catalog(
    kitting: Kitting, probe: Probe
) -> None:
    bad = composite("bad", Step("pick", {"obj": "nothing"}))
    with pytest.raises(SkillLoadError, match="nothing"):
        AgentCore(name="x", wm=kitting.wm, skills=catalog(probe, bad))
    wrapped = SkillEntry(description=bad.description, factory=functools.partial(bad), source="p")
    with pytest.raises(SkillLoadError, match="nothing"):  # as plug-ins wrap classes
        AgentCore(name="x", wm=kitting.wm, skills={**catalog(probe), "bad": wrapped})
    core = AgentCore(name="x", wm=kitting.wm, skills=entries(probe, Pick, Place, PickAndPlace))
    with pytest.raises(SkillLoadError, match="no skill 'place'"):
        core.replace_skills(entries(probe, Pick, PickAndPlace))
    assert {d.name for d in core.descriptions()} == {"pick", "place", "pick_and_place"}


def test_nodes_round_trip_on_the_wire() -> None:
    tree: Node = Retry(
        Selector([Parallel([Step("pick", {"obj": "obj"}), Step("noop")], mode="first"), Step("x")]),
        times=3,
    )
    data = msgspec.msgpack.encode(tree)
    assert msgspec.msgpack.decode(data, type=Node) == tree
    assert msgspec.json.decode(msgspec.json.encode(Sequence([Step("a")])), type=Node) == Sequence(
        [Step("a")]
    )
