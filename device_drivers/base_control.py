"""The mobile base controller (simulation thread): ``go_to`` along a checked path.

The holonomic base's servo set-points (x, y, yaw in the world frame) follow a minimum-jerk
profile along each segment of the path. The path is the straight line when the robot's
footprint (its base rectangle plus a 3 cm margin), swept along it, clears every floor
obstacle of the scenario (solid furniture, floor-standing fixed boxes and appliances);
otherwise the first of a few two-segment detours (via a point beside the line's middle, or a
corner) that clears them; otherwise :class:`CollisionError` naming the obstacle. A target
pose that itself overlaps an obstacle is refused. Other robots are not obstacles here (they
move; the task layer keeps them apart). Done when within 1 cm / 0.02 rad and slow; else
:class:`MotionTimeoutError` 3 s (simulated) after the profile's end.
"""

from __future__ import annotations

import itertools
import math
from collections.abc import Sequence
from typing import Any

import numpy as np

from device_drivers.control import Controller, DeviceKey, Job
from device_drivers.errors import CollisionError, CommandError, DeviceBusyError, MotionTimeoutError
from device_drivers.interfaces import BaseState
from device_drivers.motion_math import (
    PEAK_SPEED,
    footprint_corners,
    minjerk,
    rect_corners,
    rects_overlap,
    wrap,
)
from device_drivers.placement import Footprint
from device_drivers.protocol import GoTo
from device_drivers.robot_spec import Pose2D, RobotSpec, robot_layout

__all__ = ["BaseController", "plan_path"]

_MARGIN = 0.03
_YAW_SPEED = 0.8  # peak yaw rate, rad/s
_SAMPLE = 0.02  # path sampling step for the collision check, m
_SETTLE = 3.0

Waypoint = tuple[float, float, float]


def _blocker(
    a: Waypoint, b: Waypoint, half: tuple[float, float], obstacles: Sequence[Footprint]
) -> str:
    """The first obstacle the footprint hits when moving from ``a`` to ``b``, or ""."""
    n = max(2, math.ceil(math.hypot(b[0] - a[0], b[1] - a[1]) / _SAMPLE) + 1)
    n = max(n, math.ceil(abs(b[2] - a[2]) / 0.05) + 1)
    boxes = [(o.label, footprint_corners(o)) for o in obstacles]
    for s in np.linspace(0.0, 1.0, n):
        x, y, yaw = (a[i] + s * (b[i] - a[i]) for i in range(3))
        robot = rect_corners(x, y, yaw, half[0] + _MARGIN, half[1] + _MARGIN)
        for label, box in boxes:
            if rects_overlap(robot, box):
                return label
    return ""


def plan_path(
    start: Waypoint, goal: Waypoint, half: tuple[float, float], obstacles: Sequence[Footprint]
) -> list[Waypoint]:
    """Waypoints from ``start`` to ``goal`` (yaw unwrapped) that clear ``obstacles``.

    Raises:
        CollisionError: the goal overlaps an obstacle, or no tried path is free.
    """
    hit = _blocker(goal, goal, half, obstacles)
    if hit:
        raise CollisionError(f"the target pose ({goal[0]:.2f}, {goal[1]:.2f}) overlaps {hit}")
    first = _blocker(start, goal, half, obstacles)
    if not first:
        return [start, goal]
    dx, dy = goal[0] - start[0], goal[1] - start[1]
    length = math.hypot(dx, dy) or 1.0
    nx, ny = -dy / length, dx / length
    mx, my = (start[0] + goal[0]) / 2, (start[1] + goal[1]) / 2
    vias = [(mx + k * nx, my + k * ny) for k in (0.6, -0.6, 1.2, -1.2, 1.8, -1.8)]
    vias += [(goal[0], start[1]), (start[0], goal[1])]
    for vx, vy in vias:
        via = (vx, vy, (start[2] + goal[2]) / 2)
        if not _blocker(start, via, half, obstacles) and not _blocker(via, goal, half, obstacles):
            return [start, via, goal]
    raise CollisionError(
        f"the path from ({start[0]:.2f}, {start[1]:.2f}) to ({goal[0]:.2f}, {goal[1]:.2f}) is "
        f"blocked by {first}, and no detour is free"
    )


class BaseController(Controller):
    def __init__(
        self,
        key: DeviceKey,
        label: str,
        model: Any,
        data: Any,
        spec: RobotSpec,
        obstacles: Sequence[Footprint],
    ) -> None:
        super().__init__(key, label)
        self.m, self.d = model, data
        self.joints = robot_layout(spec).base_joints
        self.acts = np.array([model.actuator(j).id for j in self.joints])
        self.qadr = np.array([model.jnt_qposadr[model.joint(j).id] for j in self.joints])
        self.dadr = np.array([model.jnt_dofadr[model.joint(j).id] for j in self.joints])
        self.half = (spec.base_length / 2, spec.base_width / 2)
        self.obstacles = list(obstacles)
        self.owner = ""  # the arm's label while a whole-body motion drives the base
        self.segments: list[tuple[np.ndarray[Any, Any], np.ndarray[Any, Any], float]] = []

    def begin(self, job: Job, t: float) -> None:
        cmd = job.command
        if not isinstance(cmd, GoTo):
            raise CommandError(f"{self.label} (a mobile base) cannot {type(cmd).__name__}")
        if self.owner:
            raise DeviceBusyError(f"{self.label} is driven by {self.owner} (whole-body motion)")
        x, y, yaw = (float(v) for v in self.d.ctrl[self.acts])
        goal = (cmd.target.x, cmd.target.y, yaw + wrap(cmd.target.yaw - yaw))
        path = plan_path((x, y, yaw), goal, self.half, self.obstacles)
        self.segments = []
        for a, b in itertools.pairwise(path):
            pa, pb = np.array(a), np.array(b)
            span = max(
                math.hypot(b[0] - a[0], b[1] - a[1]) / cmd.speed, abs(b[2] - a[2]) / _YAW_SPEED
            )
            self.segments.append((pa, pb, max(0.3, PEAK_SPEED * span)))

    def update(self, job: Job, t: float) -> None:
        elapsed = t - self.started_at
        total = sum(seg[2] for seg in self.segments)
        job.progress = 0.95 * min(elapsed / total, 1.0)
        for a, b, period in self.segments:
            if elapsed <= period:
                self.d.ctrl[self.acts] = a + minjerk(elapsed / period) * (b - a)
                return
            elapsed -= period
        goal = self.segments[-1][1]
        self.d.ctrl[self.acts] = goal
        error = self.d.qpos[self.qadr] - goal
        speed = float(np.abs(self.d.qvel[self.dadr]).max())
        if math.hypot(error[0], error[1]) < 0.01 and abs(error[2]) < 0.02 and speed < 0.02:
            self.done(job)
        elif elapsed > _SETTLE:
            raise MotionTimeoutError(
                f"{self.label} is {math.hypot(error[0], error[1]) * 100:.1f} cm from its goal "
                f"{_SETTLE:g} s after the profile ended (pushed against something?)"
            )

    def hold(self) -> None:
        self.d.ctrl[self.acts] = self.d.qpos[self.qadr]

    def settled(self) -> bool:
        return float(np.abs(self.d.qvel[self.dadr]).max()) < 0.01

    def state(self) -> BaseState:
        x, y, yaw = (float(v) for v in self.d.qpos[self.qadr])
        return BaseState(
            pose=Pose2D(x, y, wrap(yaw)), moving=self.job is not None or bool(self.owner)
        )
