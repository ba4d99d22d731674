"""Planning over a scenario's world model with real agent configs, for the skill-library tests:
load the scenario's scene, register agents as their configs describe them, plan a goal."""

from __future__ import annotations

from pathlib import Path

import msgspec

from scenario import load_scenario
from scenario.wm import scenario_ops
from skill_agent.runtime import AgentConfig, SkillRegistry, load_config
from task_agent import parse_goal
from task_agent.discovery import agents_from_view
from task_agent.planning import Plan, Planner
from wm_store import DeviceSpec, RobotRegistration, SkillSpec, WmClient

ROOT = Path(__file__).resolve().parents[3]
CONFIGS = ROOT / "configs" / "agents"


async def register_agent(wm: WmClient, config: AgentConfig) -> None:
    """Register the agent ``config`` describes, with its skills' descriptions, as it would."""
    entries = SkillRegistry.from_config(config, wm.ontology).load()
    encoder = msgspec.json.Encoder()
    skills = [
        SkillSpec(
            name=e.description.name,
            skill_type=e.description.family,
            description=encoder.encode(e.description).decode(),
        )
        for e in entries.values()
    ]
    await wm.register_robot(
        RobotRegistration(
            agent=config.name,
            agent_type=config.agent_type,
            robot_type=config.robot.type,
            robot_label=config.robot_label,
            devices=[DeviceSpec(type=d.type, label=d.label) for d in config.devices],
            skills=skills,
        )
    )


async def plan_scenario(wm: WmClient, scenario: str, agents: list[str], goal: str) -> Plan:
    """Load ``scenario``'s scene into ``wm``, register ``agents`` (config names such as
    ``meal/friend``) and plan ``goal`` with the real planner."""
    await wm.transact(
        scenario_ops(load_scenario(ROOT / "configs" / "scenarios" / scenario / "scenario.toml"))
    )
    for name in agents:
        await register_agent(wm, load_config(CONFIGS / f"{name}.toml"))
    found = agents_from_view(wm)
    assert all(not a.problems for a in found), [a.problems for a in found]
    return await Planner(timeout=60).plan(found, wm, parse_goal(goal, wm))
