"""The solver-independent IK core: rotation errors and the restart loop (pure numpy)."""

from __future__ import annotations

import math

import numpy as np
import numpy.typing as npt
import pytest

from device_drivers import UnreachableError
from mujoco_sim.ik import (
    IKOptions,
    TcpTarget,
    orientation_error,
    quat_to_matrix,
    rotation_error_vector,
    solve_with_restarts,
)

FloatArray = npt.NDArray[np.float64]


def _rot(axis: tuple[float, float, float], angle: float) -> FloatArray:
    x, y, z = np.asarray(axis) / np.linalg.norm(axis)
    s = math.sin(angle / 2)
    return quat_to_matrix((math.cos(angle / 2), x * s, y * s, z * s))


@pytest.mark.parametrize("angle", [0.0, 1e-7, 0.3, 2.0, math.pi - 1e-9, math.pi])
def test_rotation_error_vector_recovers_axis_angle(angle: float) -> None:
    axis = np.array([1.0, -2.0, 0.5]) / np.linalg.norm([1.0, -2.0, 0.5])
    current = _rot((0.2, 0.3, 0.9), 1.1)
    target = _rot((axis[0], axis[1], axis[2]), angle) @ current
    vec = rotation_error_vector(target, current)
    assert np.linalg.norm(vec) == pytest.approx(angle, abs=1e-6)
    if angle > 1e-3:
        assert abs(float(vec @ axis)) == pytest.approx(angle, abs=1e-6)  # ±axis at 180°


def test_orientation_error_modes() -> None:
    down = _rot((1.0, 0.0, 0.0), math.pi)  # tcp z pointing to world -z
    spun = _rot((0.0, 0.0, 1.0), 1.3) @ down  # same approach, other yaw
    assert orientation_error(TcpTarget.pointing_down((0, 0, 0)), spun) == pytest.approx(0, abs=1e-9)
    full = TcpTarget(position=(0, 0, 0), quat=(0.0, 1.0, 0.0, 0.0))
    assert orientation_error(full, spun) == pytest.approx(1.3)
    assert orientation_error(TcpTarget(position=(0, 0, 0)), spun) == 0.0
    tilted = _rot((0.0, 1.0, 0.0), 0.25) @ down
    assert orientation_error(TcpTarget.pointing_down((0, 0, 0)), tilted) == pytest.approx(0.25)


class _Scripted:
    """A fake problem: from start value s, the error goes s, s/2, ... or stalls at ``floor``."""

    def __init__(self, floor: float) -> None:
        self.floor = floor
        self.q = np.zeros(1)
        self.err = 0.0

    def reset(self, q: FloatArray) -> tuple[float, float]:
        self.q, self.err = q.copy(), float(q[0])
        return self.err, 0.0

    def step(self) -> tuple[float, float]:
        self.err = max(self.err / 2, self.floor if self.q[0] > 0.5 else 0.0)
        return self.err, 0.0

    def current(self) -> FloatArray:
        return self.q


def test_restarts_until_an_attempt_converges() -> None:
    options = IKOptions(max_iterations=50, patience=5)
    result = solve_with_restarts(
        solver="fake",
        names=["j"],
        start=np.array([0.9]),  # stalls at 1 cm
        restarts=[np.array([0.8]), np.array([0.3])],  # the second converges
        problem=_Scripted(floor=0.01),
        options=options,
        whole_body=False,
    )
    assert result.joints == {"j": 0.3}
    assert result.position_error <= options.position_tolerance
    # two stalled attempts end after patience, not after max_iterations
    assert result.iterations < 3 * 20


def test_no_convergence_reports_the_best_attempt() -> None:
    with pytest.raises(UnreachableError, match=r"fake: .*position error 10\.00 mm") as info:
        solve_with_restarts(
            solver="fake",
            names=["j"],
            start=np.array([0.9]),
            restarts=[np.array([0.7])],
            problem=_Scripted(floor=0.01),
            options=IKOptions(patience=3),
            whole_body=True,
        )
    assert info.value.position_error == pytest.approx(0.01)
    assert info.value.whole_body
