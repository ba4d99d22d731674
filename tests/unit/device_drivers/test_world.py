"""SimWorld: both scenarios build and step, pacing (fast / real time), divergence stops the world
and fails every command, the event loop never blocks while the world runs."""

from __future__ import annotations

import time
from pathlib import Path
from typing import Any

import anyio
import numpy as np
import pytest

from device_drivers.drivers import SimArm, sim_devices
from device_drivers.errors import (
    DeviceUnavailableError,
    SimulationDivergedError,
    UnknownElementError,
)
from device_drivers.protocol import MoveJoints
from device_drivers.scenario_load import load_scenario
from device_drivers.world import SimWorld, WorldOptions, running_world

pytestmark = [pytest.mark.sim, pytest.mark.anyio]

SCENARIOS = Path(__file__).resolve().parents[3] / "configs" / "scenarios"
FAST = WorldOptions(fast=True)


@pytest.mark.parametrize("name", ["kitting", "meal"])
async def test_scenario_builds_and_steps_without_divergence(name: str) -> None:
    scenario = load_scenario(SCENARIOS / name / "scenario.toml")
    async with running_world(scenario, FAST) as world:
        await world.wait_time(2.0)
        assert world.failure is None
        assert world.snapshot.time >= 2.0
        for part in scenario.parts:  # nothing fell out of its box at start
            placed = world.body_pose(part.label)
            assert placed.z > 0.3
        # every device of the scenario has a driver, every robot an arm, gripper and base
        keys = set(world.devices)
        for robot in scenario.robots:
            assert {(robot.name, d) for d in ("arm", "gripper", "base")} <= keys
        assert len(sim_devices(world)) == len(keys)


async def test_grippers_start_open_and_robots_at_their_pose() -> None:
    scenario = load_scenario(SCENARIOS / "kitting" / "scenario.toml")
    async with running_world(scenario, FAST) as world:
        devices = sim_devices(world, "r2")
        gripper, base = devices[("r2", "gripper")], devices[("r2", "base")]
        assert (await gripper.state()).opening == pytest.approx(0.085, abs=2e-3)  # type: ignore[attr-defined]
        pose = (await base.state()).pose  # type: ignore[attr-defined]
        assert (pose.x, pose.y) == pytest.approx((-0.6, 1.0), abs=1e-3)


async def test_real_time_pacing_keeps_to_the_wall_clock() -> None:
    scenario = load_scenario(SCENARIOS / "meal" / "scenario.toml")
    async with running_world(scenario, WorldOptions()) as world:
        start_wall, start_sim = time.perf_counter(), world.snapshot.time
        await anyio.sleep(0.6)
        factor = (world.snapshot.time - start_sim) / (time.perf_counter() - start_wall)
        assert 0.7 < factor < 1.15
        assert world.statistics().slips == 0


async def test_fast_mode_runs_faster_than_real_time() -> None:
    scenario = load_scenario(SCENARIOS / "meal" / "scenario.toml")
    async with running_world(scenario, FAST) as world:
        await world.wait_time(3.0)
        stats = world.statistics()
    assert stats.real_time_factor > 1.5  # ~30 on an idle 2-core machine; others may be busy
    assert stats.batches > 0 and stats.ticks >= 300


async def test_event_loop_never_blocks_while_the_world_runs(blocking_detector: Any) -> None:
    scenario = load_scenario(SCENARIOS / "kitting" / "scenario.toml")
    async with running_world(scenario, FAST) as world:
        arm = sim_devices(world, "r1")[("r1", "arm")]
        assert isinstance(arm, SimArm)
        await arm.move_joints({"shoulder_lift": 0.5, "elbow": 1.2})
        await world.wait_time(world.snapshot.time + 1.0)
    assert blocking_detector.reports == []


async def test_divergence_stops_the_world_and_fails_commands() -> None:
    scenario = load_scenario(SCENARIOS / "kitting" / "scenario.toml")
    async with running_world(scenario, FAST) as world:
        arm = sim_devices(world, "r1")[("r1", "arm")]
        assert isinstance(arm, SimArm)

        def explode(model: Any, data: Any) -> None:
            data.qvel[model.joint("r1/elbow").dofadr[0]] = np.nan

        async with anyio.create_task_group() as tg:
            outcome: list[BaseException] = []

            async def move() -> None:
                try:
                    await arm.move_joints({"elbow": 1.0}, duration=5.0)
                except SimulationDivergedError as exc:
                    outcome.append(exc)

            tg.start_soon(move)
            await world.wait_time(world.snapshot.time + 0.2)
            await world.call(explode)
            assert isinstance(await world.wait_stopped(), SimulationDivergedError)
        assert len(outcome) == 1
        assert "r1/elbow" in str(outcome[0])
        with pytest.raises(SimulationDivergedError):
            await arm.move_joints({"elbow": 0.5})
        await arm.stop()  # quiet: nothing moves any more


async def test_commands_after_the_world_stopped_are_refused() -> None:
    scenario = load_scenario(SCENARIOS / "meal" / "scenario.toml")
    async with running_world(scenario, FAST) as world:
        pass
    with pytest.raises(DeviceUnavailableError, match="stopped"):
        await world.execute(("friend", "arm"), MoveJoints({"elbow": 0.1}))


async def test_ground_truth_queries() -> None:
    scenario = load_scenario(SCENARIOS / "kitting" / "scenario.toml")
    world = await SimWorld.create(scenario, FAST)
    assert world.body_pose("Gear-1").z == pytest.approx(0.7205, abs=2e-3)
    assert world.object_in("Gear-1", "PartBox-1")
    assert not world.object_in("Gear-1", "PartBox-2")
    assert world.objects_in("PartBox-4") == ["Bolt-1", "Bolt-2", "Bolt-3"]
    with pytest.raises(UnknownElementError, match="did you mean 'Gear-1'"):
        world.body_pose("Gear1")
    with pytest.raises(DeviceUnavailableError):
        await world.execute(("r9", "arm"), MoveJoints({}))
    async with anyio.create_task_group() as tg:
        await tg.start(world.run)
        await world.wait_time(0.5)
        contacts = await world.contacts()
        tg.cancel_scope.cancel()
    assert isinstance(contacts, list)
