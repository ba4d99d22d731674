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

``SetVelocity`` drives at a twist given in the base frame instead: each tick the commanded
twist ramps towards the requested one (clamped to the robot's ``base_max_speed`` and
``base_max_yaw_rate``, at ``base_max_acceleration``) and the set-points advance by it. A tick
whose set-point footprint would newly overlap an obstacle (same footprints and margin as the
paths) halts the base with :class:`CollisionError`. After ``duration`` the twist ramps down
and the job ends once the base is still (:class:`MotionTimeoutError` if it is not within 3 s);
without a duration a ``Stop`` ends it normally. A new ``SetVelocity`` replaces a running one
(which ends normally); a ``GoTo`` while one runs, or one while a ``GoTo`` runs, is refused
(:class:`DeviceBusyError`). States report the measured velocity in the base frame.
"""

from __future__ import annotations

import itertools
import math
from collections.abc import Callable, Sequence
from functools import partial
from typing import Any

import numpy as np

from device_drivers import (
    BaseState,
    CollisionError,
    CommandError,
    DeviceBusyError,
    DeviceKey,
    MotionTimeoutError,
    Pose2D,
    Twist2D,
)
from device_drivers.protocol import GoTo, SetVelocity
from mujoco_sim.control._job import Controller, Job
from mujoco_sim.motion._math import (
    PEAK_SPEED,
    footprint_corners,
    minjerk,
    rect_corners,
    rects_overlap,
    wrap,
)
from scenario import Footprint, RobotSpec, robot_layout

__all__ = ["BaseController", "plan_path"]

_MARGIN = 0.03
_YAW_SPEED = 0.8  # peak yaw rate, rad/s
_SAMPLE = 0.02  # path sampling step for the collision check, m
_SETTLE = 3.0

Waypoint = tuple[float, float, float]


def _blocker(
    a: Waypoint, b: Waypoint, half: tuple[float, float], obstacles: Sequence[Footprint]
) -> str:
    """The first obstacle the footprint hits when moving from ``a`` to ``b``, or "". Only the
    obstacles within reach of the line from ``a`` to ``b`` (their centre closer to it than
    their half diagonal plus the robot's, with its margin) are checked, sample by sample: the
    cost follows the obstacles near the path, not the size of the site."""
    reach = math.hypot(*half) + _MARGIN
    (ax, ay), (dx, dy) = a[:2], (b[0] - a[0], b[1] - a[1])
    length2 = dx * dx + dy * dy
    near: list[tuple[str, np.ndarray[Any, Any], float, float, float]] = []
    for o in obstacles:
        s = ((o.x - ax) * dx + (o.y - ay) * dy) / length2 if length2 > 0 else 0.0
        s = min(1.0, max(0.0, s))
        within = reach + math.hypot(o.hx, o.hy)
        if math.hypot(o.x - ax - s * dx, o.y - ay - s * dy) <= within:
            near.append((o.label, footprint_corners(o), o.x, o.y, within))
    if not near:
        return ""
    n = max(2, math.ceil(math.hypot(dx, dy) / _SAMPLE) + 1)
    n = max(n, math.ceil(abs(b[2] - a[2]) / 0.05) + 1)
    for s in np.linspace(0.0, 1.0, n):
        x, y, yaw = (a[i] + s * (b[i] - a[i]) for i in range(3))
        robot = None
        for label, box, ox, oy, within in near:
            if math.hypot(ox - x, oy - y) > within:
                continue
            if robot is None:
                robot = rect_corners(x, y, yaw, half[0] + _MARGIN, half[1] + _MARGIN)
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
    halt_timeout = 1.5  # braking from 1 m/s and swinging back to the hold point takes ~1 s

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
        self.max_speed, self.max_yaw_rate = spec.base_max_speed, spec.base_max_yaw_rate
        self.max_accel = spec.base_max_acceleration
        self.twist = np.zeros(3)  # the commanded twist of a velocity job (base frame)
        self.last = 0.0  # simulation time of the velocity job's last tick
        reach = math.hypot(*self.half) + _MARGIN
        self.boxes = [
            (o.label, footprint_corners(o), o.x, o.y, reach + math.hypot(o.hx, o.hy))
            for o in self.obstacles
        ]

    def start(self, job: Job, t: float) -> None:
        running = self.job
        if (
            isinstance(job.command, SetVelocity)
            and running is not None
            and isinstance(running.command, SetVelocity)
        ):
            try:
                _check_twist(job.command)
            except CommandError as exc:  # a bad twist leaves the running one alone
                self.done(job, error=exc)
                return
            self.done(running)  # replaced: the earlier call returns; the ramp goes on
            self.job = None
        super().start(job, t)

    def begin(self, job: Job, t: float) -> None:
        cmd = job.command
        if not isinstance(cmd, GoTo | SetVelocity):
            raise CommandError(f"{self.label} (a mobile base) cannot {type(cmd).__name__}")
        if self.owner:
            raise DeviceBusyError(f"{self.label} is driven by {self.owner} (whole-body motion)")
        if isinstance(cmd, SetVelocity):
            _check_twist(cmd)
            self.last = t
            return
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
        if isinstance(job.command, SetVelocity):
            self._drive(job, job.command, t)
            return
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

    def _drive(self, job: Job, cmd: SetVelocity, t: float) -> None:
        """One tick of a velocity job (see the module doc)."""
        dt, self.last = t - self.last, t
        elapsed = t - self.started_at
        over = cmd.duration is not None and elapsed >= cmd.duration
        target = np.zeros(3) if over else self._clamped(cmd)
        step = self.max_accel * dt
        self.twist = _ramp(self.twist, target, step, step * self.max_yaw_rate / self.max_speed)
        if dt > 0 and self.twist.any():
            now = self.d.ctrl[self.acts].copy()
            c, s = math.cos(now[2]), math.sin(now[2])
            vx, vy, wz = self.twist
            new = now + dt * np.array([c * vx - s * vy, s * vx + c * vy, wz])
            hit = self._hits(new) - self._hits(now)
            if hit:
                raise CollisionError(
                    f"{self.label}: driving at ({vx:.2f} m/s, {vy:.2f} m/s, {wz:.2f} rad/s) "
                    f"would hit {', '.join(sorted(hit))}; halted"
                )
            self.d.ctrl[self.acts] = new
        if cmd.duration is None:
            return
        job.progress = 0.95 * min(elapsed / cmd.duration, 1.0)
        if over and not self.twist.any():
            if self.settled():
                self.done(job)
            elif elapsed > cmd.duration + _SETTLE:
                raise MotionTimeoutError(
                    f"{self.label} still moves {_SETTLE:g} s after its velocity command ended "
                    "(pushed by something?)"
                )

    def _clamped(self, cmd: SetVelocity) -> np.ndarray[Any, Any]:
        """The requested twist within the base's speed and yaw-rate limits (the direction of
        travel kept)."""
        speed = math.hypot(cmd.vx, cmd.vy)
        scale = min(1.0, self.max_speed / speed) if speed > 0 else 1.0
        wz = min(max(cmd.wz, -self.max_yaw_rate), self.max_yaw_rate)
        return np.array([cmd.vx * scale, cmd.vy * scale, wz])

    def _hits(self, pose: np.ndarray[Any, Any]) -> set[str]:
        """Obstacles the footprint (with the margin) overlaps at set-points ``pose``."""
        x, y, yaw = (float(v) for v in pose)
        robot = None
        found = set()
        for label, box, ox, oy, near in self.boxes:
            if math.hypot(ox - x, oy - y) > near:
                continue
            if robot is None:
                robot = rect_corners(x, y, yaw, self.half[0] + _MARGIN, self.half[1] + _MARGIN)
            if rects_overlap(robot, box):
                found.add(label)
        return found

    def halt(self, t: float, reason: str) -> None:
        job = self.job
        command = job.command if job is not None else None
        if job is not None and isinstance(command, SetVelocity) and command.duration is None:
            self.hold()
            self.done(job)  # a stop is how an open-ended velocity command ends
            self.job = None
            return
        super().halt(t, reason)

    def hold(self) -> None:
        self.d.ctrl[self.acts] = self.d.qpos[self.qadr]
        self.twist = np.zeros(3)

    def settled(self) -> bool:
        """Slow *and* at the set-points: a base braking from speed swings past its hold point
        and back, and is slow for an instant at the far end of the swing."""
        error = np.abs(self.d.qpos[self.qadr] - self.d.ctrl[self.acts])
        slow = float(np.abs(self.d.qvel[self.dadr]).max()) < 0.01
        return slow and float(error[:2].max()) < 0.002 and float(error[2]) < 0.002

    def at_rest(self) -> bool:
        """Settled, and slower than 3 mm/s (3 mrad/s): a paused base creeps onto its hold
        point at the end."""
        return self.settled() and float(np.abs(self.d.qvel[self.dadr]).max()) < 0.003

    def state(self) -> BaseState:
        return self.capture()()

    def capture(self) -> Callable[[], BaseState]:
        moving = self.job is not None or bool(self.owner)
        return partial(_base_state, self.d.qpos[self.qadr], self.d.qvel[self.dadr], moving)


def _base_state(pose: Any, twist: Any, moving: bool) -> BaseState:
    x, y, yaw = (float(v) for v in pose)
    vx, vy, wz = (float(v) for v in twist)
    c, s = math.cos(yaw), math.sin(yaw)
    return BaseState(
        pose=Pose2D(x, y, wrap(yaw)),
        moving=moving,
        velocity=Twist2D(_rounded(c * vx + s * vy), _rounded(c * vy - s * vx), _rounded(wz)),
    )


def _check_twist(cmd: SetVelocity) -> None:
    values = (cmd.vx, cmd.vy, cmd.wz, 1.0 if cmd.duration is None else cmd.duration)
    if not all(math.isfinite(v) for v in values):
        raise CommandError(f"a velocity command needs finite values, not {cmd}")
    if cmd.duration is not None and not 0 < cmd.duration <= 3600:
        raise CommandError(f"a velocity command lasts 0-3600 s, not {cmd.duration}")


def _ramp(
    now: np.ndarray[Any, Any], target: np.ndarray[Any, Any], linear: float, angular: float
) -> np.ndarray[Any, Any]:
    """``now`` moved towards ``target`` by at most ``linear`` (the x, y part, as a vector)
    and ``angular`` (the yaw rate)."""
    out = now.copy()
    dx, dy = target[0] - now[0], target[1] - now[1]
    gap = math.hypot(dx, dy)
    scale = 1.0 if gap <= linear else linear / gap
    out[0] += dx * scale
    out[1] += dy * scale
    out[2] += min(max(target[2] - now[2], -angular), angular)
    return out


def _rounded(value: float) -> float:
    """To 1 mm/s (or mrad/s), with no negative zero (no noise digits in published states)."""
    return round(value, 3) + 0.0
