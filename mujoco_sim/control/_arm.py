"""The arm controller (simulation thread): joint moves, tool moves, grasp watching.

- ``MoveJoints``: a minimum-jerk trajectory from the present set-points to the target, over
  ``duration`` (default: 1 rad/s peak on the joint that moves most, at least 0.4 s).
- ``MoveTcp`` with ``straight``: the tool follows the line (and the slerp of orientations)
  from the set-point pose to the target with a minimum-jerk time law; each control tick
  :class:`~mujoco_sim.motion.TcpTracker` solves IK for the next point (base joints
  too with ``whole_body``, the base then belongs to the arm until the motion ends; the points
  of the next ticks are worked out together, which gives the same set-points at a lower cost).
  If the tracker loses the path, a full DLS solve takes over for that tick; if that fails too,
  the arm halts at that tick and the motion fails with :class:`UnreachableError`. Without
  ``straight``: a joint move to the IK solution the driver computed (``MoveTcp.final``).
- Every joint move is routed first (:class:`~mujoco_sim.motion.JointRouter`): its
  straight joint path is checked for collisions of the arm with itself and the robot's base;
  if it collides, another IK solution of the tool target or a detour through the rest posture
  (one segment after the other), else :class:`CollisionError` before anything moves.
- Completion: set-points at the target, then the joints within 0.01 rad and slow; otherwise
  :class:`MotionTimeoutError` 2 s (simulated) after the trajectory's end.
- A fixed robot (no base controller: :class:`NoBase`) moves its arm alone; its tracker's
  model stands where the robot stands, so tool targets stay in the world frame.
- A motion started while the gripper holds something fails with :class:`GraspLostError` as
  soon as the gripper no longer holds it (the arm halts).
"""

from __future__ import annotations

import difflib
import math
from collections import deque
from collections.abc import Callable
from functools import partial
from typing import TYPE_CHECKING, Any

import mujoco
import numpy as np

from device_drivers import (
    ArmState,
    CommandError,
    DeviceBusyError,
    DeviceKey,
    GraspLostError,
    MotionTimeoutError,
    Pose2D,
    UnreachableError,
)
from device_drivers.protocol import MoveJoints, MoveTcp
from mujoco_sim.control._job import Controller, Job
from mujoco_sim.motion._joint_route import JointRouter, TimedRoute
from mujoco_sim.motion._math import PEAK_SPEED, minjerk, pose_of, quat_angle, quat_wxyz, tcp_target
from mujoco_sim.motion._tcp_tracker import TcpTracker
from scenario import RobotSpec, robot_layout

if TYPE_CHECKING:
    from mujoco_sim.control._base import BaseController
    from mujoco_sim.control._gripper import GripperController

__all__ = ["ArmController", "NoBase"]

_JOINT_SPEED = 1.0  # peak joint speed of a default-duration move, rad/s
_ANGULAR_SPEED = 1.0  # peak tool rotation speed of a straight move, rad/s
_SETTLE = 2.0  # s after the trajectory's end before MotionTimeoutError
_TRACK_POS, _TRACK_ROT = 2e-3, 0.02  # tracker residual that hands a tick to the full solver
_JUMP = 0.15  # largest set-point change per tick, rad: more means a branch flip
_AHEAD = 25  # ticks of a straight move worked out at once (see ArmController._line)


class NoBase:
    """The base of a fixed robot: no joints, never busy (what :class:`ArmController` reads of
    a :class:`~mujoco_sim.control.BaseController`)."""

    def __init__(self) -> None:
        self.acts = self.qadr = np.zeros(0, dtype=np.intp)
        self.job: Job | None = None
        self.owner = ""
        self.label = "no base"

    def hold(self) -> None:
        """Nothing to hold."""


