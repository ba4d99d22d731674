"""RobotSpec is strict config; robot_layout spells every element name."""

from __future__ import annotations

import msgspec
import pytest

from device_drivers import Pose2D
from scenario import ARM_JOINTS_6, ARM_JOINTS_7, UR5E_JOINTS, MjcfArm, RobotSpec, robot_layout


def test_defaults_decode_from_empty_table() -> None:
    assert msgspec.convert({}, RobotSpec) == RobotSpec()
    assert msgspec.convert({"x": 1.0, "yaw": 0.5}, Pose2D) == Pose2D(1.0, 0.0, 0.5)


@pytest.mark.parametrize(
    ("fields", "needle"),
    [
        ({"base_heigth": 0.3}, "unknown field"),
        ({"base_height": -0.3}, "base_height"),
        ({"upper_arm_length": 0.0}, "upper_arm_length"),
        ({"wrist_length": 0.01}, "wrist_length"),
        ({"arm_dof": 5}, "arm_dof"),
        ({"name": "r 1"}, "name"),
        ({"arm_rgba": [1.0, 0.0, 0.0, 2.0]}, "arm_rgba"),
    ],
)
def test_bad_config_is_rejected(fields: dict[str, object], needle: str) -> None:
    with pytest.raises(msgspec.ValidationError, match=needle):
        msgspec.convert(fields, RobotSpec)


def test_layout_names_are_prefixed() -> None:
    names = robot_layout(RobotSpec(name="r1"))
    assert names.prefix == "r1/"
    assert names.base_joints == ("r1/base_x", "r1/base_y", "r1/base_yaw")
    assert names.arm_joints == tuple(f"r1/{j}" for j in ARM_JOINTS_6)
    assert names.tcp_site == "r1/tcp"
    assert names.gripper_actuator == "r1/gripper"
    assert names.servo_joints == names.base_joints + names.arm_joints


def test_layout_seven_dof_and_custom_prefix() -> None:
    names = robot_layout(RobotSpec(name="r2", arm_dof=7), prefix="")
    assert names.arm_joints == ARM_JOINTS_7
    assert names.pad_geoms == (("left_pad",), ("right_pad",))
    assert names.hand_body == "gripper" and names.gripper_tendon == "gripper"


def test_mjcf_layout_names_file_elements_under_the_robot() -> None:
    names = robot_layout(RobotSpec(name="r3", mjcf=MjcfArm()))
    assert names.arm_joints == tuple(f"r3/{j}" for j in UR5E_JOINTS)
    assert names.base_joints == robot_layout(RobotSpec(name="r3")).base_joints
    assert names.tcp_site == "r3/gripper/pinch" and names.hand_body == "r3/gripper/base"
    assert names.pad_geoms[0] == ("r3/gripper/left_pad1", "r3/gripper/left_pad2")
    assert names.gripper_actuator == "r3/gripper/fingers_actuator" and not names.gripper_tendon
    assert msgspec.convert({"mjcf": {}}, RobotSpec).mjcf == MjcfArm()
