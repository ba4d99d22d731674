"""SimWorld: both scenarios build and step, pacing (fast / real time), divergence stops the world
and fails every command, the event loop never blocks while the world runs."""

from __future__ import annotations

import time
from collections import deque
from pathlib import Path
from typing import Any

import anyio
import numpy as np
import pytest

from device_drivers import (
    DeviceUnavailableError,
    Pose2D,
    SimulationDivergedError,
    UnknownElementError,
)
from device_drivers.protocol import MoveJoints
from mujoco_sim import Plant, SimArm, SimWorld, WorldOptions, running_world, sim_devices
from scenario import load_scenario

pytestmark = [pytest.mark.sim, pytest.mark.anyio]

SCENARIOS = Path(__file__).resolve().parents[3] / "configs" / "scenarios"
FAST = WorldOptions(fast=True)


@pytest.mark.parametrize("name", ["kitting", "meal", "workshop"])
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


async def test_a_quiet_world_in_real_time_runs_a_batch_at_a_time_and_wakes_for_news() -> None:
    """Real time with nothing moving by command: batches of 50 ms (5 ticks), not one thread
    hand-over per 10 ms tick; a command wakes it and starts within a batch of the clock."""
    scenario = load_scenario(SCENARIOS / "meal" / "scenario.toml")
    async with running_world(scenario, WorldOptions()) as world:
        await anyio.sleep(0.1)
        before = world.statistics()
        await anyio.sleep(0.5)
        quiet = world.statistics()
        arm = sim_devices(world, "friend")[("friend", "arm")]
        assert isinstance(arm, SimArm)
        issued = world.snapshot.time
        await arm.move_joints({"elbow": 1.2}, duration=0.3)
        started = world.plant.controllers[("friend", "arm")].started_at
    ticks, batches = quiet.ticks - before.ticks, quiet.batches - before.batches
    assert ticks >= 30 and ticks / batches >= 3  # a tick per batch before
    assert 0.0 <= started - issued <= WorldOptions().batch + 1e-9


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


async def _scripted(options: WorldOptions) -> tuple[list[tuple[str, float]], list[Any], Any]:
    """Two robots and a sensor driven by local drivers, each command issued as soon as the
    one before it is over: (command start times), (detections), final joint positions."""
    scenario = load_scenario(SCENARIOS / "kitting" / "scenario.toml")
    starts: list[tuple[str, float]] = []
    seen: list[Any] = []
    async with running_world(scenario, options) as world:
        devices = sim_devices(world)
        arm1, hand1 = devices[("r1", "arm")], devices[("r1", "gripper")]
        base2, camera = devices[("r2", "base")], devices[("Camera-1", "sensor")]
        assert isinstance(arm1, SimArm)

        def started(key: tuple[str, str]) -> None:
            """Note when the command that just ended started; then keep the loop busy for a
            while (the world runs on meanwhile), as a loaded loop would before reacting."""
            starts.append((f"{key[0]}/{key[1]}", world.plant.controllers[key].started_at))
            time.sleep(0.004)

        async def r1() -> None:
            await arm1.move_joints({"shoulder_lift": 0.4, "elbow": 1.2}, duration=0.55)
            started(("r1", "arm"))
            await hand1.close()  # type: ignore[attr-defined]
            started(("r1", "gripper"))
            seen.append(await camera.detect())  # type: ignore[attr-defined]
            await arm1.move_joints({"elbow": 1.5}, duration=0.33)
            started(("r1", "arm"))
            await hand1.open()  # type: ignore[attr-defined]
            started(("r1", "gripper"))

        async def r2() -> None:
            await base2.go_to(Pose2D(-0.4, 1.0, 0.2))  # type: ignore[attr-defined]
            started(("r2", "base"))
            seen.append(await camera.detect())  # type: ignore[attr-defined]
            await world.wait_time(2.345)  # an alarm, in the middle of a batch
            started(("r2", "base"))  # a slow reaction to it (notes the go_to's start again)
            await base2.go_to(Pose2D(-0.6, 1.0, 0.0))  # type: ignore[attr-defined]
            started(("r2", "base"))

        async with anyio.create_task_group() as tg:
            tg.start_soon(r1)
            tg.start_soon(r2)
        handovers = world.statistics().handovers
        assert world.snapshot.time < 8.0
        await world.wait_time(8.0)
        final = await world.call(lambda _model, data: (float(data.time), data.qpos.copy()))
    return sorted(starts), [seen, handovers], final


async def test_fast_runs_keep_the_batch_semantics() -> None:
    """Handing finished jobs over during a run of batches changes nothing in simulated time:
    the same commands start at the same ticks as with a hand-over after every batch, and the
    world ends in the same state; it only saves hand-overs."""
    runs, lockstep = (
        await _scripted(FAST),
        await _scripted(WorldOptions(fast=True, fast_handover=0)),
    )
    assert runs[0] == lockstep[0] and len(runs[0]) == 7
    assert runs[1][0] == lockstep[1][0]  # the same detections, noise included
    assert runs[2][0] == lockstep[2][0]  # the same tick: 8 s, a batch boundary
    np.testing.assert_array_equal(runs[2][1], lockstep[2][1])
    assert runs[1][1] < lockstep[1][1] / 2  # far fewer hand-overs


