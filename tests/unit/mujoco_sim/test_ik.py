"""IK: both solvers reach >= 99 % of random reachable targets (arm only), reach far targets by
moving the base (whole body), agree with each other, and fail with typed errors."""

from __future__ import annotations

import math
from collections.abc import Callable, Mapping
from typing import Any

import msgspec
import mujoco
import numpy as np
import numpy.typing as npt
import pytest

from device_drivers import IKError, UnreachableError
from mujoco_sim.ik import DlsIK, IKSolver, TcpTarget, orientation_error
from mujoco_sim.models import build_robot
from mujoco_sim.placo_ik import PlacoIK
from scenario import RobotLayout, RobotSpec

pytestmark = pytest.mark.sim

Pose = tuple[npt.NDArray[np.float64], npt.NDArray[np.float64]]
FK = Callable[[Mapping[str, float]], Pose]
Sampler = Callable[[np.random.Generator], dict[str, float]]
SOLVERS: dict[str, Callable[[RobotSpec], IKSolver]] = {
    "placo": PlacoIK.for_robot,
    "dls": DlsIK.for_robot,
}
READY = (0.0, 0.4, 1.5, 0.0, 1.24, 0.0)  # arm joint values: gripper pointing down in front


@pytest.fixture(scope="module", params=sorted(SOLVERS))
def solver(request: pytest.FixtureRequest, spec: RobotSpec) -> IKSolver:
    return SOLVERS[request.param](spec)


def _quat(rot: npt.NDArray[np.float64]) -> tuple[float, float, float, float]:
    quat = np.zeros(4)
    mujoco.mju_mat2Quat(quat, rot.flatten())
    w, x, y, z = (float(v) for v in quat)
    return (w, x, y, z)


def _check_reached(
    fk: FK, q0: Mapping[str, float], joints: Mapping[str, float], target: TcpTarget
) -> float:
    """Verify a solution with MuJoCo's own forward kinematics; return the position error."""
    pos, rot = fk({**q0, **joints})
    assert orientation_error(target, rot) < 2e-3
    return float(np.linalg.norm(pos - np.asarray(target.position)))


def test_solvers_satisfy_the_protocol(solver: IKSolver) -> None:
    assert isinstance(solver, IKSolver)


def test_arm_only_success_rate(solver: IKSolver, arm_sampler: Sampler, fk: FK) -> None:
    """200 full-pose targets from FK of random configurations, each solved from another random
    configuration: at least 99 % converge, and MuJoCo confirms each solution."""
    rng = np.random.default_rng(2024)
    solved, iterations = 0, []
    for _ in range(200):
        pos, rot = fk(arm_sampler(rng))
        target = TcpTarget(position=(pos[0], pos[1], pos[2]), quat=_quat(rot))
        q0 = arm_sampler(rng)
        try:
            result = solver.solve(q0, target)
        except UnreachableError:
            continue
        assert set(result.joints) == set(solver.arm_joints)
        assert _check_reached(fk, q0, result.joints, target) < 2e-4
        solved += 1
        iterations.append(result.iterations)
    assert solved >= 198, f"{solver.name}: {solved}/200"


def test_pointing_down_targets(solver: IKSolver, arm_sampler: Sampler, fk: FK) -> None:
    """Approach-axis targets (yaw free) at table height in front of the robot."""
    rng = np.random.default_rng(7)
    q0 = dict(arm_sampler(rng), **dict(zip(solver.arm_joints, READY, strict=True)))
    for _ in range(30):
        x, y, z = rng.uniform(0.35, 0.65), rng.uniform(-0.25, 0.25), rng.uniform(0.72, 0.8)
        target = TcpTarget.pointing_down((x, y, z))
        result = solver.solve(q0, target)
        assert _check_reached(fk, q0, result.joints, target) < 2e-4
        assert result.orientation_error < 1e-3


