"""Planning for a fixed robot: the shipped ``kitting-cell`` scenario (a Panda on a pedestal, no
base) registers arm and gripper only, its agent offers no ``navigate``, and the real planner
reaches the scenario's goals with pick and place_at, without a single navigate step: the robot
and both boxes are ``at`` its home."""

from __future__ import annotations

from collections.abc import AsyncIterator
from pathlib import Path

import pytest

from scenario import load_scenario
from scenario.wm import scenario_ops
from skill_agent.runtime import SkillRegistry, load_config
from tests.unit.skill_agent.scenario_planning import plan_scenario
from tests.unit.wm_store.stores import memory_client
from wm_store import WmClient
from wm_store.ontology import Cls, Ontology
from wm_store.protocol import AddElement

ROOT = Path(__file__).resolve().parents[3]
SCENARIO = ROOT / "configs" / "scenarios" / "kitting-cell" / "scenario.toml"


@pytest.fixture
async def wm() -> AsyncIterator[WmClient]:
    async with memory_client() as client:
        yield client


def test_the_scene_of_a_fixed_robot_has_no_base() -> None:
    scenario = load_scenario(SCENARIO)
    added = {op.label: op.type for op in scenario_ops(scenario) if isinstance(op, AddElement)}
    assert added["c1-arm"] == Cls.Arm and added["c1-gripper"] == Cls.Gripper
    assert "c1-base" not in added
    assert not any(cls == Cls.MobileBase for cls in added.values())


def test_the_fixed_robots_agent_offers_no_navigate() -> None:
    config = load_config(ROOT / "configs" / "agents" / "kitting-cell" / "c1.toml")
    entries = SkillRegistry.from_config(config, Ontology.default()).load()
    config.check_skill_names(entries)
    assert {e.description.name for e in entries.values()} == {"locate", "pick", "place_at"}
    assert {d.type for d in config.devices} == {Cls.Arm, Cls.Gripper, Cls.Camera}


@pytest.mark.anyio
async def test_the_cell_goals_are_planned_without_navigate(wm: WmClient) -> None:
    goals = " and ".join(load_scenario(SCENARIO).goals)
    plan = await plan_scenario(wm, "kitting-cell", ["kitting-cell/c1"], goals)
    skills = [s.skill for s in plan.steps]
    assert skills.count("pick") == 2 and skills.count("place_at") == 2
    assert "navigate" not in skills
    assert {s.agent for s in plan.steps} == {"c1"}