async def test_an_alarm_due_at_the_end_of_a_batch_rides_on_its_report() -> None:
    """An alarm first due at the last tick of a batch is rung by the batch's own report: one
    snapshot handed over for that tick, not two; the woken task sees that tick and the
    command it sends starts at the next batch boundary, that very tick."""
    scenario = load_scenario(SCENARIOS / "meal" / "scenario.toml")
    world = await SimWorld.create(scenario, FAST)
    posted: list[float] = []
    report = world._fast.report

    def counting(finished: list[Any], snapshot: Any) -> None:
        posted.append(snapshot.time)
        report(finished, snapshot)

    world._fast.report = counting  # type: ignore[method-assign]
    arm = sim_devices(world, "friend")[("friend", "arm")]
    assert isinstance(arm, SimArm)
    async with anyio.create_task_group() as tg:
        await tg.start(world.run)
        await world.wait_time(1.0 - 1e-6)  # batches of 10 ticks from 0: tick 100 ends one
        woken = world.snapshot.time
        await arm.move_joints({"elbow": 1.2}, duration=0.2)
        started = world.plant.controllers[("friend", "arm")].started_at
        tg.cancel_scope.cancel()
    assert abs(woken - 1.0) < 1e-9 and started == woken
    assert [t for t in posted if abs(t - 1.0) < 1e-9] == [woken]


async def test_quiet_batch_ends_are_published_without_waking_the_loop() -> None:
    """In a fast run only events (a finished job, a due alarm) are posted to the loop and
    waited for; a batch end at which nothing happened is published by reference: the loop is
    not woken, yet every reader sees the newest snapshot."""
    scenario = load_scenario(SCENARIOS / "meal" / "scenario.toml")
    world = await SimWorld.create(scenario, FAST)
    delivered: list[float] = []
    deliver = world._fast.deliver

    def counting(finished: list[Any], snapshot: Any, ack: Any) -> None:
        delivered.append(snapshot.time)
        deliver(finished, snapshot, ack)

    world._fast.deliver = counting  # type: ignore[method-assign]
    async with anyio.create_task_group() as tg:
        await tg.start(world.run)
        await world.wait_time(2.0 - 1e-6)  # the only event, at the end of the 20th batch
        assert world.snapshot.time == pytest.approx(2.0)
        seen = world.snapshot.time
        while world.snapshot.time < seen + 1.0:  # a reader that polls between checkpoints
            await anyio.lowlevel.checkpoint()
        tg.cancel_scope.cancel()
    assert delivered == [pytest.approx(2.0)]
    assert world.statistics().batches >= 30


async def test_a_call_runs_at_the_next_batch_boundary() -> None:
    """A fast run returns at the next batch boundary when call() waits, not after its wall
    budget (worth up to a second of simulated time here)."""
    scenario = load_scenario(SCENARIOS / "kitting" / "scenario.toml")
    async with running_world(scenario, FAST) as world:
        arm = sim_devices(world, "r1")[("r1", "arm")]
        assert isinstance(arm, SimArm)
        for _ in range(3):
            await arm.move_joints({"elbow": 1.2}, duration=0.43)  # handed over mid-run
            finished = world.snapshot.time
            now = await world.call(lambda _model, data: float(data.time))
            assert 0.0 <= now - finished <= FAST.fast_batch + 1e-9
            await arm.move_joints({"elbow": 1.5}, duration=0.43)


async def test_progress_is_reported_every_batch_in_fast_mode() -> None:
    scenario = load_scenario(SCENARIOS / "meal" / "scenario.toml")
    async with running_world(scenario, FAST) as world:
        arm = sim_devices(world, "friend")[("friend", "arm")]
        assert isinstance(arm, SimArm)
        seen: list[tuple[float, float]] = []
        await arm.move_joints(
            {"elbow": 1.2}, duration=1.0, progress=lambda p: seen.append((p, world.snapshot.time))
        )
    times = [t for _, t in seen[:-1]]
    assert 9 <= len(times) <= 12  # 1 s of motion, batches of 0.1 s
    assert np.allclose(np.diff(times), FAST.fast_batch)
    assert [p for p, _ in seen] == sorted(p for p, _ in seen) and seen[-1][0] == 1.0


@pytest.mark.parametrize("fast_run", [False, True])
def test_a_diverged_state_fails_the_batch_it_happens_in(fast_run: bool) -> None:
    """The state is checked after every batch, also inside a fast run of batches."""
    plant = Plant(load_scenario(SCENARIOS / "kitting" / "scenario.toml"))
    ticks = round(FAST.fast_batch / plant.tick_time)
    plant.run_batch(ticks, [])
    plant.data.qvel[plant.model.joint("r1/elbow").dofadr[0]] = np.nan
    options: dict[str, Any] = {}
    if fast_run:  # batches for up to 10 s of wall time, had nothing been found
        options = {"inbox": deque(), "until": lambda _t: False, "budget": 10.0}
        options["report"] = lambda _jobs, _snapshot: None
    with pytest.raises(SimulationDivergedError, match="r1/elbow"):
        plant.run_batch(ticks, [], **options)
    assert plant.batches_run == 2  # the first batch after the bad state raised
