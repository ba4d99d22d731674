"""Shared fixtures of the device-layer tests: the default robot, its model and random joint
configurations (seeded numpy Generators, never the global RNG)."""

from __future__ import annotations

from collections.abc import Callable, Mapping
from typing import Any

import mujoco
import numpy as np
import numpy.typing as npt
import pytest

from mujoco_sim.models import build_robot
from mujoco_sim.physics import set_joint_positions, site_pose
from scenario import RobotLayout, RobotSpec, robot_layout

Sampler = Callable[[np.random.Generator], dict[str, float]]


@pytest.fixture(scope="session")
def spec() -> RobotSpec:
    return RobotSpec(name="r1")


@pytest.fixture(scope="session")
def layout(spec: RobotSpec) -> RobotLayout:
    return robot_layout(spec)


@pytest.fixture(scope="session")
def robot_model(spec: RobotSpec) -> Any:
    """The robot alone, compiled (an ``MjModel``)."""
    return build_robot(spec).compile()


@pytest.fixture(scope="session")
def arm_sampler(robot_model: Any, layout: RobotLayout) -> Sampler:
    """Draws arm configurations uniformly inside the joint limits (base at the origin)."""
    ranges = np.array([robot_model.joint(j).range for j in layout.arm_joints])

    def sample(rng: np.random.Generator) -> dict[str, float]:
        q = dict.fromkeys(layout.base_joints, 0.0)
        q.update(zip(layout.arm_joints, rng.uniform(ranges[:, 0], ranges[:, 1]), strict=True))
        return {k: float(v) for k, v in q.items()}

    return sample


Pose = tuple[npt.NDArray[np.float64], npt.NDArray[np.float64]]
ForwardKinematics = Callable[[Mapping[str, float]], Pose]


@pytest.fixture(scope="session")
def fk(robot_model: Any, layout: RobotLayout) -> ForwardKinematics:
    """MuJoCo forward kinematics of the tcp: (position, rotation matrix) at joint values."""
    data = mujoco.MjData(robot_model)

    def tcp(q: Mapping[str, float]) -> Pose:
        set_joint_positions(robot_model, data, q, hold=False)
        mujoco.mj_kinematics(robot_model, data)
        return site_pose(robot_model, data, layout.tcp_site)

    return tcp
