"""The simulation benchmark's baseline is the run's own physics: replaying what the tap
recorded every control tick (set-points, weld switches and weld poses, gripper force limits)
with bare ``mj_step`` from the same start reproduces the run's state bit for bit, grasp
included. The weld's relative pose, set when a gripper grasps, is part of what is replayed:
without it the replayed box sits differently in the hand, with other contacts and fewer solver
iterations, and the baseline is cheaper than the run's physics while carrying (see
docs/benchmarks.md, section "Simulation", "What made the difference", item 11)."""

from __future__ import annotations

from pathlib import Path
from typing import Any

import anyio
import numpy as np
import pytest

from benchmarks.sim import Tap, Window, WorldTruth, drive, step_through
from mujoco_sim import Plant, SimWorld, WorldOptions, sim_devices
from scenario import load_scenario

pytestmark = [pytest.mark.sim, pytest.mark.anyio]

SCENARIO = Path(__file__).resolve().parents[3] / "configs" / "scenarios" / "meal" / "scenario.toml"


async def test_the_replay_steps_the_runs_physics_bit_for_bit(tmp_path: Path) -> None:
    scenario = load_scenario(SCENARIO)
    tap = Tap(path=tmp_path / "run.rrd", recording_id="replay-test")
    world = await SimWorld.create(scenario, WorldOptions(fast=True), tap)
    try:
        async with anyio.create_task_group() as tg:
            await tg.start(world.run)
            truth = WorldTruth(world, Window(world, tap))
            success = await drive(truth, sim_devices(world), "meal", 1)

            def now(_model: Any, data: Any) -> tuple[int, Any]:
                return tap.count, data.qpos.copy()  # between batches: one consistent moment

            count, qpos = await world.call(now)
            tg.cancel_scope.cancel()
    finally:
        await anyio.to_thread.run_sync(tap.close)
    assert success == {"MealBox-1": True}
    ticks = tap.ticks(0, count)
    assert any(active.any() for _, active, _, _ in ticks), "the run grasped: a weld was on"
    plant = Plant(scenario)
    step_through(plant, ticks)
    np.testing.assert_array_equal(plant.data.qpos, qpos)