def _far_targets(rng: np.random.Generator, count: int) -> list[TcpTarget]:
    """Pointing-down targets 1.3-3 m from the base: out of the arm's reach (0.82 m)."""
    targets = []
    for _ in range(count):
        angle, dist = rng.uniform(-math.pi, math.pi), rng.uniform(1.3, 3.0)
        z = rng.uniform(0.72, 0.85)
        targets.append(TcpTarget.pointing_down((dist * math.cos(angle), dist * math.sin(angle), z)))
    return targets


def test_whole_body_reaches_far_targets_and_solvers_agree(
    spec: RobotSpec, layout: RobotLayout, fk: FK
) -> None:
    rng = np.random.default_rng(99)
    placo_ik, dls_ik = PlacoIK.for_robot(spec), DlsIK.for_robot(spec)
    for target in _far_targets(rng, 30):
        q0 = dict(zip(layout.base_joints, (0.0, 0.0, rng.uniform(-3, 3)), strict=True))
        q0.update(zip(layout.arm_joints, READY, strict=True))
        reached = []
        for ik in (placo_ik, dls_ik):
            result = ik.solve(q0, target, whole_body=True)
            assert set(result.joints) == set(layout.servo_joints)
            error = _check_reached(fk, q0, result.joints, target)
            assert error < 2e-3
            reached.append(fk({**q0, **result.joints})[0])
        assert float(np.linalg.norm(reached[0] - reached[1])) < 2e-3


def test_arm_only_cannot_reach_far_targets(solver: IKSolver, layout: RobotLayout) -> None:
    q0 = dict(zip(layout.servo_joints, (0.0, 0.0, 0.0, *READY), strict=True))
    for target in _far_targets(np.random.default_rng(5), 3):
        with pytest.raises(UnreachableError, match="whole_body=True") as info:
            solver.solve(q0, target)
        assert info.value.position_error > 0.4
        assert info.value.solver == solver.name
        assert set(info.value.joints) == set(layout.arm_joints)


def test_missing_joint_in_q0_is_an_ik_error(solver: IKSolver, layout: RobotLayout) -> None:
    q0 = dict.fromkeys(layout.arm_joints, 0.0)  # no base joints
    with pytest.raises(IKError, match="base_x"):
        solver.solve(q0, TcpTarget(position=(0.5, 0.0, 0.8)))


@pytest.mark.parametrize("cls", [PlacoIK, DlsIK])
def test_unknown_site_is_an_ik_error(cls: Any, spec: RobotSpec, layout: RobotLayout) -> None:
    with pytest.raises(IKError, match="r1/nope"):
        cls(build_robot(spec), tcp_site="r1/nope", arm_joints=layout.arm_joints)


def test_target_validation() -> None:
    with pytest.raises(ValueError, match="not both"):
        TcpTarget(position=(0, 0, 0), quat=(1, 0, 0, 0), approach=(0, 0, -1))
    with pytest.raises(msgspec.ValidationError, match="non-zero"):
        msgspec.convert({"position": [0, 0, 1], "approach": [0, 0, 0]}, TcpTarget)
    assert TcpTarget.pointing_down((1, 2, 3)).approach == (0.0, 0.0, -1.0)


def test_default_robot_serves_the_kitting_task(
    solver: IKSolver, layout: RobotLayout, robot_model: Any, fk: FK
) -> None:
    """Gripper pointing down: parts on a 0.7 m table in front, and the kit box on the deck."""
    data = mujoco.MjData(robot_model)
    mujoco.mj_kinematics(robot_model, data)
    deck = data.site(layout.deck_site).xpos
    q0 = dict(zip(layout.servo_joints, (0.0, 0.0, 0.0, *READY), strict=True))
    targets = [
        TcpTarget.pointing_down((x, y, 0.725))  # centre of a 5 cm part on the table
        for x in (0.40, 0.55, 0.70)
        for y in (-0.2, 0.0, 0.2)
    ]
    targets.append(TcpTarget.pointing_down((deck[0], deck[1], deck[2] + 0.15)))  # over the kit
    for target in targets:
        result = solver.solve(q0, target)
        assert _check_reached(fk, q0, result.joints, target) < 2e-4
