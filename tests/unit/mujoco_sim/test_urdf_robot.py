"""Robot descriptions from one URDF file: what is derived, and what the errors say."""

from __future__ import annotations

from pathlib import Path

import mujoco
import pytest

from mujoco_sim.models import build_robot, load_robot_file
from mujoco_sim.models.__main__ import main as inspect_main
from scenario import MjcfArm, RobotFileError, RobotSpec, describe_file, robot_layout

pytest.importorskip("cmeel", reason="needs example-robot-data: pip install example-robot-data")

PANDA_HOME = (0.0, -0.85, 0.0, -2.61, 0.0, 1.76, -0.785)
PANDA = MjcfArm(package="example-robot-data:panda", home=PANDA_HOME)


def test_the_panda_chain_gripper_and_fingers_are_derived() -> None:
    robot = describe_file(PANDA)
    assert robot.kind == "urdf" and robot.base_link == "panda_link0"
    assert robot.arm_joints == tuple(f"panda_joint{i}" for i in range(1, 8))
    assert robot.tool_link == "panda_hand"
    assert robot.gripper_joints == ("panda_finger_joint1", "panda_finger_joint2")  # driven first
    assert (robot.left_finger, robot.right_finger) == ("panda_leftfinger", "panda_rightfinger")


def test_the_built_panda_has_servos_a_tool_frame_and_pads() -> None:
    spec = RobotSpec(name="r1", mjcf=PANDA)
    names = robot_layout(spec)
    model = build_robot(spec).compile()
    for joint in names.servo_joints:
        assert model.actuator(joint).id >= 0
    act = model.actuator(names.gripper_actuator).id
    assert list(model.actuator_ctrlrange[act]) == pytest.approx([0.0, 0.04])
    site = model.site(names.tcp_site).id
    assert model.body(model.site_bodyid[site]).name == "r1/panda_hand"
    # between the fingertips: the URDF's own panda_hand_tcp frame is 0.1034 m out
    assert model.site_pos[site] == pytest.approx([0.0, 0.0, 0.1034], abs=1e-3)
    for pads in names.pad_geoms:
        assert model.geom_priority[model.geom(pads[0]).id] == 1
    assert model.neq >= 1  # the <mimic> finger follows the driven one
    data = mujoco.MjData(model)
    mujoco.mj_forward(model, data)


def test_what_cannot_be_derived_names_the_file_and_the_key() -> None:
    with pytest.raises(RobotFileError, match=r"z1\.urdf.*gripper_joints") as info:
        describe_file(MjcfArm(package="example-robot-data:z1"))  # a one-jaw gripper
    assert info.value.key == "gripper_joints"
    z1 = describe_file(MjcfArm(package="example-robot-data:z1", gripper_joints=("jointGripper",)))
    assert z1.tool_link == "gripperStator" and len(z1.arm_joints) == 6
    with pytest.raises(RobotFileError, match="home"):
        build_robot(RobotSpec(mjcf=MjcfArm(package="example-robot-data:panda")))  # 6 values
    with pytest.raises(RobotFileError, match=r"no such robot.*panda"):
        describe_file(MjcfArm(package="example-robot-data:pandaa"))
    with pytest.raises(RobotFileError, match="tool_link"):
        describe_file(MjcfArm(package="example-robot-data:panda", tool_link="nope"))


def test_a_missing_file_is_named(tmp_path: Path) -> None:
    missing = tmp_path / "arm.urdf"
    with pytest.raises(RobotFileError, match="arm_xml") as info:
        describe_file(MjcfArm(arm_xml=str(missing)))
    assert str(missing) in str(info.value)


def test_the_inspect_command_prints_what_was_derived(capsys: pytest.CaptureFixture[str]) -> None:
    toml = Path(__file__).resolve().parents[3] / "configs/scenarios/kitting-panda/scenario.toml"
    assert inspect_main([str(toml)]) == 0
    out = capsys.readouterr().out
    assert "r2/panda_joint7" in out and "r2/panda_hand" in out


def test_one_mjcf_file_gives_the_same_robot(tmp_path: Path) -> None:
    """The Panda written out as one MJCF file (MuJoCo's own conversion of the URDF): the same
    chain, gripper (the <mimic> is a joint equality there) and tool frame are derived."""
    urdf = build_robot(RobotSpec(name="r1", mjcf=PANDA)).compile()
    path = tmp_path / "panda.xml"
    path.write_text(load_robot_file(describe_file(PANDA)).to_xml())
    arm = MjcfArm(arm_xml=str(path), home=PANDA_HOME)
    robot = describe_file(arm)
    assert robot.kind == "mjcf"
    assert robot.arm_joints == describe_file(PANDA).arm_joints
    assert robot.gripper_joints == ("panda_finger_joint1", "panda_finger_joint2")
    model = build_robot(RobotSpec(name="r1", mjcf=arm)).compile()
    tcp = model.site("r1/tcp").id
    assert model.site_pos[tcp] == pytest.approx(urdf.site_pos[urdf.site("r1/tcp").id], abs=1e-6)
