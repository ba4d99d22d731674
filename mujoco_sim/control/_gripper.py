"""The gripper controller (simulation thread): close with real contacts, attach when both pads
touch, open and release (see :mod:`mujoco_sim.control`).

Openings and forces go through the robot's :class:`~mujoco_sim.control.GripperDrive`
(the generated gripper's servo takes metres; a file's gripper, e.g. the 2F-85, is calibrated).
``close(force)``: the squeeze force is limited to ``force`` (at most the model's
``gripper_force``) and the set-point is "closed"; the fingers stop on the object (or meet). Once the
opening has been still for 5 ticks (or is below 2 mm) the grasp is evaluated and the job
returns the :class:`GripperState`. ``open(width)`` detaches first, then opens; it ends when
the opening is reached or the fingers are blocked. Both time out after 3 s (simulated).
A pause holds the fingers where they are at once; the resume sends them on to the opening.
"""

from __future__ import annotations

from typing import Any

from device_drivers import CommandError, DeviceKey, GripperState, MotionTimeoutError
from device_drivers.protocol import CloseGripper, OpenGripper
from mujoco_sim.control._grasp import Grasping
from mujoco_sim.control._gripper_drive import GripperDrive
from mujoco_sim.control._job import Controller, Job

__all__ = ["GripperController"]

_STILL = 0.003  # opening speed below which the fingers count as stopped, m/s
_TIMEOUT = 3.0


class GripperController(Controller):
    pause_ramp = 0.0  # the fingers halt at once on a pause (see on_pause)

    def __init__(
        self, key: DeviceKey, label: str, data: Any, drive: GripperDrive, grasp: Grasping
    ) -> None:
        super().__init__(key, label)
        self.d, self.drive, self.grasp = data, drive, grasp
        self.act = drive.act
        self.max_opening = drive.max_opening
        self.max_force = drive.rated_force
        self._still = 0
        self._target = 0.0

    @property
    def holding(self) -> str:
        return self.grasp.holding

    @property
    def opening(self) -> float:
        return self.drive.opening(self.d)

    def begin(self, job: Job, t: float) -> None:
        cmd = job.command
        if isinstance(cmd, CloseGripper):
            self.drive.limit_force(cmd.force)
            self._target = 0.0
        elif isinstance(cmd, OpenGripper):
            width = self.max_opening if cmd.width is None else cmd.width
            if not 0.0 <= width <= self.max_opening + 1e-9:
                raise CommandError(
                    f"{self.label}: width {width} m is outside 0..{self.max_opening} m"
                )
            self.grasp.detach()
            self.drive.limit_force(self.max_force)
            self._target = width
        else:
            raise CommandError(f"{self.label} (a gripper) cannot {type(cmd).__name__}")
        self.d.ctrl[self.act] = self.drive.control(self._target)
        self._still = 0

    def update(self, job: Job, t: float) -> None:
        elapsed = t - self.started_at
        opening, speed = self.opening, self.drive.speed(self.d)
        self._still = self._still + 1 if elapsed > 0.1 and speed < _STILL else 0
        if isinstance(job.command, CloseGripper):
            job.progress = min(0.9, elapsed / 0.5)
            if self._still >= 5 or opening < 0.002:
                target = self.grasp.between_pads()
                if target:
                    self.grasp.attach(target)
                self.done(job, self.state(moving=False))
                return
        else:
            job.progress = min(0.9, elapsed / 0.5)
            if abs(opening - self._target) < 0.002 or self._still >= 20:
                self.done(job)
                return
        if elapsed > _TIMEOUT:
            raise MotionTimeoutError(
                f"{self.label}: the fingers still move after {_TIMEOUT:g} s "
                f"(opening {opening * 1000:.1f} mm)"
            )

    def hold(self) -> None:
        self.d.ctrl[self.act] = self.drive.control(self.opening)

    def on_pause(self) -> None:
        """The fingers stop where they are (their motion is not timed: no slowing down)."""
        if self.job is not None and not self._deferred:
            self.hold()

    def on_resume(self) -> None:
        """The fingers go on to the job's opening; stillness is counted afresh."""
        if self.job is not None and not self._deferred:
            self.d.ctrl[self.act] = self.drive.control(self._target)
            self._still = 0

    def settled(self) -> bool:
        return self.drive.speed(self.d) < _STILL

    def state(self, *, moving: bool | None = None) -> GripperState:
        return GripperState(
            opening=self.opening,
            holding=self.grasp.holding,
            pads_in_contact=self.grasp.pads_in_contact(),
            moving=self.job is not None if moving is None else moving,
        )
