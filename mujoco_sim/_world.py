"""``SimWorld``: one MuJoCo world for a scenario, stepped in a worker thread, driven from anyio.

Threading model (every crossing is here or in the modules it names):

- **Event loop**: drivers, the remote server, tests. They *queue* jobs
  (:class:`~mujoco_sim.control.Job`) into a ``deque`` and wait on the job's
  ``anyio.Event``; they *read* state from the latest :class:`~mujoco_sim.
  Snapshot` (immutable copies). The loop never touches ``MjModel``/``MjData``.
- **Simulation thread**: :meth:`SimWorld.run` calls ``anyio.to_thread.run_sync(plant.run_batch,
  ..., limiter=CapacityLimiter(1))`` in a loop. A batch takes the queued jobs, runs the
  controllers at the control rate (100 Hz) between ``mj_step(m, d, nstep=5)`` calls, checks
  the state, copies a snapshot and returns the finished jobs; back on the loop the runner sets
  their events and calls progress callbacks (fast mode: one call runs many batches and hands
  jobs over as they finish, see "Pacing"). :meth:`SimWorld.call` runs any function on the
  model through the same limiter (ground truth such as contacts, test hooks). Only one thread
  at a time ever holds the model, whichever pool thread it is.
- **IK threads**: :meth:`SimWorld.solve_ik` runs placo (and DLS as fallback) on each robot's
  own solver objects through ``to_thread`` with a per-robot limiter, so checking a tool target
  never stalls stepping (:mod:`mujoco_sim`).
- **Recorder**: logs from the simulation thread (rerun's SDK batches and sends on its own
  threads); optional camera images are rendered on a thread the recorder owns.

Pacing: real time (default) runs each batch when the wall clock says its ticks are due
(``anyio.sleep`` in between); if the simulation falls behind by more than ``slip`` seconds it
gives up catching up and counts a slip. While something moves by command, a job waits or an
alarm is near, that is every tick (10 ms); a *quiet* world sleeps until a whole batch is due
(``batch``, 50 ms) or until news (a command, a :meth:`SimWorld.call`, an alarm) wakes it, and
then first runs the ticks due by then, so the news starts at the present tick: an idle world
in real time then costs a small share of a core (see docs/benchmarks.md, section Simulation).
The pacing strategies are :class:`~mujoco_sim._pacing.RealTimePacing` and
:class:`~mujoco_sim._pacing.FastPacing`; the state the runner keeps is split by owning thread
(:class:`~mujoco_sim._runner_state.LoopState`, :class:`~mujoco_sim._runner_state.ThreadState`).

``fast`` runs batches back to back in one thread call (a *run*) that hands finished jobs and
due alarms to the loop as they happen, so that the loop still reacts to the simulation in
lock-step: :class:`~mujoco_sim._fast_run.FastRun` (its module doc tells how), which the world
owns. Backend: asyncio only (anyio's asyncio backend, as meshlink), since a fast run posts to
the running asyncio loop from the simulation thread.

Failure: a diverged state (or any error inside a batch) stops the world; every waiting and
later command fails with that error.
"""

from __future__ import annotations

import logging
import math
import time
from collections.abc import AsyncIterator, Callable
from contextlib import asynccontextmanager
from functools import partial
from typing import TYPE_CHECKING, Annotated, Any, TypeVar

import anyio
import anyio.abc
import anyio.to_thread
from msgspec import Meta, Struct

from device_drivers import (
    DeviceError,
    DeviceKey,
    DeviceUnavailableError,
    ProgressCallback,
    WorldPose,
)
from device_drivers.protocol import Command, Pause, Resume, Stop
from mujoco_sim._fast_run import FastRun
from mujoco_sim._paced_run import PacedRun
from mujoco_sim._pacing import FastPacing, Pacing, RealTimePacing
from mujoco_sim._plant import Batch, DeviceKind, Plant
from mujoco_sim._robot_ik import WorldIK
from mujoco_sim._runner_state import LoopState, ThreadState
from mujoco_sim._snapshot import Snapshot, object_in
from mujoco_sim.control._grasp import GraspMode
from mujoco_sim.control._job import Job
from mujoco_sim.ik._core import IKResult
from scenario import Scenario

