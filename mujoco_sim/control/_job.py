"""Jobs and the controller base class: how a device command travels through the simulation.

A :class:`Job` is made on the event loop (by a driver), queued to the world, then *started*,
*ticked* and *finished* in the simulation thread, and finally *completed* on the loop (its
``done`` event set) when the batch that finished it returns. Fields written in the simulation
thread (``progress``, ``result``, ``error``, ``finished``) are read on the loop only after the
batch call returned, which orders the two (the batch is one ``anyio.to_thread.run_sync``).

A :class:`Controller` owns one device in the simulation thread. Each control tick the plant
calls :meth:`Controller.tick` on the active ones, then steps the physics. Controllers write
servo set-points (``data.ctrl``); an idle controller writes nothing, so its device holds the
last set-point. Nothing here may touch the event loop.

**Pause** (``Pause`` / ``Resume`` commands). Each controller runs its motions on a *motion
clock*: the simulation time less :attr:`Controller.lag`, the time it was held. A pause slows
that clock linearly from full rate to a stop over :attr:`Controller.pause_ramp` simulated
seconds (0.5 s), so a trajectory timed by it (minimum-jerk paths, straight tool lines, a
velocity command's set-points) decelerates along its own path and its set-points then stay
where it stopped; the servos bring the device to rest there. A resume speeds the clock up
over the same ramp and the motion goes on to its target. Time limits of a motion (the settle
timeouts) are counted on the motion clock, so they do not run out while held. The ``Pause``
job finishes once the clock stands and the device has been at rest
(:meth:`Controller.at_rest`) for 5 control ticks in a row, or :attr:`Controller.halt_timeout`
after the ramp, whichever is first: its result is the simulated seconds it took. A motion
command that arrives while paused is accepted (one at a time, as ever) but
begins at the resume. ``Stop`` ends a pause: the held motion fails with
:class:`MotionStoppedError` and the clock runs again. Controllers whose motion is not timed
(the gripper's fingers) set ``pause_ramp = 0`` and hold in :meth:`Controller.on_pause`.
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

import anyio
from msgspec import Struct

from device_drivers import DeviceBusyError, DeviceKey, MotionStoppedError, ProgressCallback
from device_drivers.protocol import Command, Pause, Resume, Stop

__all__ = ["NOT_INSTANT", "Controller", "Job"]

_REST_TICKS = 5
"""Control ticks in a row a paused device must be settled for its pause to be done."""

NOT_INSTANT: Any = object()
"""What :meth:`Controller.instant` returns for a command that needs motion."""


class Job:
    """One command for one device (see module doc for which thread touches what)."""

    __slots__ = (
        "cancelled",
        "command",
        "device",
        "done",
        "error",
        "finished",
        "on_progress",
        "progress",
        "reported",
        "result",
    )

    def __init__(
        self, device: DeviceKey, command: Command, on_progress: ProgressCallback | None = None
    ) -> None:
        self.device = device
        self.command = command
        self.on_progress = on_progress
        self.progress = 0.0  # sim thread
        self.result: Any = None  # sim thread
        self.error: BaseException | None = None  # sim thread (or loop, before it starts)
        self.finished = False  # sim thread
        self.cancelled = False  # loop: the waiter gave up; a job not started yet is dropped
        self.done = anyio.Event()  # loop only
        self.reported = -1.0  # loop only: last progress given to on_progress

    def finish(self, result: Any = None, error: BaseException | None = None) -> None:
        """Sim thread: the job is over (idempotent; the first outcome wins)."""
        if not self.finished:
            self.result, self.error, self.finished = result, error, True
            if error is None:
                self.progress = 1.0


class Controller:
    """Base of the per-device controllers (simulation thread only).

    Subclasses implement :meth:`begin` (validate and set up a motion job; raise a
    ``DeviceError`` to refuse it), :meth:`update` (one control tick of the active job),
    :meth:`hold` (set-points to where the device is now) and :meth:`settled`, and may
    override :meth:`state`. The base class does the bookkeeping: one motion at a time
    (:class:`DeviceBusyError` otherwise), ``Stop`` = hold now and finish the running job with
    :class:`MotionStoppedError`, the stop job finishing once the device has settled; ``Pause``
    and ``Resume`` on the motion clock (see the module doc). ``begin`` and ``update`` get
    motion-clock times; ``start``, ``tick`` and ``halt`` simulation times.
    """

    halt_timeout = 0.6
    """A stop job finishes when settled or after this many simulated seconds."""
    pause_ramp = 0.5
    """Simulated seconds over which a pause slows the motion clock to a stop (and a resume
    speeds it up again)."""

    def __init__(self, key: DeviceKey, label: str) -> None:
        self.key = key
        self.label = label
        self.job: Job | None = None
        self.started_at = 0.0  # on the motion clock
        self._halting: list[tuple[Job, float]] = []
        self.finished: list[Job] = []  # drained by the plant after each batch
        self.paused = False
        self.rate = 1.0
        """The motion clock's rate: 1 running, 0 held, in between while slowing or speeding up."""
        self.lag = 0.0
        """Simulated seconds the motion clock is behind the simulation (0 if never paused)."""
        self._clock_seen: float | None = None
        self._deferred = False  # self.job came while paused: begun at the resume
        self._pausing: list[tuple[Job, float]] = []
        self._resting = 0  # ticks in a row held and settled, while a pause job waits

    @property
    def active(self) -> bool:
        return self.job is not None or bool(self._halting) or bool(self._pausing)

    def start(self, job: Job, t: float) -> None:
        """Take ``job`` at simulation time ``t``; errors finish it at once."""
        self._advance(t)
        command = job.command
        if isinstance(command, Stop):
            self.halt(t, f"{self.label}: stopped")
            self._unpause(t)
            self._halting.append((job, t))
            return
        if isinstance(command, Pause):
            if not self._pausing:
                self._resting = 0
            if not self.paused:
                self.paused = True
                self.on_pause()
            self._pausing.append((job, t))
            return
        if isinstance(command, Resume):
            self._resume(t)
            self.done(job)
            return
        now = t - self.lag
        try:
            result = self.instant(job, now)
            if result is not NOT_INSTANT:
                self.done(job, result)
                return
            if self.job is not None:
                raise DeviceBusyError(
                    f"{self.label} is executing {type(self.job.command).__name__}; stop it first"
                )
            if self.paused:  # held: the motion begins at the resume
                self.job, self._deferred = job, True
                return
            self._deferred = False
            self.begin(job, now)
        except Exception as exc:
            self.done(job, error=exc)
            return
        if not job.finished:
            self.job, self.started_at = job, now

    def _advance(self, t: float) -> None:
        """Run the motion clock up to simulation time ``t`` (see the module doc)."""
        last, self._clock_seen = self._clock_seen, t
        dt = 0.0 if last is None or t <= last else t - last
        target = 0.0 if self.paused else 1.0
        rate = self.rate
        if rate == target:
            self.lag += dt * (1.0 - rate)
            return
        if self.pause_ramp <= 0.0:
            new = target
        elif self.paused:
            new = max(0.0, rate - dt / self.pause_ramp)
        else:
            new = min(1.0, rate + dt / self.pause_ramp)
        self.lag += dt * (1.0 - (rate + new) / 2.0)
        self.rate = new

    def _resume(self, t: float) -> None:
        """End a pause: the clock speeds up again; a motion that came while held begins."""
        if self.paused:
            self.paused = False
            self.on_resume()
        for pause, since in self._pausing:
            self.done(pause, t - since)
        self._pausing.clear()
        job = self.job
        if job is None or not self._deferred:
            return
        self._deferred = False
        now = t - self.lag
        try:
            self.begin(job, now)
        except Exception as exc:
            self.job = None
            self.done(job, error=exc)
            return
        self.started_at = now
        if job.finished:
            self.job = None

    def _unpause(self, t: float) -> None:
        """A stop ends a pause: the clock runs at full rate again."""
        self._resume(t)
        self.rate, self._deferred = 1.0, False

    def halt(self, t: float, reason: str) -> None:
        """Hold where the device is now; the running job fails with ``reason``."""
        self.hold()
        self._deferred = False
        if self.job is not None:
            self.done(self.job, error=MotionStoppedError(reason))
            self.job = None

    def fail(self, error: BaseException) -> None:
        """Hold and finish the running job with ``error`` (e.g. a timeout)."""
        self.hold()
        if self.job is not None:
            self.done(self.job, error=error)
            self.job = None

    def tick(self, t: float) -> None:
        self._advance(t)
        if self.job is not None and not self._deferred and self.rate > 0.0:
            try:
                self.update(self.job, t - self.lag)
            except Exception as exc:
                self.fail(exc)
            if self.job is not None and self.job.finished:
                self.job = None
        for item in list(self._halting):
            job, since = item
            if self.settled() or t - since >= self.halt_timeout:
                self._halting.remove(item)
                self.done(job, t - since)  # the result: simulated seconds to stand still
        if self._pausing:
            held = self.rate == 0.0 or self.job is None or self._deferred
            self._resting = self._resting + 1 if held and self.at_rest() else 0
        for item in list(self._pausing):
            job, since = item
            if self._resting >= _REST_TICKS or t - since >= self.pause_ramp + self.halt_timeout:
                self._pausing.remove(item)
                self.done(job, t - since)  # the result: simulated seconds to come to rest

    def done(self, job: Job, result: Any = None, error: BaseException | None = None) -> None:
        job.finish(result, error)
        self.finished.append(job)

    # ------------------------------------------------------------------ to implement
    def instant(self, job: Job, t: float) -> Any:
        """The result of a command that needs no motion, else :data:`NOT_INSTANT`."""
        return NOT_INSTANT

    def begin(self, job: Job, t: float) -> None:
        raise NotImplementedError

    def update(self, job: Job, t: float) -> None:
        raise NotImplementedError

    def hold(self) -> None:
        """Set-points to the present position."""

    def on_pause(self) -> None:
        """A pause begins (the motion clock starts slowing down)."""

    def on_resume(self) -> None:
        """A pause ends (the motion clock starts speeding up)."""

    def settled(self) -> bool:
        return True

    def at_rest(self) -> bool:
        """Still enough for a pause to be done (default: :meth:`settled`)."""
        return self.settled()

    def state(self) -> Struct | None:
        return None

    def capture(self) -> Struct | Callable[[], Struct] | None:
        """What a snapshot keeps of this device: its state now, or a function that builds it
        later, from copies taken now, on whichever thread first reads it (most snapshots of a
        fast world are never read: see :class:`~mujoco_sim.DeviceStates`).
        Default: :meth:`state`."""
        return self.state()
