"""The microwave controller (simulation thread): door motor and heater (a door without a motor,
``ApplianceEntry.door_motor = false``, refuses ``SetDoor``: an arm swings it).

Two channels run independently: the door (``SetDoor``: a minimum-jerk ramp of the hinge
servo's set-point at the scenario's door speed, done within 0.03 rad of the goal) and the heater
(``Heat``: a countdown in simulated time). Heating is refused while the door is open (more
than 0.05 rad); opening the door while heating stops the heater, whose job then fails with
:class:`MotionStoppedError`, as a real microwave would. ``Press``: ``start`` heats for the
scenario's default time without waiting, ``stop`` stops the heater, ``open`` opens the door
(and waits). ``contents`` lists the objects whose centre is inside the cavity.
"""

from __future__ import annotations

from collections.abc import Callable, Mapping
from functools import partial
from typing import Any

import msgspec
import numpy as np

from device_drivers import (
    ApplianceState,
    CommandError,
    DeviceBusyError,
    DeviceKey,
    MotionStoppedError,
    MotionTimeoutError,
)
from device_drivers.protocol import Heat, Press, SetDoor
from mujoco_sim._snapshot import ObjectInfo
from mujoco_sim.control._job import Controller, Job
from mujoco_sim.motion._math import PEAK_SPEED, minjerk
from scenario import ApplianceEntry

__all__ = ["ApplianceController"]

_OPEN = 0.05  # door angle above which the door counts as open, rad


