"""The generated robot and world: they compile, carry the documented names, hold still under
gravity, and their bases go where they are told."""

from __future__ import annotations

import math
from collections.abc import Callable, Mapping
from pathlib import Path
from typing import Any

import msgspec
import mujoco
import numpy as np
import numpy.typing as npt
import pytest

from device_drivers import ModelError, Pose2D
from mujoco_sim.models import build_robot, build_world
from mujoco_sim.physics import (
    check_state,
    hold_servos,
    joint_positions,
    set_joint_positions,
    site_pose,
)
from scenario import RobotLayout, RobotSpec, robot_layout

pytestmark = pytest.mark.sim

ASSETS = Path(__file__).parents[2] / "assets"

Pose = tuple[npt.NDArray[np.float64], npt.NDArray[np.float64]]


def _names(model: Any, kind: str, count: int) -> list[str]:
    return [getattr(model, kind)(i).name for i in range(count)]


def test_robot_compiles_with_documented_names(robot_model: Any, layout: RobotLayout) -> None:
    joints = _names(robot_model, "joint", robot_model.njnt)
    assert joints == [*layout.base_joints, *layout.arm_joints, *layout.finger_joints]
    assert _names(robot_model, "actuator", robot_model.nu) == [
        *layout.servo_joints,
        layout.gripper_actuator,
    ]
    sites = set(_names(robot_model, "site", robot_model.nsite))
    assert {layout.tcp_site, layout.base_site, layout.deck_site, *layout.camera_sites} <= sites
    assert set(layout.camera_sites) <= set(_names(robot_model, "camera", robot_model.ncam))
    assert {*layout.pad_geoms[0], *layout.pad_geoms[1]} <= set(
        _names(robot_model, "geom", robot_model.ngeom)
    )
    # one joint per body: placo merges several joints of one body into one
    assert len(set(robot_model.jnt_bodyid)) == robot_model.njnt
    assert all(robot_model.jnt_limited[robot_model.joint(j).id] for j in layout.arm_joints)


def test_seven_dof_arm() -> None:
    spec = RobotSpec(name="seven", arm_dof=7)
    model = build_robot(spec).compile()
    assert "seven/upper_arm_roll" in _names(model, "joint", model.njnt)
    assert model.nu == 3 + 7 + 1


def test_world_of_two_robots(spec: RobotSpec) -> None:
    r2 = msgspec.structs.replace(spec, name="r2", arm_dof=7)
    world = build_world([(spec, Pose2D(1.0, -0.5, 0.3)), (r2, Pose2D(-1.0, 2.0, -2.0))])
    model = world.compile()
    for robot in (spec, r2):
        names = robot_layout(robot)
        assert set(names.servo_joints) <= set(_names(model, "joint", model.njnt))
        assert model.actuator(names.gripper_actuator).id >= 0
    assert model.nu == (3 + 6 + 1) + (3 + 7 + 1)
    bodies = _names(model, "body", model.nbody)[1:]
    assert all(b.startswith(("r1/", "r2/")) for b in bodies)
    # base joints are world coordinates: the reset state is each robot's initial pose
    data = mujoco.MjData(model)
    assert joint_positions(model, data, robot_layout(r2).base_joints) == pytest.approx(
        {"r2/base_x": -1.0, "r2/base_y": 2.0, "r2/base_yaw": -2.0}
    )


def test_world_kinematics_equal_robot_alone(
    spec: RobotSpec,
    layout: RobotLayout,
    fk: Callable[[Mapping[str, float]], Pose],
) -> None:
    """The ref-placed robot in a world and the robot alone agree at equal joint values."""
    model = build_world([(spec, Pose2D(0.7, -1.2, 2.5))]).compile()
    data = mujoco.MjData(model)
    rng = np.random.default_rng(3)
    for _ in range(10):
        q = dict(zip(layout.servo_joints, rng.uniform(-1.5, 1.5, 9), strict=True))
        set_joint_positions(model, data, q)
        mujoco.mj_kinematics(model, data)
        pos, rot = site_pose(model, data, layout.tcp_site)
        ref_pos, ref_rot = fk(q)
        assert np.allclose(pos, ref_pos, atol=1e-12)
        assert np.allclose(rot, ref_rot, atol=1e-12)