if TYPE_CHECKING:
    from mujoco_sim.recording._recorder import Recorder

__all__ = ["SimWorld", "WorldOptions", "WorldStatistics", "running_world"]

T = TypeVar("T")
_log = logging.getLogger(__name__)
_HALT_WAIT = 2.0  # wall seconds a cancelled motion waits for its halt


class WorldOptions(Struct, frozen=True, forbid_unknown_fields=True, kw_only=True):
    fast: bool = False
    """As fast as possible instead of real time."""
    control_rate: Annotated[float, Meta(ge=10, le=500)] = 100.0
    batch: Annotated[float, Meta(gt=0, le=1)] = 0.05
    """Largest simulated time per batch in real time, s (it runs what is due, up to this)."""
    fast_batch: Annotated[float, Meta(gt=0, le=1)] = 0.1
    """Simulated time per batch in fast mode, s: longer batches, fewer thread hand-offs."""
    fast_handover: Annotated[float, Meta(ge=0, le=1)] = 0.02
    """Fast mode: longest wall time, s, of one thread call running batches back to back (see
    the module doc); 0: one batch per call, finished jobs handed over at its end."""
    slip: Annotated[float, Meta(gt=0)] = 0.25
    handover: Annotated[float, Meta(ge=0, le=10)] = 0.0
    """Real time: > 0 runs batches on the wall clock in the simulation thread for up to this
    many wall seconds per thread call (a *paced run*, :mod:`mujoco_sim._paced_run`: the
    physics keeps time while the event loop is blocked); 0 (default): every batch is handed
    through the event loop, which slipped no more often on a loaded machine
    (docs/benchmarks.md, "Real-time physics at 40 robots")."""
    publish: Annotated[float, Meta(gt=0, le=1)] = 0.04
    """Real time: simulated seconds between the snapshots (and, in paced runs, progress
    reports) published while nothing else happens (a snapshot of 160 devices' states costs
    ~1 ms); finished jobs and due alarms bring their own."""
    grasp: GraspMode = "weld"
    seed: int = 0
    max_acceleration: Annotated[float, Meta(gt=0)] = 1e6


class WorldStatistics(Struct, frozen=True):
    sim_time: float
    wall_time: float
    real_time_factor: float
    batches: int
    ticks: int
    slips: int
    busy: float
    """Wall seconds spent inside batches."""
    handovers: int = 0
    """Thread calls back to the loop (in fast mode one runs many batches: see the module doc)."""
    robot_contact_ticks: int = 0
    """Control ticks that ended with two robots' bodies in contact (should stay 0)."""
    first_robot_contact: str = ""
    """The first such contact, in words ("r1 and r2 touched at t = ... s (bodies)")."""


