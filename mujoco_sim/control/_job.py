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
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

import anyio
from msgspec import Struct

from device_drivers import DeviceBusyError, DeviceKey, MotionStoppedError, ProgressCallback
from device_drivers.protocol import Command, Stop

__all__ = ["NOT_INSTANT", "Controller", "Job"]

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
    :class:`MotionStoppedError`, the stop job finishing once the device has settled.
    """

    halt_timeout = 0.6
    """A stop job finishes when settled or after this many simulated seconds."""

    def __init__(self, key: DeviceKey, label: str) -> None:
        self.key = key
        self.label = label
        self.job: Job | None = None
        self.started_at = 0.0
        self._halting: list[tuple[Job, float]] = []
        self.finished: list[Job] = []  # drained by the plant after each batch

    @property
    def active(self) -> bool:
        return self.job is not None or bool(self._halting)

    def start(self, job: Job, t: float) -> None:
        """Take ``job`` at simulation time ``t``; errors finish it at once."""
        if isinstance(job.command, Stop):
            self.halt(t, f"{self.label}: stopped")
            self._halting.append((job, t))
            return
        try:
            result = self.instant(job, t)
            if result is not NOT_INSTANT:
                self.done(job, result)
                return
            if self.job is not None:
                raise DeviceBusyError(
                    f"{self.label} is executing {type(self.job.command).__name__}; stop it first"
                )
            self.begin(job, t)
        except Exception as exc:
            self.done(job, error=exc)
            return
        if not job.finished:
            self.job, self.started_at = job, t

    def halt(self, t: float, reason: str) -> None:
        """Hold where the device is now; the running job fails with ``reason``."""
        self.hold()
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
        if self.job is not None:
            try:
                self.update(self.job, t)
            except Exception as exc:
                self.fail(exc)
            if self.job is not None and self.job.finished:
                self.job = None
        for item in list(self._halting):
            job, since = item
            if self.settled() or t - since >= self.halt_timeout:
                self._halting.remove(item)
                self.done(job, t - since)  # the result: simulated seconds to stand still

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

    def settled(self) -> bool:
        return True

    def state(self) -> Struct | None:
        return None

    def capture(self) -> Struct | Callable[[], Struct] | None:
        """What a snapshot keeps of this device: its state now, or a function that builds it
        later, from copies taken now, on whichever thread first reads it (most snapshots of a
        fast world are never read: see :class:`~mujoco_sim.DeviceStates`).
        Default: :meth:`state`."""
        return self.state()