def test_duplicate_robot_names_are_refused(spec: RobotSpec) -> None:
    with pytest.raises(ModelError, match=r"unique.*\['r1'\]"):
        build_world([(spec, Pose2D()), (spec, Pose2D(x=2.0))])


def _world(spec: RobotSpec, pose: Pose2D) -> tuple[Any, Any]:
    model = build_world([(spec, pose)]).compile()
    data = mujoco.MjData(model)
    hold_servos(model, data)
    return model, data


ARM_POSES = {  # shoulder_pan, shoulder_lift, elbow, wrist_roll, wrist_pitch, tool_roll (rad)
    "horizontal": (0.0, math.pi / 2, 0.0, 0.0, 0.0, 0.0),  # worst gravity load
    "ready": (0.5, 0.4, 1.5, 0.0, 1.24, 0.0),  # gripper pointing down in front
    "reach_table": (0.3, 1.2, 0.3, 0.2, 0.3, 0.1),
}


@pytest.mark.parametrize("pose", sorted(ARM_POSES))
def test_arm_holds_its_pose_under_gravity(spec: RobotSpec, layout: RobotLayout, pose: str) -> None:
    model, data = _world(spec, Pose2D(0.5, -0.3, 0.4))
    set_joint_positions(model, data, dict(zip(layout.arm_joints, ARM_POSES[pose], strict=True)))
    mujoco.mj_forward(model, data)
    start, _ = site_pose(model, data, layout.tcp_site)
    worst = 0.0
    for _ in range(20):  # 2 s
        mujoco.mj_step(model, data, nstep=50)
        check_state(model, data)
        now, _ = site_pose(model, data, layout.tcp_site)
        worst = max(worst, float(np.linalg.norm(now - start)))
    assert worst < 0.01, f"tcp drifted {worst * 1000:.1f} mm"


def test_base_goes_to_commanded_pose(spec: RobotSpec, layout: RobotLayout) -> None:
    model, data = _world(spec, Pose2D(0.5, -0.3, 0.4))
    goal = {"r1/base_x": 1.5, "r1/base_y": 0.2, "r1/base_yaw": -1.0}
    for name, value in goal.items():
        data.ctrl[model.actuator(name).id] = value
    mujoco.mj_step(model, data, nstep=1500)  # 3 s
    check_state(model, data)
    assert joint_positions(model, data, layout.base_joints) == pytest.approx(goal, abs=2e-3)
    base_pos, base_rot = site_pose(model, data, layout.base_site)
    assert base_pos == pytest.approx([1.5, 0.2, 0.0], abs=2e-3)
    assert math.atan2(base_rot[1, 0], base_rot[0, 0]) == pytest.approx(-1.0, abs=2e-3)


def test_gripper_opens_to_commanded_width(spec: RobotSpec, layout: RobotLayout) -> None:
    model, data = _world(spec, Pose2D())
    data.ctrl[model.actuator(layout.gripper_actuator).id] = 0.06
    mujoco.mj_step(model, data, nstep=500)
    left, right = joint_positions(model, data, layout.finger_joints).values()
    assert left + right == pytest.approx(0.06, abs=1e-3)
    assert left == pytest.approx(right, abs=1e-4)


def test_world_with_scene_extras(spec: RobotSpec) -> None:
    scene = mujoco.MjSpec.from_file(str(ASSETS / "table_with_part.xml"))
    model = build_world([(spec, Pose2D(0.2, 0.0, 0.0))], extras={"scene": scene}).compile()
    data = mujoco.MjData(model)
    hold_servos(model, data)
    mujoco.mj_step(model, data, nstep=250)  # 0.5 s
    check_state(model, data)
    part_z = data.body("scene/part").xpos[2]
    assert part_z == pytest.approx(0.7 + 0.025, abs=2e-3)  # resting on the table top
    with pytest.raises(ModelError, match="repeated"):
        build_world([(spec, Pose2D())], extras={"r1": mujoco.MjSpec()})
