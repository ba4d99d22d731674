"""IK with placo's QP kinematics solver (joint limits as hard constraints).

The robot is exported with :func:`mujoco_sim.placo_ik.load_placo_robot` (a dummy
floating base ``ik_root`` that stays masked, so placo's joint limits cover every real joint).
Per solve: a soft position task on the tcp frame (weight 1), a soft orientation task (full
orientation) or axis-align task (approach axis, rotation about it free) (weight 1), the
regularisation task (``IKOptions.regularization``, 1e-3: keeps a far start from stalling
against joint limits; it fades quadratically once the error score is below 5 cm, or the last
millimetres converge linearly near singular configurations), the base joints masked unless
``whole_body``, every joint outside the chain (e.g. fingers) masked. One ``solve(True)`` is
one QP step; :func:`mujoco_sim.ik.solve_with_restarts` repeats it until converged.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from typing import Any

import mujoco
import numpy as np

from device_drivers import IKError
from mujoco_sim.ik._chain import ChainSolver
from mujoco_sim.ik._core import (
    FloatArray,
    IKOptions,
    IKResult,
    TcpTarget,
    gather,
    orientation_error,
    quat_to_matrix,
    random_configurations,
    solve_with_restarts,
)
from mujoco_sim.placo_ik._export import IK_ROOT, load_placo_robot
from mujoco_sim.placo_ik._import import placo

__all__ = ["PlacoIK"]

_FADE = 0.05  # below this error score (m), the regularisation weight fades quadratically


class PlacoIK(ChainSolver):
    """placo IK for one robot model. ``robot`` is the robot alone as an ``MjSpec``; targets are
    in its world frame (for the generated robots: the world frame of the scene)."""

    name = "placo"

    def __init__(
        self,
        robot: mujoco.MjSpec,
        *,
        tcp_site: str,
        arm_joints: Sequence[str],
        base_joints: Sequence[str] = (),
        options: IKOptions | None = None,
    ) -> None:
        super().__init__(
            robot,
            tcp_site=tcp_site,
            arm_joints=arm_joints,
            base_joints=base_joints,
            options=options,
        )
        self._tcp = tcp_site
        # placo objects: untyped (Any) from here on; they never leave this instance.
        self._robot: Any = load_placo_robot(robot)
        model: Any = self._robot.model
        frames = set(self._robot.frame_names())
        if tcp_site not in frames:
            raise IKError(f"placo: no frame {tcp_site!r} in the exported model")
        known = set(self._robot.joint_names())
        missing = [j for j in self.chain if j not in known]
        if missing:
            raise IKError(f"placo: unknown joints {missing}; the model has {sorted(known)}")
        self._solver: Any = placo.KinematicsSolver(self._robot)
        self._solver.mask_fbase(True)  # the dummy ik_root free joint
        self._solver.enable_joint_limits(True)
        self._regularization = self._solver.add_regularization_task(self.options.regularization)
        for joint in known - set(self.chain) - {IK_ROOT}:
            self._solver.mask_dof(joint)
        offsets = [self._robot.get_joint_offset(j) for j in self.chain]
        self._lower = np.array([model.lowerPositionLimit[i] for i in offsets], dtype=np.float64)
        self._upper = np.array([model.upperPositionLimit[i] for i in offsets], dtype=np.float64)
        n_base = len(self.base_joints)
        self._arm_restarts = random_configurations(
            self._lower[n_base:], self._upper[n_base:], self.options.restarts, self.options.seed
        )

    def tcp_pose(self, q: Mapping[str, float]) -> tuple[FloatArray, FloatArray]:
        """placo's forward kinematics: tcp position (m) and rotation matrix, model frame."""
        self._set(gather(q, self.chain, self.name))
        return self._tcp_pose()

    def solve(
        self, q0: Mapping[str, float], target: TcpTarget, *, whole_body: bool = False
    ) -> IKResult:
        """Joint values that put the tcp on ``target``, starting from ``q0`` (see ``IKSolver``)."""
        q_chain = gather(q0, self.chain, self.name)
        n_base = len(self.base_joints)
        active = slice(0, None) if whole_body else slice(n_base, None)
        for joint in self.base_joints:
            (self._solver.unmask_dof if whole_body else self._solver.mask_dof)(joint)
        restarts = self._arm_restarts
        if whole_body:
            restarts = [np.concatenate([q_chain[:n_base], r]) for r in restarts]
        tasks = self._add_tasks(target)
        try:
            return solve_with_restarts(
                solver=self.name,
                names=self.chain[active],
                start=q_chain[active],
                restarts=restarts,
                problem=_PlacoProblem(self, q_chain, active, target),
                options=self.options,
                whole_body=whole_body,
            )
        finally:
            for task in tasks:
                self._solver.remove_task(task)

    def _add_tasks(self, target: TcpTarget) -> list[Any]:
        position = self._solver.add_position_task(self._tcp, np.asarray(target.position, float))
        position.configure("tcp_position", "soft", 1.0)
        tasks = [position]
        if target.quat is not None:
            orient = self._solver.add_orientation_task(self._tcp, quat_to_matrix(target.quat))
            orient.configure("tcp_orientation", "soft", 1.0)
            tasks.append(orient)
        elif target.approach is not None:
            axis = np.asarray(target.approach, float) / np.linalg.norm(target.approach)
            align = self._solver.add_axisalign_task(self._tcp, np.array([0.0, 0.0, 1.0]), axis)
            align.configure("tcp_approach", "soft", 1.0)
            tasks.append(align)
        return tasks

    def _set(self, q: FloatArray) -> None:
        for name, value in zip(self.chain, q, strict=True):
            self._robot.set_joint(name, float(value))
        self._robot.update_kinematics()

    def _get(self) -> FloatArray:
        return np.array([self._robot.get_joint(n) for n in self.chain], dtype=np.float64)

    def _tcp_pose(self) -> tuple[FloatArray, FloatArray]:
        t = np.asarray(self._robot.get_T_world_frame(self._tcp), dtype=np.float64)
        return t[:3, 3].copy(), t[:3, :3].copy()


class _PlacoProblem:
    """One solve of :class:`PlacoIK` (its tasks are in place while this runs)."""

    def __init__(self, ik: PlacoIK, q_chain: FloatArray, active: slice, target: TcpTarget) -> None:
        self._ik, self._q, self._active, self._target = ik, q_chain.copy(), active, target
        self._goal = np.asarray(target.position, dtype=np.float64)
        self._errs = (np.inf, np.inf)

    def reset(self, q: FloatArray) -> tuple[float, float]:
        self._q[self._active] = q
        self._ik._set(np.clip(self._q, self._ik._lower, self._ik._upper))
        return self._errors()

    def step(self) -> tuple[float, float]:
        # Levenberg-Marquardt-like: full regularisation far away (no stalling against limits
        # from a far start), fading near the target (no slow tail near singularities).
        score = self._errs[0] + 0.1 * self._errs[1]
        weight = self._ik.options.regularization * min(1.0, (score / _FADE) ** 2)
        self._ik._regularization.configure("regularization", "soft", max(weight, 1e-9))
        self._ik._solver.solve(True)
        self._ik._robot.update_kinematics()
        return self._errors()

    def current(self) -> FloatArray:
        return self._ik._get()[self._active]

    def _errors(self) -> tuple[float, float]:
        pos, rot = self._ik._tcp_pose()
        self._errs = float(np.linalg.norm(self._goal - pos)), orientation_error(self._target, rot)
        return self._errs
