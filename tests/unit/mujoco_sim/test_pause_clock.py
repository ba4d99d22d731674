"""The motion clock of the controllers (no physics): a pause slows a motion to a stop over
the ramp and holds it, its time limits do not run out while held, the resume goes on to the
same end; a command given while held begins at the resume; a stop ends a pause."""

from __future__ import annotations

import pytest

from device_drivers import MotionStoppedError, MotionTimeoutError
from device_drivers.protocol import MoveJoints, Pause, Resume, Stop
from mujoco_sim.control import Controller, Job

TICK = 0.01


class Line(Controller):
    """Moves a point from 0 to 1 in 1 s of its motion clock; fails 0.5 s after that unless
    ``stuck`` is False (it is done at once at the end then)."""

    def __init__(self, *, stuck: bool = False, ramp: float = 0.5) -> None:
        super().__init__(("r1", "arm"), "r1-arm")
        self.position = 0.0
        self.stuck = stuck
        self.pause_ramp = ramp
        self.begun: list[float] = []
        self.seen = 0.0  # the position at the last settled() check

    def begin(self, job: Job, t: float) -> None:
        self.begun.append(t)

    def update(self, job: Job, t: float) -> None:
        elapsed = t - self.started_at
        self.position = min(1.0, elapsed)
        if elapsed >= 1.0 and not self.stuck:
            self.done(job)
        elif elapsed > 1.5:
            raise MotionTimeoutError("stuck")

    def settled(self) -> bool:
        """Still since the last check."""
        still, self.seen = self.position == self.seen, self.position
        return still


def over(job: Job) -> bool:
    """Whether ``job`` has finished (a call: its value changes between asserts)."""
    return job.finished


class Clock:
    def __init__(self, controller: Controller) -> None:
        self.controller, self.t = controller, 0.0

    def send(self, command: object) -> Job:
        job = Job(self.controller.key, command)  # type: ignore[arg-type]
        self.controller.start(job, self.t)
        return job

    def run(self, seconds: float) -> None:
        for _ in range(round(seconds / TICK)):
            self.controller.tick(self.t)
            self.t = round(self.t + TICK, 9)


def test_a_pause_slows_the_motion_to_a_stop_and_the_resume_finishes_it() -> None:
    line = Line()
    clock = Clock(line)
    motion = clock.send(MoveJoints({"elbow": 1.0}))
    clock.run(0.3)
    at_pause = line.position
    pause = clock.send(Pause())
    clock.run(0.25)
    assert not over(pause) and line.rate == pytest.approx(0.5, abs=0.03)
    clock.run(0.35)
    assert line.rate == 0.0 and over(pause) and pause.error is None
    assert pause.result <= line.pause_ramp + 0.07  # seconds to rest: the ramp, 5 ticks still
    stopped = line.position
    assert at_pause < stopped < at_pause + 0.3  # it slowed down over the ramp (~0.25 of travel)
    clock.run(5.0)  # held far longer than the motion's own limits
    assert line.position == stopped and not over(motion)
    resume = clock.send(Resume())
    assert resume.finished and resume.error is None
    clock.run(3.0)
    assert motion.finished and motion.error is None and line.position == 1.0
    assert line.lag == pytest.approx(5.1 + 0.5, abs=0.02)  # stood still, plus half of each ramp


def test_time_limits_still_count_on_the_motion_clock() -> None:
    line = Line(stuck=True)
    clock = Clock(line)
    motion = clock.send(MoveJoints({"elbow": 1.0}))
    clock.run(0.5)
    clock.send(Pause())
    clock.run(10.0)
    assert not over(motion)
    clock.send(Resume())
    clock.run(2.0)
    assert isinstance(motion.error, MotionTimeoutError)


def test_a_command_given_while_paused_begins_at_the_resume() -> None:
    line = Line()
    clock = Clock(line)
    pause = clock.send(Pause())
    clock.run(0.1)
    assert over(pause)  # nothing moved: at rest at once
    motion = clock.send(MoveJoints({"elbow": 1.0}))
    clock.run(2.0)
    assert line.begun == [] and line.position == 0.0 and not over(motion)
    clock.send(Resume())
    assert len(line.begun) == 1
    clock.run(2.0)
    assert motion.finished and motion.error is None and line.position == 1.0


def test_a_stop_ends_a_pause_and_the_held_motion() -> None:
    line = Line()
    clock = Clock(line)
    motion = clock.send(MoveJoints({"elbow": 1.0}))
    clock.run(0.3)
    pause = clock.send(Pause())
    clock.run(1.0)
    stop = clock.send(Stop())
    clock.run(0.1)
    assert isinstance(motion.error, MotionStoppedError)
    assert stop.finished and pause.finished
    assert not line.paused and line.rate == 1.0
    again = clock.send(MoveJoints({"elbow": 1.0}))  # free again: runs at once
    clock.run(1.1)
    assert again.finished and again.error is None


def test_without_a_ramp_the_motion_stops_at_the_next_tick() -> None:
    line = Line(ramp=0.0)
    clock = Clock(line)
    clock.send(MoveJoints({"elbow": 1.0}))
    clock.run(0.3)
    clock.send(Pause())
    clock.run(0.01)
    held = line.position
    clock.run(1.0)
    assert line.position == held and line.rate == 0.0


def test_a_controller_never_paused_runs_on_simulation_time() -> None:
    line = Line()
    clock = Clock(line)
    motion = clock.send(MoveJoints({"elbow": 1.0}))
    clock.run(1.01)
    assert motion.finished and line.lag == 0.0
