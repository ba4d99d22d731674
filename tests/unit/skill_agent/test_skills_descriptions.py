"""The standard skills' descriptions: they pass the load checks against the real ontology,
every condition has a planner face (except the documented run-time-only ones), the agent
configs of both scenarios load them, and a real planner reaches the scenarios' goals with them
over the scenes ``scenario.wm`` builds."""

from __future__ import annotations

from collections.abc import AsyncIterator
from pathlib import Path

import anyio
import msgspec
import pytest

from scenario import load_scenario
from skill_agent.conditions import describe, symbolic
from skill_agent.parameters import check_description, is_value_kind
from skill_agent.protocol import SkillDescription
from skill_agent.runtime import SkillRegistry, load_config
from skill_agent.skills import ALL_SKILLS, HEATED, RUNTIME_ONLY
from tests.unit.skill_agent.scenario_planning import plan_scenario
from wm_store import InMemoryTransport, WmClient
from wm_store.ontology import Ontology
from wm_store.server import WmService, WmStore

ROOT = Path(__file__).resolve().parents[3]
CONFIGS = ROOT / "configs" / "agents"
DESCRIPTIONS = [cls.description for cls in ALL_SKILLS]


@pytest.fixture(scope="module")
def ontology() -> Ontology:
    return Ontology.default()


@pytest.mark.parametrize("desc", DESCRIPTIONS, ids=lambda d: f"{d.name}-{d.doc[:12]}")
def test_every_description_passes_the_load_checks(
    desc: SkillDescription, ontology: Ontology
) -> None:
    check_description(desc, ontology)
    assert desc.doc and desc.duration > 0
    for spec in desc.parameters:
        assert spec.doc, f"{desc.name}.{spec.name} has no doc"
        if spec.kind == "hardware":
            assert not is_value_kind(spec.type)
        if spec.kind == "offline":
            assert spec.default is not None


@pytest.mark.parametrize("desc", DESCRIPTIONS, ids=lambda d: f"{d.name}-{d.doc[:12]}")
def test_every_condition_has_a_planner_face_unless_documented(desc: SkillDescription) -> None:
    allowed = set(RUNTIME_ONLY.get(desc.name, ()))
    runtime = {describe(c) for c in [*desc.pre, *desc.hold, *desc.post] if symbolic(c) is None}
    assert runtime == allowed & runtime
    assert not any(symbolic(c) is None for c in desc.post), "predictions must be plannable"


def test_the_runtime_only_list_names_real_conditions() -> None:
    by_name = {d.name: d for d in DESCRIPTIONS}
    for name, conds in RUNTIME_ONLY.items():
        texts = {describe(c) for c in by_name[name].pre}
        assert set(conds) <= texts


def test_descriptions_survive_the_wire() -> None:
    for desc in DESCRIPTIONS:
        data = msgspec.json.encode(desc)
        assert msgspec.json.decode(data, type=SkillDescription) == desc


CONFIG_FILES = ["kitting/r1", "kitting/r2", "meal/friend", "meal/microwave"]


@pytest.mark.parametrize("name", CONFIG_FILES)
def test_the_agent_configs_load_the_library(name: str, ontology: Ontology) -> None:
    config = load_config(CONFIGS / f"{name}.toml")
    entries = SkillRegistry.from_config(config, ontology).load()
    config.check_skill_names(entries)
    assert entries, "skills loaded"


@pytest.fixture
async def wm(ontology: Ontology) -> AsyncIterator[WmClient]:
    store = await WmStore.open(ontology)
    async with anyio.create_task_group() as tg:
        await tg.start(store.run)
        async with WmClient.connect(InMemoryTransport(WmService(store)), ontology) as client:
            yield client
        tg.cancel_scope.cancel()


@pytest.mark.anyio
async def test_the_kitting_goals_are_plannable(wm: WmClient) -> None:
    scenario = load_scenario(ROOT / "configs" / "scenarios" / "kitting" / "scenario.toml")
    plan = await plan_scenario(
        wm, "kitting", ["kitting/r1", "kitting/r2"], " and ".join(scenario.goals)
    )
    skills = [s.skill for s in plan.steps]
    assert skills.count("pick") == skills.count("place") == len(scenario.goals)
    assert {s.agent for s in plan.steps} == {"r1", "r2"}
    assert skills.count("navigate") >= 2


@pytest.mark.anyio
async def test_the_meal_goal_is_plannable_through_the_microwave(wm: WmClient) -> None:
    goal = "contain(Microwave-1, MealBox-1) and doorOpen(Microwave-1) = false"
    plan = await plan_scenario(wm, "meal", ["meal/friend", "meal/microwave"], goal)
    skills = [s.skill for s in plan.steps]
    assert skills.index("pick") < skills.index("put_in") < skills.index("close_door")
    assert "open_door" in skills


@pytest.mark.anyio
async def test_serving_the_meal_is_plannable(wm: WmClient) -> None:
    scenario = load_scenario(ROOT / "configs" / "scenarios" / "meal" / "scenario.toml")
    goal = " and ".join(g for g in scenario.goals if HEATED or "heated" not in g)
    plan = await plan_scenario(wm, "meal", ["meal/friend", "meal/microwave"], goal)
    skills = [s.skill for s in plan.steps]
    assert skills[-1] == "serve"
    if HEATED:  # the ontology knows `heated`: the meal goes through the microwave
        assert "heat" in skills and skills.index("heat") < skills.index("serve")


def test_entry_points_publish_the_whole_library() -> None:
    """Every standard skill is installed under the ``skimesh.skills`` entry-point group."""
    from importlib.metadata import entry_points

    from skill_agent.skills import ALL_SKILLS

    published = {ep.load() for ep in entry_points(group="skimesh.skills")}
    assert published == set(ALL_SKILLS)
