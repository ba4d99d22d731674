"""A scenario's MuJoCo world posed from what the mesh reports, for a recording made elsewhere.

``skimesh monitor`` runs on any host and has no physics: :class:`Mirror` builds the scenario's
model (the same :class:`~mujoco_sim.Plant` ``skimesh sim`` builds, never stepped) and poses it
from the devices' published states and the objects' poses, then hands it to a
:class:`~mujoco_sim.recording.Recorder` like a running world would: same geometry, same
``world/<body>`` entities, same ``robots/<robot>/joints`` plots.

- a base state (``Pose2D``) sets the base's x, y, yaw joints (their positions *are* world
  coordinates); an arm state its joints (short names, ``<robot>/`` prefixed in the model);
- a gripper state's opening sets the generated gripper's fingers (half the opening each) and
  is what ``robots/<robot>/joints`` plots; a gripper from a file keeps its fingers where they
  start (its four-bar linkage is closed by the physics, which does not run here);
- an appliance state's door angle sets its door hinge;
- an object's world pose sets its free joint (objects without one stay where they stand).

Threads: the ``set_*`` methods only store values (under a lock: call them from the event
loop); :meth:`Mirror.sample` writes them into the model's data, runs the kinematics and lets
the recorder sample. Call :meth:`start` and :meth:`sample` from one thread at a time (a worker
thread in async code).
"""

from __future__ import annotations

from collections.abc import Mapping
from functools import partial
from threading import Lock
from typing import Any

import mujoco

from device_drivers import ApplianceState, BaseState, GripperState, Pose2D, WorldPose
from device_drivers.protocol import (
    ApplianceStateReply,
    ArmStateReply,
    BaseStateReply,
    GripperStateReply,
    StateMessage,
)
from mujoco_sim._plant import Plant
from mujoco_sim.control import TendonDrive
from scenario import Scenario, robot_layout

from ._recorder import Recorder, RobotSeries

__all__ = ["Mirror"]


class Mirror:
    """The world of ``scenario`` posed from reported states (see the module doc)."""

    def __init__(self, scenario: Scenario) -> None:
        self.scenario = scenario
        self.plant = Plant(scenario)
        self.model: Any = self.plant.model
        self.data: Any = self.plant.data
        m = self.model
        self._qadr: dict[str, int] = {}
        self._bases: dict[str, tuple[int, int, int]] = {}
        self._arms: dict[str, str] = {}  # robot -> joint name prefix
        for robot in scenario.robots:
            layout = robot_layout(robot.spec)
            self._arms[robot.name] = f"{robot.name}/"
            if len(layout.base_joints) == 3:
                x, y, yaw = (self._adr(j) for j in layout.base_joints)
                self._bases[robot.name] = (x, y, yaw)
        self.openings: dict[str, float] = {
            r.name: float(d.opening(self.data)) for r, d in self._drives()
        }
        self._free: dict[str, int] = {}
        for label in self.plant.facts.objects:
            body = m.body(label)
            if body.jntnum[0] and m.jnt_type[body.jntadr[0]] == mujoco.mjtJoint.mjJNT_FREE:
                self._free[label] = int(m.jnt_qposadr[body.jntadr[0]])
        self._doors = {
            a.label: self._adr(f"{a.label}/door")
            for a in scenario.appliances
            if mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_JOINT, f"{a.label}/door") >= 0
        }
        self._lock = Lock()
        self._pending: dict[int, float] = {}  # qpos address -> value, written by sample()
        self._poses: dict[str, WorldPose] = {}
        self.applied = 0
        """States and poses taken so far (for checks)."""

    def _adr(self, joint: str) -> int:
        return int(self.model.jnt_qposadr[self.model.joint(joint).id])

    def _drives(self) -> list[tuple[Any, Any]]:
        return [(r, self.plant.drives[r.name]) for r in self.scenario.robots]

    @property
    def objects(self) -> list[str]:
        """The objects whose poses the mirror takes (those with a free joint)."""
        return sorted(self._free)

    def series(self) -> list[RobotSeries]:
        """What the recorder plots per robot: the plant's joints, the reported opening."""
        return [
            RobotSeries(s.name, s.joints, partial(self._opening, s.name))
            for s in self.plant.series()
        ]

    def _opening(self, robot: str, _data: Any) -> float:
        return self.openings[robot]

    # ------------------------------------------------------------------ taking states
    def set_base(self, robot: str, pose: Pose2D) -> None:
        if robot in self._bases:
            with self._lock:
                values = (pose.x, pose.y, pose.yaw)
                self._pending.update(zip(self._bases[robot], values, strict=True))
            self.applied += 1

    def set_arm(self, robot: str, joints: Mapping[str, float]) -> None:
        prefix = self._arms.get(robot)
        if prefix is None:
            return
        taken = {}
        for name, value in joints.items():
            full = name if name.startswith(prefix) else prefix + name
            if mujoco.mj_name2id(self.model, mujoco.mjtObj.mjOBJ_JOINT, full) >= 0:
                taken[self._adr(full)] = value
        with self._lock:
            self._pending.update(taken)
        self.applied += 1

    def set_gripper(self, robot: str, state: GripperState) -> None:
        drive = self.plant.drives.get(robot)
        if drive is None:
            return
        self.openings[robot] = state.opening
        if isinstance(drive, TendonDrive):
            with self._lock:
                self._pending.update((int(adr), state.opening / 2) for adr in drive.fingers)
        self.applied += 1

    def set_appliance(self, label: str, state: ApplianceState) -> None:
        if label in self._doors:
            with self._lock:
                self._pending[self._doors[label]] = state.door_angle
            self.applied += 1

    def set_object(self, label: str, pose: WorldPose) -> None:
        if label in self._free:
            with self._lock:
                self._poses[label] = pose
            self.applied += 1

    def apply(self, owner: str, device: str, message: StateMessage) -> None:
        """A device's published state (``devices/<owner>/<device>/state``)."""
        match message:
            case BaseStateReply(state=BaseState(pose=pose)):
                self.set_base(owner, pose)
            case ArmStateReply(state=state):
                self.set_arm(owner, state.joints)
            case GripperStateReply(state=state):
                self.set_gripper(owner, state)
            case ApplianceStateReply(state=state):
                self.set_appliance(owner, state)

    # ------------------------------------------------------------------ recording
    def start(self, recorder: Recorder, *, cameras: tuple[str, ...] = ()) -> None:
        """Log the geometry and start following (``cameras``: rendered from the mirror)."""
        self._write()
        recorder.start(self.model, self.data, cameras=cameras, robots=self.series())

    def sample(self, recorder: Recorder, time: float) -> None:
        """Pose the model with what was taken, at ``time`` s (never earlier than the last),
        and let ``recorder`` sample it."""
        self._write()
        self.data.time = max(time, float(self.data.time))
        recorder.sample(self.model, self.data)

    def _write(self) -> None:
        with self._lock:
            pending, self._pending = self._pending, {}
            poses, self._poses = self._poses, {}
        for adr, value in pending.items():
            self.data.qpos[adr] = value
        for label, p in poses.items():
            adr = self._free[label]
            self.data.qpos[adr : adr + 7] = (p.x, p.y, p.z, p.qw, p.qx, p.qy, p.qz)
        mujoco.mj_kinematics(self.model, self.data)