class ArmController(Controller):
    def __init__(
        self,
        key: DeviceKey,
        label: str,
        model: Any,
        data: Any,
        spec: RobotSpec,
        gripper: GripperController,
        base: BaseController | None,
        *,
        at: Pose2D | None = None,
    ) -> None:
        """``base``: the robot's base controller (None: a fixed robot, built ``at`` its pose
        for the tracker; whole-body motions then move the arm alone)."""
        super().__init__(key, label)
        self.m, self.d = model, data
        layout = robot_layout(spec)
        self.prefix = layout.prefix
        self.joints = layout.arm_joints
        self.short = tuple(j.removeprefix(self.prefix) for j in self.joints)
        self.acts = np.array([model.actuator(j).id for j in self.joints])
        self.qadr = np.array([model.jnt_qposadr[model.joint(j).id] for j in self.joints])
        self.dadr = np.array([model.jnt_dofadr[model.joint(j).id] for j in self.joints])
        self.range = np.array([model.jnt_range[model.joint(j).id] for j in self.joints])
        self.site = model.site(layout.tcp_site).id
        self.gripper = gripper
        self.base: BaseController | NoBase = NoBase() if base is None else base
        self.tracker = TcpTracker(spec, at=at)
        rest = spec.mjcf.home if spec.mjcf is not None else [0.0] * len(self.joints)
        self.router = JointRouter(self.tracker.model, layout, rest, label=label)
        self.fallback = self.router.ik  # on the tracker's model too: one private robot model
        self.timestep = float(model.opt.timestep)
        self.plan: dict[str, Any] = {}

    # ------------------------------------------------------------------ start
    def begin(self, job: Job, t: float) -> None:
        cmd, n = job.command, self.tracker.n_base
        q0 = np.concatenate([self.d.ctrl[self.base.acts], self.d.ctrl[self.acts]])
        q1, duration, goal = q0.copy(), None, None
        if isinstance(cmd, MoveJoints):
            for name, value in cmd.target.items():
                q1[n + self._index(name)] = value
            self._check_limits(q1[n:])
            duration = cmd.duration
        elif not isinstance(cmd, MoveTcp):
            raise CommandError(f"{self.label} (an arm) cannot {type(cmd).__name__}")
        elif cmd.whole_body and (self.base.job is not None or self.base.owner):
            raise DeviceBusyError(f"{self.base.label} is busy; whole-body motion needs it")
        elif not cmd.straight:  # to the driver's IK solution, or another (see JointRouter)
            first = 0 if cmd.whole_body else n
            chain = zip(self.tracker.chain[first:], q1[first:], strict=True)
            q1[first:] = [cmd.final.get(j, q) for j, q in chain]
            goal = tcp_target(cmd.target)
        whole = isinstance(cmd, MoveTcp) and cmd.whole_body
        if isinstance(cmd, MoveTcp) and cmd.straight:
            self._line_plan(cmd)
        else:
            path = TimedRoute(q0, self.router.route(q0, q1, goal), duration, _JOINT_SPEED)
            self.plan = {"kind": "joints", "path": path, "T": path.period, "whole_body": whole}
        if whole:
            self.base.owner = self.label
        self.plan["holding"] = self.gripper.holding

    def _index(self, name: str) -> int:
        short = name.removeprefix(self.prefix)
        if short in self.short:
            return self.short.index(short)
        close = difflib.get_close_matches(short, self.short, n=1)
        hint = f"did you mean {close[0]!r}?" if close else f"joints: {list(self.short)}"
        raise CommandError(f"{self.label} has no joint {name!r}; {hint}")

    def _check_limits(self, q: np.ndarray[Any, Any]) -> None:
        for name, value, (lo, hi) in zip(self.short, q, self.range, strict=True):
            if not lo - 1e-9 <= value <= hi + 1e-9:
                raise CommandError(
                    f"{self.label}: {name} = {value:.3f} rad is outside its limits "
                    f"[{lo:.2f}, {hi:.2f}]"
                )

    def _line_plan(self, cmd: MoveTcp) -> None:
        q = np.concatenate([self.d.ctrl[self.base.acts], self.d.ctrl[self.acts]])
        p0, r0 = self.tracker.fk(q)
        quat0 = np.zeros(4)
        mujoco.mju_mat2Quat(quat0, r0.ravel())
        target = cmd.target
        p1, quat1 = np.array([target.x, target.y, target.z]), quat_wxyz(target)
        length, angle = float(np.linalg.norm(p1 - p0)), quat_angle(quat0, quat1)
        period = max(0.3, PEAK_SPEED * length / cmd.speed, PEAK_SPEED * angle / _ANGULAR_SPEED)
        turn = np.zeros(3)  # quat0 * quat(turn) = quat1, the shorter way: slerp is quat(f turn)
        mujoco.mju_subQuat(turn, quat1, quat0)
        self.plan = {"kind": "line", "q": q, "p0": p0, "p1": p1, "quat0": quat0, "quat1": quat1}
        self.plan.update(T=period, whole_body=cmd.whole_body, q1=None, dp=p1 - p0, turn=turn)
        self.plan.update(ahead=deque(), applied=q, last_t=None)  # see _line

    # ------------------------------------------------------------------ ticks
    def update(self, job: Job, t: float) -> None:
        plan = self.plan
        held = plan["holding"]
        if held and self.gripper.holding != held:
            raise GraspLostError(f"{self.gripper.label} lost {held} while {self.label} moved")
        s = (t - self.started_at) / plan["T"]
        job.progress = 0.95 * min(s, 1.0)
        if plan["kind"] == "joints":
            q = plan["path"].at(t - self.started_at)
            self.d.ctrl[self.acts] = q[self.tracker.n_base :]
            if plan["whole_body"]:
                self.d.ctrl[self.base.acts] = q[: self.tracker.n_base]
        elif plan["q1"] is None:
            self._line(plan, t)
        if s < 1.0:
            return
        error = np.abs(self.d.qpos[self.qadr] - self.d.ctrl[self.acts])
        still = float(np.abs(self.d.qvel[self.dadr]).max()) < 0.05
        if self.base.owner == self.label:  # whole body: the base must be there too
            base_error = np.abs(self.d.qpos[self.base.qadr] - self.d.ctrl[self.base.acts])
            still = still and float(base_error.max(initial=0.0)) < 0.003
        if float(error.max()) < 0.01 and still:
            self.done(job)
        elif t - self.started_at > plan["T"] + _SETTLE:
            worst = int(np.argmax(error))
            raise MotionTimeoutError(
                f"{self.label}: {self.short[worst]} is {error[worst]:.3f} rad from its target "
                f"{_SETTLE:g} s after the trajectory ended (blocked, or overloaded?)"
            )

    def _line(self, plan: dict[str, Any], t: float) -> None:
        """Set this tick's point of a straight move. Its points depend only on the path and
        the tick times (the tracker starts each from the one before), so once the tick period
        is known they are worked out :data:`_AHEAD` ticks at a time: the same numbers, at a
        fraction of the cost of one per tick between physics steps, which leave the caches
        cold. A tick at another time than the one worked out for drops them."""
        ahead: deque[tuple[float, Any, bool, UnreachableError | None]] = plan["ahead"]
        if ahead and abs(ahead[0][0] - t) > 1e-9:  # (a held motion's clock has a lag)
            ahead.clear()
            plan["q"] = plan["applied"]
        if not ahead:
            self._work_out(plan, t)
        _, q, done, error = ahead.popleft()
        if error is not None:
            raise error
        n = self.tracker.n_base
        self.d.ctrl[self.acts] = q[n:]
        if plan["whole_body"]:
            self.d.ctrl[self.base.acts] = q[:n]
        plan["applied"], plan["last_t"] = q, t
        if done:
            plan["q1"] = q

    def _work_out(self, plan: dict[str, Any], t: float) -> None:
        """Queue the points of the ticks from ``t`` on (one if the tick period is unknown),
        up to the end of the path or an error, with their tick times computed as MuJoCo
        advances ``data.time`` (one ``timestep`` per step)."""
        steps = 0 if plan["last_t"] is None else round((t - plan["last_t"]) / self.timestep)
        for k in range(_AHEAD if steps > 0 else 1):
            for _ in range(steps if k else 0):
                t += self.timestep
            s = (t - self.started_at) / plan["T"]
            try:
                q = self._track(plan, minjerk(s), done=s >= 1.0)
            except UnreachableError as error:
                plan["ahead"].append((t, None, False, error))
                return
            plan["ahead"].append((t, q, s >= 1.0, None))
            if s >= 1.0:
                return

    def _track(self, plan: dict[str, Any], f: float, *, done: bool) -> Any:
        """The next point of a straight move (at path fraction ``f``), from the one before."""
        pos = plan["p0"] + f * plan["dp"]
        quat = plan["quat0"].copy()  # slerp(quat0, quat1, f), in two MuJoCo calls
        mujoco.mju_quatIntegrate(quat, plan["turn"], f)
        flat = np.empty(9)
        mujoco.mju_quat2Mat(flat, quat)
        rot = flat.reshape(3, 3)
        whole = plan["whole_body"]
        iterations = 4 if done else 1  # converge exactly on the last point
        q, pos_err, rot_err = self.tracker.step(
            plan["q"], pos, rot, whole_body=whole, iterations=iterations
        )
        if pos_err > _TRACK_POS or rot_err > _TRACK_ROT or np.abs(q - plan["q"]).max() > _JUMP:
            q = self._full_solve(plan["q"], pos, rot, whole)
        plan["q"] = q
        return q

    def _full_solve(self, q: Any, pos: Any, rot: Any, whole: bool) -> Any:
        quat = np.zeros(4)
        mujoco.mju_mat2Quat(quat, rot.ravel())
        q0 = dict(zip(self.tracker.chain, q, strict=True))
        try:
            result = self.fallback.solve(q0, tcp_target(pose_of(pos, quat)), whole_body=whole)
        except UnreachableError as exc:
            raise UnreachableError(
                position_error=exc.position_error,
                orientation_error=exc.orientation_error,
                iterations=exc.iterations,
                solver="tracker+dls",
                joints=exc.joints,
                whole_body=whole,
            ) from None
        q_new = np.array(
            [result.joints.get(j, v) for j, v in zip(self.tracker.chain, q, strict=True)]
        )
        if np.abs(q_new - q).max() > 3 * _JUMP:
            raise UnreachableError(
                position_error=math.nan,
                orientation_error=math.nan,
                iterations=result.iterations,
                solver="tracker+dls",
                joints=result.joints,
                whole_body=whole,
            )
        return q_new

    # ------------------------------------------------------------------ hooks
    def done(self, job: Job, result: Any = None, error: BaseException | None = None) -> None:
        if job is self.job and self.base.owner == self.label:
            self.base.owner = ""
        super().done(job, result, error)

    def hold(self) -> None:
        self.d.ctrl[self.acts] = self.d.qpos[self.qadr]
        if self.base.owner == self.label:
            self.base.hold()

    def settled(self) -> bool:
        return float(np.abs(self.d.qvel[self.dadr]).max()) < 0.02

    def state(self) -> ArmState:
        return self.capture()()

    def capture(self) -> Callable[[], ArmState]:
        d, site = self.d, self.site
        copies = (d.qpos[self.qadr], d.site_xpos[site].copy(), d.site_xmat[site].copy())
        return partial(_arm_state, self.short, *copies, self.job is not None)


def _arm_state(
    short: tuple[str, ...], q: Any, tcp_pos: Any, tcp_mat: Any, moving: bool
) -> ArmState:
    quat = np.zeros(4)
    mujoco.mju_mat2Quat(quat, tcp_mat)
    return ArmState(
        joints={n: float(v) for n, v in zip(short, q, strict=True)},
        tcp=pose_of(tcp_pos, quat),
        moving=moving,
    )
