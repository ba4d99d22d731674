"""The simulation proper, run in the simulation thread: model, data, controllers, batches.

:class:`Plant` is synchronous and not thread-safe by design: :class:`~mujoco_sim.
SimWorld` calls it only through ``anyio.to_thread.run_sync`` with a ``CapacityLimiter(1)``,
so at most one thread touches ``MjModel``/``MjData`` at any time, and the event loop never does.

One batch (:meth:`Plant.run_batch`) = start the queued jobs, then for each control tick: the
active controllers update their set-points, ``mj_step(m, d, nstep=steps_per_tick)`` (which
releases the GIL), the recorder samples; finally ``check_state`` (divergence ->
:class:`SimulationDivergedError`) and a :class:`~mujoco_sim.Snapshot` of copies.
"""

from __future__ import annotations

import math
from collections import deque
from collections.abc import Callable
from dataclasses import dataclass
from time import perf_counter
from typing import TYPE_CHECKING, Any, Literal

import mujoco
import numpy as np

from device_drivers import DeviceKey, DeviceUnavailableError
from mujoco_sim._snapshot import DeviceStates, SceneFacts, Snapshot
from mujoco_sim.control._appliance import ApplianceController
from mujoco_sim.control._arm import ArmController
from mujoco_sim.control._base import BaseController
from mujoco_sim.control._grasp import Grasping, GraspMode
from mujoco_sim.control._gripper import GripperController
from mujoco_sim.control._gripper_drive import Calibration, GripperDrive, gripper_drive
from mujoco_sim.control._job import Controller, Job
from mujoco_sim.control._sensing import CameraController, PlatformController
from mujoco_sim.models._scene import build_scene, weld_name
from mujoco_sim.physics._contacts import RobotContacts
from mujoco_sim.physics._health import DEFAULT_MAX_ACCELERATION, check_state
from mujoco_sim.physics._options import TIMESTEP
from mujoco_sim.physics._state import hold_servos, set_joint_positions
from scenario import MjcfArm, Scenario, footprints, resolve_placements, robot_layout

if TYPE_CHECKING:
    from mujoco_sim.recording._recorder import Recorder, RobotSeries

__all__ = ["Batch", "DeviceKind", "Plant"]

DeviceKind = Literal["arm", "gripper", "base", "sensor", "appliance"]


@dataclass(frozen=True)
class Batch:
    finished: list[Job]
    snapshot: Snapshot
    ticks: int
    time: float
    """The simulation time at the batch's end (the snapshot may be older: see ``publish``)."""


