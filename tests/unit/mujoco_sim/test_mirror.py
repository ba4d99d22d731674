"""The mirror: a scenario's world posed from reported states, without the physics, and what
the recorder makes of it (the same ``world/<body>`` and ``robots/<robot>/joints`` entities as
a running world's)."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
import rerun.chunk

from device_drivers import ApplianceState, ArmState, BaseState, GripperState, Pose2D, WorldPose
from device_drivers.protocol import (
    ApplianceStateReply,
    ArmStateReply,
    BaseStateReply,
    GripperStateReply,
)
from mujoco_sim.recording import Mirror, Recorder
from scenario import load_scenario

pytestmark = [pytest.mark.sim]

SCENARIOS = Path(__file__).resolve().parents[3] / "configs" / "scenarios"


def body(mirror: Mirror, name: str) -> np.ndarray:
    return np.asarray(mirror.data.xpos[mirror.model.body(name).id]).copy()


def test_states_and_poses_pose_the_world_and_the_recorder_follows_it(tmp_path: Path) -> None:
    mirror = Mirror(load_scenario(SCENARIOS / "kitting" / "scenario.toml"))
    path = tmp_path / "mirror.rrd"
    recorder = Recorder(path=path, rate=10.0, flush_every=0.5, min_flush_wall=0.0)
    mirror.start(recorder)
    assert "Gear-1" in mirror.objects
    shoulder = mirror.model.joint("r1/shoulder_lift")
    lift = int(mirror.model.jnt_qposadr[shoulder.id])

    mirror.apply("r1", "base", BaseStateReply(BaseState(pose=Pose2D(1.5, -0.5, np.pi / 2))))
    tcp = WorldPose(0.0, 0.0, 0.0)
    mirror.apply("r1", "arm", ArmStateReply(ArmState(joints={"shoulder_lift": 0.7}, tcp=tcp)))
    mirror.apply("r1", "gripper", GripperStateReply(GripperState(opening=0.02)))
    mirror.apply("r2", "arm", ArmStateReply(ArmState(joints={"no_such_joint": 1.0}, tcp=tcp)))
    mirror.set_object("Gear-1", WorldPose(0.3, 0.4, 0.9, 0.0, 0.0, 0.7071068, 0.7071068))
    assert float(mirror.data.qpos[lift]) != pytest.approx(0.7)  # taken, not written yet
    mirror.sample(recorder, 1.0)

    assert body(mirror, "r1/base") == pytest.approx([1.5, -0.5, 0.0], abs=1e-9)
    assert float(mirror.data.qpos[lift]) == pytest.approx(0.7)
    assert body(mirror, "Gear-1") == pytest.approx([0.3, 0.4, 0.9])
    w, x, y, z = mirror.data.xquat[mirror.model.body("Gear-1").id]
    assert (x, y) == pytest.approx((0.0, 0.0), abs=1e-6) and z == pytest.approx(w, abs=1e-6)
    assert mirror.openings["r1"] == pytest.approx(0.02)
    mirror.sample(recorder, 0.5)  # never back in time
    assert float(mirror.data.time) == 1.0
    recorder.close()

    moved: dict[str, list[object]] = {}
    plotted: list[object] = []
    for chunk in rerun.chunk.RrdReader(str(path)).stream():
        batch = chunk.to_record_batch()
        name = str(chunk.entity_path)
        if not chunk.is_static and "Transform3D:translation" in batch.schema.names:
            moved.setdefault(name, []).extend(batch.column("Transform3D:translation").to_pylist())
        if name == "/robots/r1/joints" and "Scalars:scalars" in batch.schema.names:
            plotted += batch.column("Scalars:scalars").to_pylist()
    assert np.asarray(moved["/world/Gear-1"][-1]).ravel() == pytest.approx([0.3, 0.4, 0.9])
    assert "/world/r1.base" in moved
    assert np.asarray(plotted[-1]).ravel()[-1] == pytest.approx(0.02)  # the reported opening


def test_an_appliance_state_opens_its_door() -> None:
    mirror = Mirror(load_scenario(SCENARIOS / "meal" / "scenario.toml"))
    (appliance,) = mirror.scenario.appliances
    door = mirror.model.joint(f"{appliance.label}/door")
    mirror.apply(appliance.label, "appliance", ApplianceStateReply(ApplianceState(door_angle=1.2)))
    recorder = Recorder()
    mirror.start(recorder)
    assert float(mirror.data.qpos[mirror.model.jnt_qposadr[door.id]]) == pytest.approx(1.2)
    recorder.close()