class SimWorld:
    """See the module doc. Build with :meth:`create` (or :func:`running_world`), start with
    :meth:`run` in a task group."""

    def __init__(
        self,
        scenario: Scenario,
        options: WorldOptions | None = None,
        recorder: Recorder | None = None,
    ) -> None:
        """Blocking (builds and compiles the model and the IK solvers): call it
        through :meth:`create` from async code."""
        self.options = options or WorldOptions()
        self.scenario = scenario
        o = self.options
        self.plant = Plant(
            scenario,
            control_rate=o.control_rate,
            grasp=o.grasp,
            seed=o.seed,
            max_acceleration=o.max_acceleration,
            recorder=recorder,
        )
        self.recorder = recorder
        self.facts = self.plant.facts
        self._limiter = anyio.CapacityLimiter(1)
        self._on_loop = LoopState(self.plant.snapshot)
        self._in_thread = ThreadState(self.plant.snapshot)
        self._fast = FastRun(
            self.plant, self._on_loop, self._in_thread, release=self._forget, ring=self._ring
        )
        self._ik = WorldIK(scenario)
        if recorder is not None:  # still in the constructing thread: nothing steps yet
            cameras = [
                f"{c.mount}/{c.site}" if c.mount else c.label
                for c in scenario.sensors
                if c.kind == "camera"
            ]
            recorder.start(
                self.plant.model, self.plant.data, cameras=cameras, robots=self.plant.series()
            )

    @classmethod
    async def create(
        cls,
        scenario: Scenario,
        options: WorldOptions | None = None,
        recorder: Recorder | None = None,
    ) -> SimWorld:
        """Build the world in a worker thread (the loop keeps running)."""
        return await anyio.to_thread.run_sync(cls, scenario, options, recorder)

    # ------------------------------------------------------------------ the runner
    async def run(
        self, *, task_status: anyio.abc.TaskStatus[None] = anyio.TASK_STATUS_IGNORED
    ) -> None:
        """Step until cancelled or failed (see module doc). Returns after a failure, with every
        waiting command failed; never raises it (read :attr:`failure`)."""
        o, plant = self.options, self.plant
        max_ticks = max(1, round((o.fast_batch if o.fast else o.batch) / plant.tick_time))
        self._on_loop.wall0 = wall0 = time.perf_counter()
        pacing: Pacing = (
            FastPacing(max_ticks)
            if o.fast
            else RealTimePacing(
                plant,
                self._on_loop,
                lambda: max(self._on_loop.sim_time, self.snapshot.time),
                max_ticks=max_ticks,
                slip=o.slip,
                wall0=wall0,
            )
        )
        run = self._fast.batch_runner(fast=o.fast, fast_handover=o.fast_handover)
        if isinstance(pacing, RealTimePacing) and o.handover > 0:
            self._fast.attach()
            run = PacedRun(
                plant,
                self._on_loop,
                self._in_thread,
                hand=self._fast,
                pacing=pacing,
                budget=o.handover,
                publish=o.publish,
                progress=self._report_progress,
            )
        per_batch = isinstance(pacing, RealTimePacing) and o.handover <= 0
        task_status.started()
        try:
            while self._on_loop.failure is None:
                ticks, take_jobs = await pacing.next_batch()
                inbox = self._on_loop.inbox
                jobs = [inbox.popleft() for _ in range(len(inbox))] if take_jobs else []
                started = time.perf_counter()
                self._fast.begin(ticks)
                call = (
                    partial(plant.run_batch, publish=self._publishing(ticks)) if per_batch else run
                )
                try:
                    batch = await anyio.to_thread.run_sync(call, ticks, jobs, limiter=self._limiter)
                except Exception as exc:  # divergence, or a bug in a controller
                    self._fast.take_posts()
                    _log.error("simulation stopped: %s", exc)
                    self._fail(exc, jobs)
                    return
                self._fast.take_posts()
                self._on_loop.busy += time.perf_counter() - started
                self._complete(batch)
        finally:
            self._fast.close()
            if self._on_loop.failure is None:
                self._fail(DeviceUnavailableError("the simulation was stopped"), [])

    def _publishing(self, ticks: int) -> bool:
        """Loop, real time with a hand-off per batch: whether the next batch, of ``ticks``, ends
        with a snapshot: every ``publish`` simulated s, and when an alarm comes due (a batch that
        finishes a job takes one anyway). Readers see a snapshot at most that old."""
        s = self._on_loop
        end = s.sim_time + ticks * self.plant.tick_time
        return end - s.published >= self.options.publish - 1e-9 or end >= s.next_alarm - 1e-9

    def _tell(self) -> None:
        """Loop: something a quiet world in real time must not sleep through happened."""
        self._on_loop.news.set()

    def _ring(self, sim_time: float) -> None:
        """Wake the :meth:`wait_time` alarms due at ``sim_time``."""
        if self._on_loop.alarms:
            due = [a for a in self._on_loop.alarms if a[0] <= sim_time]
            for alarm in due:
                self._on_loop.alarms.remove(alarm)
                alarm[1].set()
            self._on_loop.next_alarm = min((a[0] for a in self._on_loop.alarms), default=math.inf)

    def _complete(self, batch: Batch) -> None:
        self._on_loop.snapshot = batch.snapshot
        self._on_loop.sim_time = max(self._on_loop.sim_time, batch.time)
        if batch.snapshot.time >= batch.time:
            self._on_loop.published = batch.time
        self._on_loop.handovers += 1
        for job in batch.finished:
            self._forget(job)
            job.done.set()
        self._ring(batch.snapshot.time)
        self._report_progress()

    def _report_progress(self) -> None:
        """Loop: call the progress callbacks of the waiting jobs whose progress changed."""
        for job in self._on_loop.waiting:
            if job.on_progress is not None and job.progress != job.reported:
                job.reported = job.progress
                job.on_progress(job.progress)

    def _forget(self, job: Job) -> None:
        if job in self._on_loop.waiting:
            self._on_loop.waiting.discard(job)
            if job.on_progress is not None:
                self._on_loop.reporting -= 1

    def _fail(self, error: BaseException, started: list[Job]) -> None:
        self._on_loop.failure = error
        for job in [*self._on_loop.waiting, *started, *self._on_loop.inbox]:
            if not job.finished:
                job.finish(error=error)
            job.done.set()
        self._on_loop.waiting.clear()
        self._on_loop.reporting = 0
        self._on_loop.inbox.clear()
        for _, alarm in self._on_loop.alarms:
            alarm.set()
        self._on_loop.stopped.set()

    @property
    def failure(self) -> BaseException | None:
        """Why the world stopped (``None`` while it runs)."""
        return self._on_loop.failure

    async def wait_stopped(self) -> BaseException | None:
        """Wait until the world stops; return why."""
        await self._on_loop.stopped.wait()
        return self._on_loop.failure

    async def wait_time(self, sim_time: float) -> None:
        """Wait until the simulation clock reaches ``sim_time`` s (or the world stops)."""
        if self.snapshot.time >= sim_time or self._on_loop.failure is not None:
            return
        alarm = anyio.Event()
        self._on_loop.alarms.append((sim_time, alarm))
        self._on_loop.next_alarm = min(self._on_loop.next_alarm, sim_time)
        self._tell()
        await alarm.wait()

    async def sleep(self, seconds: float) -> None:
        """Wait ``seconds`` of simulated time."""
        await self.wait_time(self.snapshot.time + seconds)

    # ------------------------------------------------------------------ commands
    async def execute(
        self, device: DeviceKey, command: Command, progress: ProgressCallback | None = None
    ) -> Any:
        """Queue ``command`` for ``device`` and wait for its outcome. Cancelling the caller
        halts the device (it holds where it is) before the cancellation propagates (not for
        ``Stop``, ``Pause`` and ``Resume``)."""
        if device not in self.plant.controllers:
            raise DeviceUnavailableError(f"no device {device[0]}/{device[1]} in this world")
        if self._on_loop.failure is not None:
            raise self._on_loop.failure
        job = Job(device, command, progress)
        self._on_loop.waiting.add(job)
        if progress is not None:
            self._on_loop.reporting += 1
        self._on_loop.inbox.append(job)
        self._tell()
        try:
            await job.done.wait()
        except anyio.get_cancelled_exc_class():
            job.cancelled = True
            if not isinstance(command, Stop | Pause | Resume):
                with anyio.CancelScope(shield=True), anyio.move_on_after(_HALT_WAIT):
                    await self.halt(device)
            raise
        if job.error is not None:
            raise job.error
        if progress is not None and job.reported < 1.0:
            progress(1.0)
        return job.result

    async def halt(self, device: DeviceKey) -> None:
        """Stop ``device`` and wait until it holds still (quietly if the world has stopped)."""
        if self._on_loop.failure is not None:
            return
        try:
            await self.execute(device, Stop())
        except DeviceError:
            if self._on_loop.failure is None:
                raise

    def state(self, device: DeviceKey) -> Any:
        """The device's state in the latest snapshot."""
        try:
            return self.snapshot.states[device]
        except KeyError:
            raise DeviceUnavailableError(
                f"no device {device[0]}/{device[1]} with a state"
            ) from None

    @property
    def snapshot(self) -> Snapshot:
        """The newest state of the world: the last batch end's, or the last one delivered with
        an event if that is newer (see :mod:`mujoco_sim._fast_run`). Immutable: read it once
        per decision."""
        latest, delivered = self._in_thread.latest, self._on_loop.snapshot
        return latest if latest.time > delivered.time else delivered

    @property
    def devices(self) -> dict[DeviceKey, DeviceKind]:
        return dict(self.plant.kinds)

    def label(self, device: DeviceKey) -> str:
        return self.plant.controllers[device].label

    async def call(self, fn: Callable[[Any, Any], T]) -> T:
        """Run ``fn(model, data)`` in the simulation thread, between batches (a fast run
        returns at the next batch boundary for it)."""
        plant = self.plant
        self._on_loop.calls += 1
        self._tell()
        try:
            return await anyio.to_thread.run_sync(
                fn, plant.model, plant.data, limiter=self._limiter
            )
        finally:
            self._on_loop.calls -= 1

    # ------------------------------------------------------------------ IK
    async def solve_ik(self, robot: str, target: WorldPose, *, whole_body: bool) -> IKResult:
        """Joint values putting ``robot``'s tool at ``target`` from its present set-points
        (:class:`~mujoco_sim.WorldIK`: placo, then DLS, on an IK thread).

        Raises:
            UnreachableError: neither solver converged (the smaller residual is reported).
        """
        arm = self.plant.controllers[(robot, "arm")]
        base = self.plant.controllers.get((robot, "base"))  # none: a fixed robot
        q0 = {**(self._setpoints(base) if base else {}), **self._setpoints(arm)}
        return await self._ik.solve(robot, q0, target, whole_body=whole_body)

    def _setpoints(self, ctrl: Any) -> dict[str, float]:
        values = self.snapshot.ctrl[ctrl.acts]  # a copy taken in the simulation thread
        return {j: float(v) for j, v in zip(ctrl.joints, values, strict=True)}

    # ------------------------------------------------------------------ ground truth
    def body_pose(self, name: str) -> WorldPose:
        """World pose of a body (a label, or ``r1/gripper``) in the latest snapshot."""
        return self.snapshot.pose(self.facts.body(name))

    def object_in(self, label: str, container: str) -> bool:
        """Whether ``label`` lies in ``container`` now, at rest and not held."""
        return object_in(self.snapshot, self.facts, label, container)

    def objects_in(self, container: str) -> list[str]:
        return [o for o in self.facts.objects if o != container and self.object_in(o, container)]

    async def contacts(self) -> list[tuple[str, str, float]]:
        """Bodies in contact now, with normal forces (computed in the simulation thread)."""
        return await self.call(lambda _model, _data: self.plant.contacts())

    def statistics(self) -> WorldStatistics:
        s = self._on_loop
        wall = time.perf_counter() - s.wall0 if s.wall0 else 0.0
        sim = self.snapshot.time
        return WorldStatistics(
            sim_time=sim,
            wall_time=wall,
            real_time_factor=sim / wall if wall > 0 else math.nan,
            batches=self.plant.batches_run,  # counted in the simulation thread
            ticks=self.plant.ticks_run,
            slips=s.slips,
            busy=s.busy,
            handovers=s.handovers,
            robot_contact_ticks=self.plant.robot_contacts.ticks,  # counted in the sim thread
            first_robot_contact=str(self.plant.robot_contacts.first or ""),
        )


@asynccontextmanager
async def running_world(
    scenario: Scenario, options: WorldOptions | None = None, recorder: Recorder | None = None
) -> AsyncIterator[SimWorld]:
    """Build ``scenario``'s world (in a worker thread) and step it while the block runs."""
    world = await SimWorld.create(scenario, options, recorder)
    async with anyio.create_task_group() as tg:
        await tg.start(world.run)
        try:
            yield world
        finally:
            tg.cancel_scope.cancel()
