"""The simulation benchmark's measurements per scenario: the full system beside the bare
``mj_step`` replay of its own set-points, bare stepping at rest, an idle world in real time,
stop-to-halt."""

from __future__ import annotations

import contextlib
import statistics
import time
from collections.abc import Sequence
from pathlib import Path
from typing import Any

import anyio
import mujoco

from benchmarks.common import (
    ROOT,
)
from benchmarks.sim._system import full_system
from device_drivers import Arm, MotionStoppedError
from device_drivers.protocol import Stop
from mujoco_sim import Plant, WorldOptions, running_world, sim_devices
from scenario import Scenario, load_scenario


def replay(scenario: Scenario, ticks: Sequence[Any], timed_from: int = 0) -> tuple[float, float]:
    """Wall and simulated seconds of stepping a fresh copy of the world through
    ``ticks[timed_from:]`` with bare mj_step (see :func:`step_through`)."""
    plant = Plant(scenario)
    wall = step_through(plant, ticks, timed_from)
    return wall, (len(ticks) - timed_from) * plant.tick_time


def step_through(plant: Plant, ticks: Sequence[Any], timed_from: int = 0) -> float:
    """Step ``plant`` through the recorded ``ticks`` (:meth:`~benchmarks.sim._system.Tap.ticks`)
    with bare ``mj_step``; return the wall seconds from tick ``timed_from`` on. From the same
    start this is the run's physics, bit for bit (``tests/unit/benchmarks``)."""
    m, d, n = plant.model, plant.data, plant.steps_per_tick
    start = time.perf_counter()
    for i, (ctrl, active, force, eq) in enumerate(ticks):
        if i == timed_from:
            start = time.perf_counter()
        d.ctrl[:] = ctrl
        d.eq_active[:] = active
        m.actuator_forcerange[:] = force
        m.eq_data[:] = eq
        mujoco.mj_step(m, d, nstep=n)
    return time.perf_counter() - start


def at_rest(scenario: Scenario, seconds: float) -> float:
    """Wall seconds per simulated second of bare stepping with nothing moving."""
    plant = Plant(scenario)
    steps = round(seconds / plant.model.opt.timestep)
    start = time.perf_counter()
    mujoco.mj_step(plant.model, plant.data, nstep=steps)
    return (time.perf_counter() - start) / seconds


async def idle_real_time(scenario: Scenario, seconds: float) -> float:
    """CPU seconds of this process per wall second while the world runs in real time with
    nothing commanded (no recorder, no Zenoh): what an idle simulator costs its host."""
    async with running_world(scenario, WorldOptions()) as world:
        await world.wait_time(world.snapshot.time + 0.3)  # started and settled
        cpu, wall = time.process_time(), time.perf_counter()
        await anyio.sleep(seconds)
        return (time.process_time() - cpu) / (time.perf_counter() - wall)


async def _move_until_stopped(arm: Arm, goal: dict[str, float]) -> None:
    with contextlib.suppress(MotionStoppedError):
        await arm.move_joints(goal, duration=2.0)


async def stop_to_halt(scenario: Scenario, repeats: int) -> list[float]:
    """Simulated seconds from ``stop()`` to the arm standing still (< 0.02 rad/s), stopped
    0.8 s into a 2 s move (near its top speed), to one control tick (10 ms)."""
    found: list[float] = []
    async with running_world(scenario, WorldOptions(fast=True)) as world:
        robot = scenario.robots[0].name
        arm = sim_devices(world, robot)[(robot, "arm")]
        assert isinstance(arm, Arm)
        for i in range(repeats):
            goal = {"shoulder_lift": 0.9, "elbow": 1.4} if i % 2 == 0 else {"shoulder_lift": 0.1}
            async with anyio.create_task_group() as tg:
                tg.start_soon(_move_until_stopped, arm, goal)
                await world.sleep(0.8)
                # the driver's stop() is this command; its result is the settling time
                found.append(await world.execute((robot, "arm"), Stop()))
    return found


async def measure(
    name: str,
    quick: bool,
    repeat: int,
    layouts: Sequence[str],
    workdir: Path,
    period: float = 0.5,
) -> dict[str, Any]:
    """Runs 1 and 2 ``repeat`` times per layout (each fast run right before the replay of its
    own ticks, so that both see about the same machine; the layouts take turns going first);
    per layout the figures are the medians, the overhead ratio the median of the pairs'.
    ``period``: the workload reads every sensor every ``period`` simulated s (0: never)."""
    scenario = load_scenario(ROOT / "configs" / "scenarios" / name / "scenario.toml")
    picks = 1 if quick else 2
    runs: dict[str, list[dict[str, Any]]] = {layout: [] for layout in layouts}
    for i in range(repeat):
        for layout in layouts if i % 2 == 0 else layouts[::-1]:
            rrd = workdir / f"{name}-{layout}-{i}.rrd"
            fast = await full_system(
                scenario, layout=layout, fast=True, picks=picks, rrd=rrd, sensor_period=period
            )
            bare, bare_sim = await anyio.to_thread.run_sync(
                replay, scenario, fast["ticks"], fast["first_tick"]
            )
            sim = fast["sim"]
            runs[layout].append(
                {
                    "sim_s": sim,
                    "full": fast["wall"] / sim,
                    "bare": bare / bare_sim,
                    "cpu": fast["cpu"] / sim,
                    "client_cpu": fast["client_cpu"] / sim,
                    "success": fast["success"],
                    "rrd_bytes": rrd.stat().st_size,
                }
            )
    rest = await anyio.to_thread.run_sync(at_rest, scenario, 5.0 if quick else 20.0)
    real = await full_system(
        scenario,
        layout=layouts[0],
        fast=False,
        picks=picks,
        rrd=workdir / f"{name}-rt.rrd",
        limit=4 if quick else 10,
        sensor_period=period,
    )
    halts = await stop_to_halt(scenario, 3 if quick else 10)
    idle = await idle_real_time(scenario, 2.0 if quick else 5.0)
    every = [r for layout in layouts for r in runs[layout]]
    success = {p: all(r["success"][p] for r in every) for p in every[0]["success"]}
    return {
        "layouts": {layout: _summary(found) for layout, found in runs.items()},
        "rest_wall_per_sim_s": rest,
        "idle_real_time_cpu": idle,
        "success": success,
        "real_time_layout": layouts[0],
        "real_time_factor": real["sim"] / real["wall"],
        "real_time_slips": real["slips"],
        "stop_to_halt_s": halts,
        "rrd_bytes": every[0]["rrd_bytes"],
    }


def _summary(runs: list[dict[str, Any]]) -> dict[str, Any]:
    def median(key: str) -> float:
        return float(statistics.median(r[key] for r in runs))

    return {
        "sim_s": median("sim_s"),
        "full_wall_per_sim_s": median("full"),
        "bare_wall_per_sim_s": median("bare"),
        "cpu_per_sim_s": median("cpu"),
        "client_cpu_per_sim_s": median("client_cpu"),
        "overhead": statistics.median(r["full"] / r["bare"] for r in runs),
        "overheads": [r["full"] / r["bare"] for r in runs],
        "runs": runs,
    }
