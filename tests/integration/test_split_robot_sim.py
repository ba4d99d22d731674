"""The kitting robot r1 run by two agents (``configs/agents/kitting/split/``) in the MuJoCo
simulation (fast mode), each an agent core wired from its config as ``skimesh agent`` wires it:
registered in the scenario's world model, given the world's drivers of its own devices (by
label) and its ``[hardware]`` bindings. The base agent's navigate drives r1 to Station-1, then
the arm agent's pick and place put a gear into r1's kit box, while the base agent drives no arm
(it has no driver for one): the world model and the world's ground truth agree.
"""

from __future__ import annotations

from collections.abc import AsyncIterator
from contextlib import asynccontextmanager
from pathlib import Path

import anyio
import pytest

from mujoco_sim import SimWorld, WorldOptions, running_world, sim_devices
from scenario import load_scenario
from scenario.wm import scenario_ops
from skill_agent.protocol import RunResult, StartRun
from skill_agent.runtime import AgentCore, SkillRegistry, bind_devices, bind_hardware, load_config
from skill_agent.server import agent_registration
from wm_store import InMemoryTransport, WmClient
from wm_store.ontology import Ontology, Rel
from wm_store.protocol import Value
from wm_store.server import WmService, WmStore

pytestmark = [pytest.mark.sim, pytest.mark.anyio]

ROOT = Path(__file__).resolve().parents[2]
SPLIT = ROOT / "configs" / "agents" / "kitting" / "split"
KITTING = ROOT / "configs" / "scenarios" / "kitting" / "scenario.toml"


@asynccontextmanager
async def kitting_world() -> AsyncIterator[tuple[SimWorld, WmClient, dict[str, str]]]:
    """The kitting world and its world model (the scenario's scene); element ids by label."""
    scenario = load_scenario(KITTING)
    ontology = Ontology.default()
    store = await WmStore.open(ontology)
    async with anyio.create_task_group() as tg:
        await tg.start(store.run)
        async with (
            running_world(scenario, WorldOptions(fast=True)) as world,
            WmClient.connect(InMemoryTransport(WmService(store)), ontology) as wm,
        ):
            reply = await wm.transact(scenario_ops(scenario))
            ids = {ref[1:]: eid for ref, eid in reply.ids.items() if ref.startswith("$")}
            yield world, wm, ids
        tg.cancel_scope.cancel()


@asynccontextmanager
async def split_agent(world: SimWorld, wm: WmClient, name: str) -> AsyncIterator[AgentCore]:
    """Agent ``name`` of the split: its config's skills, registration, drivers and bindings."""
    config = load_config(SPLIT / f"{name}.toml")
    entries = SkillRegistry.from_config(config, wm.ontology).load()
    core = AgentCore(name=config.name, wm=wm, skills=entries, preempt_timeout=3.0)
    await wm.register_robot(agent_registration(config, core.descriptions()))
    [agent] = wm.resolve_element(type="Agent", label=config.name)
    core.robot = wm.query_relation(agent.id, "controls")[0].object
    drivers = {driver.name: driver for driver in sim_devices(world).values()}
    core.devices.update(bind_devices(wm, config.device_labels, drivers, robot=core.robot))
    core.hardware.update(bind_hardware(wm, config.hardware, robot=core.robot))
    async with anyio.create_task_group() as tg:
        await tg.start(core.run)
        yield core
        tg.cancel_scope.cancel()


async def run(core: AgentCore, skill: str, **params: str) -> RunResult:
    started = await core.start(StartRun(skill=skill, params=dict[str, Value](params)))
    with anyio.fail_after(60):
        return await core.wait(started.run_id)


async def test_the_base_agent_drives_and_the_arm_agent_picks_and_places() -> None:
    async with (
        kitting_world() as (world, wm, ids),
        split_agent(world, wm, "r1-base") as base,
        split_agent(world, wm, "r1-arm") as arm,
    ):
        assert base.robot == arm.robot == ids["r1"], "both agents run the scene's robot r1"
        labels = {wm.get_element(i).label for i in base.devices}
        assert labels == {"r1-base"}, "the base agent drives the base only"
        assert {wm.get_element(i).label for i in arm.devices} == {
            "r1-arm",
            "r1-gripper",
            "r1-camera",
            "Camera-1",
        }
        driven = await run(base, "navigate", goal=ids["Station-1"])
        assert driven.success, driven.message
        for skill, params in (
            ("pick", {"object": ids["Gear-1"]}),
            ("place", {"object": ids["Gear-1"], "container": ids["KitBox-1"]}),
        ):
            result = await run(arm, skill, **params)
            assert result.success, f"{skill}: {result.message}"
        assert wm.query_relation(ids["KitBox-1"], Rel.contain, ids["Gear-1"])
        await world.sleep(0.5)  # simulated time: the gear settles in the box
        assert world.object_in("Gear-1", "KitBox-1"), "the ground truth agrees"
