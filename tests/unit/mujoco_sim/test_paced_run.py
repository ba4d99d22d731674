"""Real time with a paced run (``mujoco_sim._paced_run``, ``WorldOptions.handover`` > 0):
while something moves, the simulation thread keeps the wall clock by itself, a thread call
runs many ticks, a busy event loop does not hold the physics back, and commands, progress,
alarms, calls and stops still come through at tick boundaries."""

from __future__ import annotations

import contextlib
import time
from functools import partial
from pathlib import Path

import anyio
import pytest

from device_drivers import DeviceUnavailableError, MotionStoppedError
from mujoco_sim import SimAppliance, SimArm, SimWorld, WorldOptions, running_world, sim_devices
from scenario import load_scenario

pytestmark = [pytest.mark.sim, pytest.mark.anyio]

MEAL = Path(__file__).resolve().parents[3] / "configs" / "scenarios" / "meal" / "scenario.toml"
PACED = WorldOptions(handover=1.0)


def friend_arm(world: SimWorld) -> SimArm:
    arm = sim_devices(world, "friend")[("friend", "arm")]
    assert isinstance(arm, SimArm)
    return arm


async def test_a_moving_world_hands_many_ticks_over_per_thread_call() -> None:
    async with running_world(load_scenario(MEAL), PACED) as world:
        arm = friend_arm(world)
        await anyio.sleep(0.1)
        before = world.statistics()
        seen: list[float] = []
        await arm.move_joints({"elbow": 1.2}, duration=0.8, progress=seen.append)
        after = world.statistics()
    ticks = after.ticks - before.ticks
    assert ticks >= 80  # the motion's 0.8 s, ticked one by one while it moves
    assert after.handovers - before.handovers <= ticks / 4  # one hand-off per tick without
    assert after.slips == 0
    assert len(seen) >= 5 and seen == sorted(seen) and seen[-1] == 1.0


async def test_the_physics_keeps_the_clock_while_the_event_loop_is_blocked() -> None:
    """A loop busy for 0.3 s (a fleet's device server, a long callback) does not stop the
    clock: the ticks due meanwhile run in the simulation thread, and nothing slips."""
    async with running_world(load_scenario(MEAL), PACED) as world:
        arm = friend_arm(world)
        async with anyio.create_task_group() as tg:
            tg.start_soon(partial(arm.move_joints, {"elbow": 1.2}, duration=1.5))
            await world.sleep(0.2)  # moving: a paced run is under way
            ticks = world.plant.ticks_run  # read across threads: a plain int
            time.sleep(0.3)  # noqa: ASYNC251 (blocks the loop on purpose)
            ran = world.plant.ticks_run - ticks
        assert world.statistics().slips == 0
    assert ran >= 15  # ~30 ticks were due; a loaded machine may run fewer before waking


async def test_a_command_given_during_a_paced_run_starts_within_a_batch() -> None:
    async with running_world(load_scenario(MEAL), PACED) as world:
        arm = friend_arm(world)
        oven = world.plant.controllers[("Microwave-1", "appliance")]
        async with anyio.create_task_group() as tg:
            tg.start_soon(partial(arm.move_joints, {"elbow": 1.2}, duration=1.0))
            await world.sleep(0.3)
            issued = world.snapshot.time
            door = sim_devices(world, "Microwave-1")[("Microwave-1", "appliance")]
            assert isinstance(door, SimAppliance)
            await door.set_door(True)
            started = oven.started_at
        assert 0.0 <= started - issued <= PACED.batch + 1e-9


async def _until_stopped(arm: SimArm) -> None:
    with contextlib.suppress(MotionStoppedError, DeviceUnavailableError):
        await arm.move_joints({"elbow": 1.2}, duration=2.0)


async def test_alarms_calls_and_stops_come_through_a_paced_run() -> None:
    async with running_world(load_scenario(MEAL), PACED) as world:
        arm = friend_arm(world)
        async with anyio.create_task_group() as tg:
            tg.start_soon(_until_stopped, arm)
            start = world.snapshot.time
            await world.sleep(0.25)
            assert 0.25 - 1e-9 <= world.snapshot.time - start <= 0.25 + PACED.batch
            wall = time.perf_counter()
            now = await world.call(lambda _model, data: float(data.time))
            assert now >= start + 0.25 and time.perf_counter() - wall < 0.5
            await arm.stop()  # halts before the motion's end
            assert world.snapshot.time - start < 1.5
            assert not world.plant.controllers[("friend", "arm")].active


async def test_stopping_the_world_ends_a_paced_run_at_the_next_batch() -> None:
    async with anyio.create_task_group() as tg:
        long = WorldOptions(handover=5.0)  # a run that would last 5 s unless stopped
        async with running_world(load_scenario(MEAL), long) as world:
            tg.start_soon(_until_stopped, friend_arm(world))
            await world.sleep(0.2)  # moving: a paced run is under way
            wall = time.perf_counter()
        stopped = time.perf_counter() - wall
    assert stopped < 1.0  # at the next batch boundary, not at the end of the run
    assert isinstance(world.failure, DeviceUnavailableError)  # "the simulation was stopped"
