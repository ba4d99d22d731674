"""Robots from one URDF file in the simulation: the kitting scenario's robot ``r2`` built from
``example-robot-data``'s URDFs (``[robots.model.mjcf] package = ...``, offline), its chain, tool
frame, gripper and pads derived from the file. The shipped skills navigate, pick a part from a
part box on a shelf and place it into the robot's kit box; the physics confirms it arrived."""

from __future__ import annotations

from collections.abc import AsyncIterator
from pathlib import Path

import anyio
import msgspec
import pytest

from device_drivers import GripperState
from mujoco_sim import WorldOptions, running_world
from scenario import MjcfArm, load_scenario
from scenario.wm import scenario_ops
from tests.integration.test_skills_sim import KITTING, Sim, run
from wm_store import InMemoryTransport, WmClient
from wm_store.ontology import Ontology, Rel
from wm_store.server import WmService, WmStore

pytest.importorskip("cmeel", reason="needs example-robot-data: pip install example-robot-data")
pytestmark = [pytest.mark.sim, pytest.mark.anyio]

ROOT = Path(__file__).resolve().parents[2]
PANDA_TOML = ROOT / "configs/scenarios/kitting-panda/scenario.toml"


async def _sim(arm: MjcfArm | None) -> AsyncIterator[Sim]:
    scenario = load_scenario(PANDA_TOML)
    if arm is not None:
        robots = [
            msgspec.structs.replace(r, model=msgspec.structs.replace(r.model, mjcf=arm))
            if r.name == "r2"
            else r
            for r in scenario.robots
        ]
        scenario = msgspec.structs.replace(scenario, robots=robots)
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
            yield Sim(world, wm, ids)
        tg.cancel_scope.cancel()


@pytest.fixture
async def panda() -> AsyncIterator[Sim]:
    async for sim in _sim(None):  # the shipped scenario: r2 is a Panda
        yield sim


async def _pick_and_place(sim: Sim, part: str, hand: str) -> None:
    async with sim.agent("r2", *KITTING, sensors=("Camera-1",)) as r2:
        for skill, params in (
            ("navigate", {"goal": sim["Station-2"]}),
            ("pick", {"object": sim[part]}),
        ):
            result = await run(r2, skill, **params)
            assert result.success, f"{skill}: {result.message}"
        state = sim.world.snapshot.states[("r2", "gripper")]
        assert isinstance(state, GripperState)
        assert state.holding == part and state.pads_in_contact == 2
        assert sim.world.body_pose(hand).z - sim.world.body_pose(part).z > 0.05
        result = await run(r2, "place", object=sim[part], container=sim["KitBox-2"])
        assert result.success, f"place: {result.message}"
    assert sim.wm.query_relation(sim["KitBox-2"], Rel.contain, sim[part])
    await sim.world.sleep(0.5)
    assert sim.world.object_in(part, "KitBox-2"), "the ground truth agrees"
    assert part not in sim.world.snapshot.attached


@pytest.mark.slow
async def test_panda_picks_a_bolt_and_places_it_in_its_kit_box(panda: Sim) -> None:
    await _pick_and_place(panda, "Bolt-1", "r2/panda_hand")
