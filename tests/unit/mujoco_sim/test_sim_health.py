"""check_state turns a diverged simulation into SimulationDivergedError naming time and joint."""

from __future__ import annotations

from typing import Any

import mujoco
import pytest

from device_drivers import Pose2D, SimulationDivergedError
from mujoco_sim.models import build_world
from mujoco_sim.physics import check_state, hold_servos
from scenario import RobotSpec

pytestmark = pytest.mark.sim


@pytest.fixture
def world(spec: RobotSpec) -> tuple[Any, Any]:
    model = build_world([(spec, Pose2D(1.0, 0.0, 0.0))]).compile()
    data = mujoco.MjData(model)
    hold_servos(model, data)
    mujoco.mj_step(model, data, nstep=10)
    return model, data


def test_healthy_state_passes(world: tuple[Any, Any]) -> None:
    check_state(*world)


def test_nan_in_qpos_names_the_joint(world: tuple[Any, Any]) -> None:
    model, data = world
    data.qpos[model.joint("r1/elbow").qposadr[0]] = float("nan")
    with pytest.raises(SimulationDivergedError, match=r"t=0\.0200 s.*qpos.*'r1/elbow'") as info:
        check_state(model, data)
    assert info.value.culprit == "r1/elbow"
    assert info.value.field == "qpos"
    assert info.value.time == pytest.approx(0.02)


def test_state_mujoco_reset_is_still_reported(world: tuple[Any, Any]) -> None:
    """MuJoCo resets a NaN state inside mj_step; its warning counter still tells."""
    model, data = world
    data.qvel[model.joint("r1/wrist_pitch").dofadr[0]] = float("inf")
    mujoco.mj_step(model, data)  # prints MuJoCo's own warning and resets the state
    with pytest.raises(SimulationDivergedError, match="reset the state") as info:
        check_state(model, data)
    assert info.value.culprit == "r1/wrist_pitch"
    assert info.value.field == "qvel"


def test_huge_acceleration(world: tuple[Any, Any]) -> None:
    model, data = world
    data.qacc[model.joint("r1/base_y").dofadr[0]] = 5e7
    with pytest.raises(SimulationDivergedError, match=r"acceleration 5e\+07") as info:
        check_state(model, data)
    assert info.value.culprit == "r1/base_y"
    check_state(model, data, max_acceleration=1e8)


def test_nan_control_names_the_actuator(world: tuple[Any, Any]) -> None:
    model, data = world
    data.ctrl[model.actuator("r1/gripper").id] = float("nan")
    with pytest.raises(SimulationDivergedError, match=r"ctrl.*'r1/gripper'"):
        check_state(model, data)


def test_finite_values_whose_sums_overflow_pass(world: tuple[Any, Any]) -> None:
    """The quick test after each batch sums the state; an overflowing sum of finite values
    sends it to the exact scans, which find nothing wrong."""
    model, data = world
    data.ctrl[:2] = 1e308  # finite, but the sum is inf
    check_state(model, data)


def test_negative_infinity_in_qvel_is_found(world: tuple[Any, Any]) -> None:
    model, data = world
    data.qvel[model.joint("r1/shoulder_pan").dofadr[0]] = -float("inf")
    with pytest.raises(SimulationDivergedError, match=r"qvel.*'r1/shoulder_pan'"):
        check_state(model, data)
