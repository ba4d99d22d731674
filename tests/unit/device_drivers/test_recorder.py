"""The rerun recording: geometry once, body poses at the sampling rate, joint series, command
outcomes; written to a file without a viewer."""

from __future__ import annotations

from collections import Counter
from pathlib import Path

import pytest
import rerun.chunk

from device_drivers.drivers import SimArm, sim_devices
from device_drivers.recorder import Recorder
from device_drivers.scenario_load import load_scenario
from device_drivers.world import WorldOptions, running_world

pytestmark = [pytest.mark.sim, pytest.mark.anyio]

KITTING = (
    Path(__file__).resolve().parents[3] / "configs" / "scenarios" / "kitting" / "scenario.toml"
)


def rows_by_entity(path: Path) -> tuple[Counter[str], set[str]]:
    rows: Counter[str] = Counter()
    static: set[str] = set()
    for chunk in rerun.chunk.RrdReader(path).stream():
        name = str(chunk.entity_path)
        if chunk.is_static:
            static.add(name)
        else:
            rows[name] += chunk.num_rows
    return rows, static


async def test_a_run_is_recorded_to_a_file(tmp_path: Path) -> None:
    path = tmp_path / "sim.rrd"
    recorder = Recorder(path=path, rate=25.0, flush_every=0.5, recording_id="test")
    async with running_world(load_scenario(KITTING), WorldOptions(fast=True), recorder) as world:
        arm = sim_devices(world, "r1")[("r1", "arm")]
        assert isinstance(arm, SimArm)
        await arm.move_joints({"elbow": 1.0}, duration=1.0)
        await world.wait_time(2.0)
    recorder.close()
    recorder.close()  # idempotent
    rows, static = rows_by_entity(path)
    # geometry: static, per body and geom kind
    assert {"/world/Gear-1/cylinder", "/world/Shelf-1/box", "/world/r1.forearm/capsule"} <= static
    assert "/world/Shelf-1" in static  # furniture does not move: its pose is static too
    # poses of moving bodies at ~25 Hz of simulated time (2 s and a bit: ~50 samples);
    # a body that did not move since it was last sent is not sent again
    moving = rows["/world/r1.forearm"]
    assert 25 <= moving <= 60  # the arm moved for ~1.2 s of the ~2 s
    assert 0 < rows["/world/r2.forearm"] < moving  # r2 stood still: sent once
    assert 0 < rows["/world/Gear-1"] < moving  # asleep in its box
    assert "/world/Shelf-1" not in rows
    assert 45 <= rows["/robots/r1/joints"] <= 60  # joint series: every sample
    assert rows["/events/r1"] >= 1  # "r1-arm: MoveJoints done"
    assert recorder.samples == rows["/robots/r1/joints"]