class ApplianceController(Controller):
    def __init__(
        self,
        key: DeviceKey,
        entry: ApplianceEntry,
        model: Any,
        data: Any,
        objects: Mapping[str, ObjectInfo],
    ) -> None:
        super().__init__(key, entry.label)
        self.m, self.d, self.entry = model, data, entry
        self.body = model.body(entry.label).id
        joint = model.joint(f"{entry.label}/door").id
        self.qadr, self.dadr = model.jnt_qposadr[joint], model.jnt_dofadr[joint]
        self.act = model.actuator(f"{entry.label}/door").id if entry.door_motor else None
        self.objects = dict(objects)
        self._labels = list(self.objects)  # the same, as arrays for contents()
        bodies = [o.body for o in self.objects.values()]
        self._lift = np.array([o.half[2] - o.bottom for o in self.objects.values()], dtype=float)
        self._watched = np.array([*bodies, self.body], dtype=int)  # the objects, the housing
        self._seen: tuple[np.ndarray[Any, Any], np.ndarray[Any, Any], list[str]] | None = None
        self.heat_job: Job | None = None
        self.heat_end = 0.0
        self.heat_period = 0.0
        self.door: tuple[float, float, float] = (0.0, 0.0, 1.0)  # from, to, period

    @property
    def angle(self) -> float:
        return float(self.d.qpos[self.qadr])

    @property
    def active(self) -> bool:
        return super().active or self.heat_job is not None

    def start(self, job: Job, t: float) -> None:
        cmd = job.command
        try:
            if isinstance(cmd, Heat):
                self._start_heating(job, t)  # finished by tick() when the time is up
                return
            if isinstance(cmd, Press) and cmd.button == "stop":
                self._stop_heating("stopped by the stop button")
                self.done(job)
                return
            if isinstance(cmd, Press) and cmd.button == "start":
                self._start_heating(Job(job.device, Heat(self.entry.default_heating_time)), t)
                self.done(job)
                return
        except Exception as exc:
            self.done(job, error=exc)
            return
        super().start(job, t)

    def _start_heating(self, job: Job, t: float) -> None:
        cmd = job.command
        assert isinstance(cmd, Heat)
        if self.angle > _OPEN or self.job is not None:
            raise CommandError(f"{self.label}: the door is open; close it before heating")
        if self.heat_job is not None:
            raise DeviceBusyError(f"{self.label} is already heating; stop it first")
        self.heat_job, self.heat_end, self.heat_period = job, t + cmd.duration, cmd.duration

    def _stop_heating(self, reason: str) -> None:
        if self.heat_job is not None:
            self.done(self.heat_job, error=MotionStoppedError(f"{self.label}: {reason}"))
            self.heat_job = None

    def begin(self, job: Job, t: float) -> None:
        cmd = job.command
        if isinstance(cmd, Press):  # "open"
            cmd = SetDoor(open=True)
        if not isinstance(cmd, SetDoor):
            raise CommandError(f"{self.label} (an appliance) cannot {type(cmd).__name__}")
        if self.act is None:
            raise CommandError(f"{self.label}: its door has no motor (an arm opens it)")
        goal = self.entry.door_open_angle if cmd.open else 0.0
        start = float(self.d.ctrl[self.act])
        period = max(0.3, PEAK_SPEED * abs(goal - start) / self.entry.door_speed)
        self.door = (start, goal, period)
        if cmd.open:
            self._stop_heating("the door was opened while heating")

    def update(self, job: Job, t: float) -> None:
        assert self.act is not None  # begin() refused the door of a motorless appliance
        start, goal, period = self.door
        s = (t - self.started_at) / period
        job.progress = 0.95 * min(s, 1.0)
        self.d.ctrl[self.act] = start + minjerk(s) * (goal - start)
        if s >= 1.0 and abs(self.angle - goal) < 0.03:
            self.done(job)
        elif s >= 1.0 and t - self.started_at > period + 2.0:
            raise MotionTimeoutError(
                f"{self.label}: the door is at {self.angle:.2f} rad, not {goal:.2f}: blocked?"
            )

    def tick(self, t: float) -> None:
        super().tick(t)
        job = self.heat_job
        if job is None:
            return
        job.progress = min(1.0, 1.0 - (self.heat_end - t) / self.heat_period)
        if t >= self.heat_end:
            self.done(job)
            self.heat_job = None

    def halt(self, t: float, reason: str) -> None:
        super().halt(t, reason)
        self._stop_heating(reason)

    def hold(self) -> None:
        if self.act is not None:
            self.d.ctrl[self.act] = np.clip(self.angle, 0.0, self.entry.door_open_angle)

    def settled(self) -> bool:
        return abs(float(self.d.qvel[self.dadr])) < 0.02

    def contents(self) -> list[str]:
        """The objects whose centre is inside the cavity (sorted labels): all objects placed
        in the housing's frame at once; the answer is kept until one of them (or the housing)
        moves."""
        if not self._labels:
            return []
        poses, xmat = self.d.xpos[self._watched], self.d.xmat[self._watched]
        seen = self._seen
        if seen is not None and np.array_equal(poses, seen[0]) and np.array_equal(xmat, seen[1]):
            return list(seen[2])
        found = self._inside(poses, xmat)
        self._seen = (poses, xmat, found)
        return list(found)

    def _inside(self, poses: Any, xmat: Any) -> list[str]:
        """Which watched objects (rows of ``poses``, ``xmat``; the housing last) are inside;
        a pure function of its arguments (it may run on another thread: see capture)."""
        a, labels, lift = self.entry, self._labels, self._lift
        rot = xmat[-1].reshape(3, 3)
        axes_z = xmat[:-1, 2::3]  # each object's z axis (the third column)
        centres = poses[:-1] + axes_z * lift[:, None] - poses[-1]
        x, y, z = (centres @ rot).T  # in the housing's frame
        d, w, h, t = a.size[0] / 2, a.size[1] / 2, a.size[2], a.wall
        inside = (-d + t <= x) & (x <= d) & (np.abs(y) <= w - t) & (t <= z) & (z <= h - t)
        return sorted(labels[i] for i in np.flatnonzero(inside))

    def state(self) -> ApplianceState:
        return msgspec.structs.replace(self._state(), contents=self.contents())

    def capture(self) -> ApplianceState | Callable[[], ApplianceState]:
        """The state, its contents worked out when read, from copies of the poses taken now."""
        if not self._labels:
            return self._state()
        poses, xmat = self.d.xpos[self._watched], self.d.xmat[self._watched]
        return partial(_with_contents, self._state(), self._inside, poses, xmat)

    def _state(self) -> ApplianceState:
        """The state now, without its contents."""
        remaining = 0.0
        if self.heat_job is not None:
            remaining = max(0.0, self.heat_end - float(self.d.time))
        angle = self.angle
        return ApplianceState(
            door_angle=angle,
            door_open=angle > _OPEN,
            heating=self.heat_job is not None,
            remaining=remaining,
        )


def _with_contents(
    state: ApplianceState, inside: Callable[[Any, Any], list[str]], poses: Any, xmat: Any
) -> ApplianceState:
    return msgspec.structs.replace(state, contents=inside(poses, xmat))