class Plant:
    """One scenario's world and its device controllers (simulation thread only)."""

    def __init__(
        self,
        scenario: Scenario,
        *,
        control_rate: float = 100.0,
        grasp: GraspMode = "weld",
        seed: int = 0,
        max_acceleration: float = DEFAULT_MAX_ACCELERATION,
        recorder: Recorder | None = None,
    ) -> None:
        self.scenario = scenario
        self.spec = build_scene(scenario)
        self.model: Any = self.spec.compile()
        self.data: Any = mujoco.MjData(self.model)
        m, d = self.model, self.data
        self.drives: dict[str, GripperDrive] = {}
        drives = self.drives
        calibrations: dict[MjcfArm, Calibration] = {}  # robots with the same gripper file
        for robot in scenario.robots:  # grippers start open; a file's arm at its home posture
            layout = robot_layout(robot.spec)
            drives[robot.name] = drive = gripper_drive(m, layout, robot.spec, calibrations)
            drive.start_open(d)
            if robot.spec.mjcf is not None:
                home = dict(zip(layout.arm_joints, robot.spec.mjcf.home, strict=True))
                set_joint_positions(m, d, home, hold=False)
        hold_servos(m, d)
        self.steps_per_tick = max(1, round(1.0 / (control_rate * TIMESTEP)))
        self.tick_time = self.steps_per_tick * TIMESTEP
        self.max_acceleration = max_acceleration
        self.recorder = recorder
        self.batches_run = 0  # simulation thread; read by SimWorld.statistics
        self.ticks_run = 0  # likewise
        self.facts = SceneFacts.build(scenario, m)
        self.robot_contacts = RobotContacts(m, {r.name: r.spec.prefix for r in scenario.robots})
        self.controllers: dict[DeviceKey, Controller] = {}
        self.kinds: dict[DeviceKey, DeviceKind] = {}
        graspable = {label: m.body(label).id for label in self.facts.graspable}
        obstacles = footprints(scenario)
        for robot in scenario.robots:
            name, spec = robot.name, robot.spec
            welds = {label: m.equality(weld_name(name, label)).id for label in graspable}
            grasping = Grasping(m, d, robot_layout(spec), graspable, welds, grasp)
            hand = GripperController(
                (name, "gripper"), f"{name}-gripper", d, drives[name], grasping
            )
            self._add(hand, "gripper")
            if spec.fixed:  # no base device; the arm's tracker stands where the robot stands
                arm = ArmController(
                    (name, "arm"), f"{name}-arm", m, d, spec, hand, None, at=robot.pose
                )
            else:
                base = BaseController((name, "base"), f"{name}-base", m, d, spec, obstacles)
                arm = ArmController((name, "arm"), f"{name}-arm", m, d, spec, hand, base)
                self._add(base, "base")
            self._add(arm, "arm")
        objects = self.facts.objects
        movable = {k: v for k, v in objects.items() if v.kind != "appliance"}
        for a in scenario.appliances:
            self._add(ApplianceController((a.label, "appliance"), a, m, d, movable), "appliance")
        placed = resolve_placements(scenario)
        furniture = {f.label: f for f in scenario.furniture}
        for i, s in enumerate(scenario.sensors):
            key = (s.owner, s.device_name)
            if s.kind == "camera":
                sensor: Controller = CameraController(key, s, m, d, objects, seed + 1000 * i)
            else:
                surface = furniture[s.surface]
                sensor = PlatformController(
                    key, s, m, d, objects, seed + 1000 * i, surface, placed[s.surface]
                )
            self._add(sensor, "sensor")
        free = [(k, o.free_dof) for k, o in self.facts.objects.items() if o.free_dof >= 0]
        self._free = (
            [k for k, _ in free],
            np.array([[a, a + 1, a + 2] for _, a in free], dtype=int),
        )
        mujoco.mj_forward(m, d)
        self.snapshot = self._snapshot()

    def _add(self, controller: Controller, kind: DeviceKind) -> None:
        self.controllers[controller.key] = controller
        self.kinds[controller.key] = kind

    @property
    def time(self) -> float:
        return float(self.data.time)

    def series(self) -> list[RobotSeries]:
        """What a recorder plots per robot: base and arm joints, gripper opening."""
        from mujoco_sim.recording._recorder import RobotSeries

        return [
            RobotSeries(r.name, (*lay.base_joints, *lay.arm_joints), self.drives[r.name].opening)
            for r in self.scenario.robots
            for lay in [robot_layout(r.spec)]
        ]

    def run_batch(
        self,
        ticks: int,
        jobs: list[Job],
        *,
        inbox: deque[Job] | None = None,
        until: Callable[[float], bool] | None = None,
        budget: float = 0.0,
        report: Callable[[list[Job], Snapshot], None] | None = None,
        wake: Callable[[float], bool] | None = None,
        publish: bool = True,
    ) -> Batch:
        """Start ``jobs``, run ``ticks`` control ticks, check and snapshot (see module doc).

        Fast mode, with ``inbox``: batches of ``ticks`` follow one another in this call, each
        starting the jobs queued in ``inbox`` meanwhile, until one finishes a job, ``until``
        (called between batches with the simulation time; it may wait) says stop, or
        ``budget`` wall seconds have passed: the same ticks and checks, with fewer hand-offs
        to the event loop and one snapshot, at the end. With ``report`` too, finished jobs do
        not end the call: ``report(jobs, snapshot)`` gets them as soon as they are over (after
        the starts of a batch for commands answered at once, after the tick that finished the
        others), the state checked and a snapshot taken at that moment; ``report([],
        snapshot)`` comes after every tick at whose end ``wake(time)`` is true; and every batch
        ends with a report (of the jobs it finished last, if any) and its snapshot. With
        ``publish`` false a batch takes a snapshot only if it finished jobs (real time
        publishes one every few ticks: ``WorldOptions.publish``).

        Raises:
            SimulationDivergedError: the state diverged during the batch.
        """
        finished = self._run_ticks(ticks, jobs, report, wake, publish=publish)
        total = ticks
        if inbox is not None:
            deadline = perf_counter() + budget
            while not finished and perf_counter() < deadline:
                if until is not None and until(float(self.data.time)):
                    break
                queued = [inbox.popleft() for _ in range(len(inbox))]
                finished = self._run_ticks(ticks, queued, report, wake, within=True)
                total += ticks
        if report is None and (publish or finished):  # (with a report, the last batch took it)
            self.snapshot = self._snapshot()
        return Batch(finished, self.snapshot, total, self.time)

    def _run_ticks(
        self,
        ticks: int,
        jobs: list[Job],
        report: Callable[[list[Job], Snapshot], None] | None,
        wake: Callable[[float], bool] | None = None,
        *,
        within: bool = False,
        publish: bool = True,
    ) -> list[Job]:
        """One batch without the final snapshot: start ``jobs``, tick, step, sample, check;
        return the jobs that finished (none with ``report``: see :meth:`run_batch`). Per tick
        only the active controllers run (no command starts within a batch, so none becomes
        active), and the recorder only when a sample is due. ``within``: a batch after the
        first of a fast run, which starts where the one before ended, with its snapshot."""
        m, d = self.model, self.data
        self.batches_run += 1
        self.ticks_run += ticks
        t = float(d.time)
        cancelled: list[Job] = []
        for job in jobs:
            if job.cancelled:
                job.finish(error=DeviceUnavailableError("the command was cancelled"))
                cancelled.append(job)
                continue
            self.controllers[job.device].start(job, t)
        controllers = list(self.controllers.values())
        if report is not None and jobs:
            done = cancelled + self._collect(controllers)
            if within and all(self.kinds[job.device] == "sensor" for job in jobs):
                if done:  # only readings, answered at once: the world is as the snapshot of
                    report(done, self.snapshot)  # the batch before shows it (the same time)
            else:
                self._report(report, done)
            cancelled = []
        active = [ctrl for ctrl in controllers if ctrl.active]
        recorder, nstep = self.recorder, self.steps_per_tick
        contacts = self.robot_contacts
        due = math.inf if recorder is None else recorder.next_sample
        for _ in range(ticks):
            if active:
                t = float(d.time)
                for ctrl in active:
                    ctrl.tick(t)
                if any(ctrl.finished for ctrl in active):  # only then may one turn idle
                    if report is not None:
                        self._report(report, self._collect(active))
                    active = [ctrl for ctrl in active if ctrl.active]
            mujoco.mj_step(m, d, nstep=nstep)
            contacts.check(m, d)
            if d.time + 1e-9 >= due:
                assert recorder is not None
                recorder.sample(m, d)
                due = recorder.next_sample
            if wake is not None and report is not None and wake(float(d.time)):
                self._report(report, [], woken=True)
        check_state(m, d, max_acceleration=self.max_acceleration)
        finished = cancelled + self._collect(controllers)
        if report is None:
            return finished
        if finished or publish:
            self.snapshot = self._snapshot()  # a batch ends with a snapshot for the loop
            report(finished, self.snapshot)
        return []

    def take_snapshot(self) -> Snapshot:
        """Take a snapshot of the world now and keep it as the latest."""
        self.snapshot = self._snapshot()
        return self.snapshot

    def _collect(self, controllers: list[Controller]) -> list[Job]:
        """Take the jobs ``controllers`` finished (their outcomes logged)."""
        finished: list[Job] = []
        for ctrl in controllers:
            if ctrl.finished:
                if self.recorder is not None:
                    for job in ctrl.finished:
                        self._log_outcome(self.recorder, ctrl, job)
                finished += ctrl.finished
                ctrl.finished = []
        return finished

    def _report(
        self, report: Callable[[list[Job], Snapshot], None], jobs: list[Job], woken: bool = False
    ) -> None:
        """Hand finished ``jobs`` over now (if any, or ``woken``): the state checked, with a
        snapshot of it."""
        if jobs or woken:
            check_state(self.model, self.data, max_acceleration=self.max_acceleration)
            self.snapshot = self._snapshot()
            report(jobs, self.snapshot)

    def _log_outcome(self, recorder: Recorder, ctrl: Controller, job: Job) -> None:
        what = type(job.command).__name__
        if job.error is None:
            recorder.log_text(self.time, ctrl.key[0], f"{ctrl.label}: {what} done")
        else:
            text = f"{ctrl.label}: {what} failed: {job.error}"
            recorder.log_text(self.time, ctrl.key[0], text, level="WARN")

    def _snapshot(self) -> Snapshot:
        d = self.data
        states = {}
        for key, ctrl in self.controllers.items():
            state = ctrl.capture()
            if state is not None:
                states[key] = state
        labels, dofs = self._free
        velocity = d.qvel[dofs]
        speed = np.sqrt((velocity * velocity).sum(axis=1)) if len(labels) else np.zeros(0)
        speeds = dict(zip(labels, speed.tolist(), strict=True))
        attached = frozenset(
            ctrl.grasp.attached
            for ctrl in self.controllers.values()
            if isinstance(ctrl, GripperController) and ctrl.grasp.attached
        )
        return Snapshot(
            time=float(d.time),
            states=DeviceStates(states),
            body_pos=d.xpos.copy(),
            body_quat=d.xquat.copy(),
            ctrl=d.ctrl.copy(),
            speeds=speeds,
            attached=attached,
        )

    def contacts(self) -> list[tuple[str, str, float]]:
        """Bodies in contact now: (body 1, body 2, normal force in N), a copy."""
        m, d = self.model, self.data
        found = []
        force = np.zeros(6)
        for i in range(d.ncon):
            con = d.contact[i]
            mujoco.mj_contactForce(m, d, i, force)
            b1, b2 = m.body(m.geom_bodyid[con.geom1]).name, m.body(m.geom_bodyid[con.geom2]).name
            found.append((str(b1), str(b2), float(force[0])))
        return found
