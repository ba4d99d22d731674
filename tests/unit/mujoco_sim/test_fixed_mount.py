"""A fixed robot (``mount = "fixed"``): its layout has no base joints, deck or front camera;
its model is a pedestal body at its pose without joints, the arm's mount ``stand_height`` up;
its IK solvers (built where it stands) solve world targets; its plant has no base device."""

from __future__ import annotations

from collections.abc import Callable

import msgspec
import mujoco
import numpy as np
import pytest

from device_drivers import Pose2D
from mujoco_sim import Plant
from mujoco_sim.control import ArmController
from mujoco_sim.ik import DlsIK, IKSolver, TcpTarget
from mujoco_sim.models import build_robot
from mujoco_sim.placo_ik import PlacoIK
from scenario import RobotSpec, Scenario, ScenarioError, parse_scenario, robot_layout

pytestmark = pytest.mark.sim

SPEC = RobotSpec(name="c1", mount="fixed", stand_height=0.6, arm_mount_x=0.1)
AT = Pose2D(1.0, -0.5, 0.7)
SOLVERS: dict[str, Callable[..., IKSolver]] = {
    "placo": PlacoIK.for_robot,
    "dls": DlsIK.for_robot,
}
CELL = """
name = "cell"
[[robots]]
name = "c1"
type = "Robot"
pose = { x = 1.0, y = -0.5, yaw = 0.7 }
[robots.model]
mount = "fixed"
stand_height = 0.6
arm_mount_x = 0.1
"""


def test_the_layout_has_no_base() -> None:
    layout = robot_layout(SPEC)
    assert layout.base_joints == () and layout.deck_site == ""
    assert layout.camera_sites == ("c1/wrist_camera",)
    assert layout.servo_joints == layout.arm_joints
    assert SPEC.devices == ("arm", "gripper") and SPEC.mount_height == 0.6
    mobile = msgspec.structs.replace(SPEC, mount="mobile")
    assert mobile.devices == ("arm", "gripper", "base")
    assert len(robot_layout(mobile).base_joints) == 3


def test_the_model_is_a_pedestal_at_the_pose() -> None:
    model = build_robot(SPEC, at=AT).compile()
    data = mujoco.MjData(model)
    mujoco.mj_forward(model, data)
    joints = {model.joint(j).name for j in range(model.njnt)}
    assert not any("base" in j for j in joints)
    assert {model.actuator(a).name for a in range(model.nu)} == {
        *robot_layout(SPEC).arm_joints,
        "c1/gripper",
    }
    base = model.body("c1/base")
    assert model.body_jntnum[base.id] == 0 and model.body_parentid[base.id] == 0
    assert data.xpos[base.id] == pytest.approx([1.0, -0.5, 0.0])
    ahead = np.array([np.cos(0.7), np.sin(0.7), 0.0]) * 0.1
    shoulder = data.xpos[model.body("c1/shoulder_link").id]
    assert shoulder == pytest.approx(np.array([1.0, -0.5, 0.6]) + ahead, abs=1e-9)
    pedestal = model.geom("c1/pedestal")
    assert 2 * model.geom_size[pedestal.id][1] == pytest.approx(0.6)


@pytest.mark.parametrize("name", sorted(SOLVERS))
def test_ik_solves_world_targets_where_the_robot_stands(name: str) -> None:
    solver = SOLVERS[name](SPEC, at=AT)
    layout = robot_layout(SPEC)
    ahead = np.array([np.cos(0.7), np.sin(0.7)])
    x, y = np.array([1.0, -0.5]) + 0.45 * ahead  # 0.35 m ahead of the shoulder
    q0 = dict(zip(layout.arm_joints, (0.0, 0.4, 1.5, 0.0, 1.24, 0.0), strict=True))
    result = solver.solve(q0, TcpTarget.pointing_down((x, y, 0.45)))
    model = build_robot(SPEC, at=AT).compile()
    data = mujoco.MjData(model)
    for joint, value in result.joints.items():
        data.qpos[model.jnt_qposadr[model.joint(joint).id]] = value
    mujoco.mj_kinematics(model, data)
    assert data.site(layout.tcp_site).xpos == pytest.approx([x, y, 0.45], abs=1e-3)
    assert set(result.joints) == set(layout.arm_joints)


def test_the_plant_of_a_fixed_robot_has_no_base_device() -> None:
    scenario: Scenario = parse_scenario(CELL)
    plant = Plant(scenario)
    assert set(plant.kinds) == {("c1", "arm"), ("c1", "gripper")}
    arm = plant.controllers[("c1", "arm")]
    assert isinstance(arm, ArmController)
    tcp = arm.state().tcp
    assert np.hypot(tcp.x - 1.0, tcp.y + 0.5) < 0.2, "the arm stands on its pedestal"


KIT = '[[containers]]\ntype = "KitBox"\nlabel = "K"\nparent = "c1"\nsize = [0.2, 0.2, 0.05]\n'
FRONT = '[[sensors]]\nkind = "camera"\nlabel = "c1-camera"\nmount = "c1"\n'  # front_camera


@pytest.mark.parametrize(
    ("text", "message"),
    [
        (CELL.replace('type = "Robot"', ""), "no MobileManipulator"),
        (CELL + KIT, "no deck"),
        (CELL + FRONT, 'has only "wrist_camera"'),
    ],
)
def test_load_checks_of_a_fixed_robot(text: str, message: str) -> None:
    with pytest.raises(ScenarioError, match=message):
        parse_scenario(text)
