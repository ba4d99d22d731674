"""MuJoCo-native damped-least-squares IK: the fallback solver and the test oracle for placo.

Each iteration runs ``mj_kinematics`` and ``mj_comPos`` (``mj_jacSite`` reads ``cdof``, which
``mj_comPos`` computes: without it the Jacobian is stale or zero), stacks the tcp position rows
and the orientation rows (3 for a full orientation; 2 for an approach axis, the rotation about
the axis being free), takes the step ``dq = Jᵀ (J Jᵀ + λ² I)⁻¹ e`` scaled to at most
``_MAX_STEP`` rad/m per joint, and clamps the joints to their limits. Errors mix metres and
radians with unit weight (1 mrad counts like 1 mm).
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from typing import TypeAlias

import mujoco
import numpy as np
import numpy.typing as npt

from device_drivers import IKError
from mujoco_sim.ik._chain import ChainSolver
from mujoco_sim.ik._core import (
    FloatArray,
    IKOptions,
    IKResult,
    TcpTarget,
    gather,
    quat_to_matrix,
    random_configurations,
    rotation_error_vector,
    solve_with_restarts,
)

__all__ = ["DlsIK"]

IntArray: TypeAlias = npt.NDArray[np.intp]

_MAX_STEP = 0.4  # largest joint change per iteration, rad or m
_FADE = 0.05  # below this error score (m), the damping fades: quadratic convergence at the end
_ONE_DOF = (int(mujoco.mjtJoint.mjJNT_HINGE), int(mujoco.mjtJoint.mjJNT_SLIDE))


class DlsIK(ChainSolver):
    """Damped least squares on a private copy of a MuJoCo model.

    ``robot`` is an ``MjSpec`` (compiled here) or an ``MjModel`` — a robot alone or a whole
    world; targets are in its world frame. ``arm_joints`` / ``base_joints`` must be hinge or
    slide joints; the base joints move only with ``whole_body=True``.
    """

    name = "dls"

    def __init__(
        self,
        robot: mujoco.MjSpec | mujoco.MjModel,
        *,
        tcp_site: str,
        arm_joints: Sequence[str],
        base_joints: Sequence[str] = (),
        options: IKOptions | None = None,
    ) -> None:
        self.options = options or IKOptions()
        self._model = robot.copy().compile() if isinstance(robot, mujoco.MjSpec) else robot
        self._data = mujoco.MjData(self._model)
        self.arm_joints = tuple(arm_joints)
        self.base_joints = tuple(base_joints)
        self._site = self._id(mujoco.mjtObj.mjOBJ_SITE, tcp_site, "site")
        joints = [self._id(mujoco.mjtObj.mjOBJ_JOINT, j, "joint") for j in self.chain]
        bad = [
            n
            for n, j in zip(self.chain, joints, strict=True)
            if int(self._model.jnt_type[j]) not in _ONE_DOF
        ]
        if bad:
            raise IKError(f"dls: only hinge and slide joints are supported, not {bad}")
        self._qadr = np.array([self._model.jnt_qposadr[j] for j in joints])
        self._dadr = np.array([self._model.jnt_dofadr[j] for j in joints])
        limited = np.array([bool(self._model.jnt_limited[j]) for j in joints])
        ranges = np.array([self._model.jnt_range[j] for j in joints])
        self._lower = np.where(limited, ranges[:, 0], -np.inf)
        self._upper = np.where(limited, ranges[:, 1], np.inf)
        n_base = len(self.base_joints)
        self._arm_restarts = random_configurations(
            self._lower[n_base:], self._upper[n_base:], self.options.restarts, self.options.seed
        )
        self._jacp = np.zeros((3, self._model.nv))
        self._jacr = np.zeros((3, self._model.nv))

    def _id(self, kind: int, name: str, what: str) -> int:
        index = int(mujoco.mj_name2id(self._model, kind, name))
        if index < 0:
            raise IKError(f"dls: the model has no {what} named {name!r}")
        return index

    def solve(
        self, q0: Mapping[str, float], target: TcpTarget, *, whole_body: bool = False
    ) -> IKResult:
        """Joint values that put the tcp on ``target``, starting from ``q0`` (see ``IKSolver``)."""
        q_chain = gather(q0, self.chain, self.name)
        n_base = len(self.base_joints)
        active = slice(0, None) if whole_body else slice(n_base, None)
        restarts = self._arm_restarts
        if whole_body:
            restarts = [np.concatenate([q_chain[:n_base], r]) for r in restarts]
        return solve_with_restarts(
            solver=self.name,
            names=self.chain[active],
            start=q_chain[active],
            restarts=restarts,
            problem=_DlsProblem(self, q_chain, active, target),
            options=self.options,
            whole_body=whole_body,
        )

    def _fk(self, q: FloatArray) -> tuple[FloatArray, FloatArray]:
        """Set the chain joints; return the tcp position and rotation matrix (world frame).
        Leaves ``cdof`` up to date for :meth:`_jacobian`."""
        self._data.qpos[self._qadr] = q
        mujoco.mj_kinematics(self._model, self._data)
        mujoco.mj_comPos(self._model, self._data)  # cdof for mj_jacSite
        rot = self._data.site_xmat[self._site].reshape(3, 3).copy()
        return self._data.site_xpos[self._site].copy(), rot

    def _jacobian(self, dofs: IntArray) -> tuple[FloatArray, FloatArray]:
        """Translational and rotational Jacobians of the tcp (world frame), active columns."""
        mujoco.mj_jacSite(self._model, self._data, self._jacp, self._jacr, self._site)
        return self._jacp[:, dofs], self._jacr[:, dofs]


class _DlsProblem:
    """One solve of :class:`DlsIK`: the chain vector with the ``active`` part iterated."""

    def __init__(self, ik: DlsIK, q_chain: FloatArray, active: slice, target: TcpTarget) -> None:
        self._ik, self._q, self._active = ik, q_chain.copy(), active
        self._goal_p = np.asarray(target.position, dtype=np.float64)
        self._goal_r = None if target.quat is None else quat_to_matrix(target.quat)
        self._axis = None
        if target.approach is not None:
            self._axis = np.asarray(target.approach, dtype=np.float64)
            self._axis /= np.linalg.norm(self._axis)
        self._lower, self._upper = ik._lower[active], ik._upper[active]
        self._dofs = ik._dadr[active]
        self._err = np.zeros(3)  # stacked error: position, then orientation rows
        self._basis = np.zeros((2, 3))  # approach mode: the two rotation axes orthogonal to z
        self._score = np.inf

    def reset(self, q: FloatArray) -> tuple[float, float]:
        self._q[self._active] = np.clip(q, self._lower, self._upper)
        return self._errors()

    def step(self) -> tuple[float, float]:
        jp, jr = self._ik._jacobian(self._dofs)
        if self._goal_r is not None:
            jac = np.vstack([jp, jr])
        elif self._axis is not None:
            jac = np.vstack([jp, self._basis @ jr])
        else:
            jac = jp
        lam2 = self._ik.options.damping**2 * min(1.0, (self._score / _FADE) ** 2) + 1e-12
        dq = jac.T @ np.linalg.solve(jac @ jac.T + lam2 * np.eye(len(self._err)), self._err)
        dq *= min(1.0, _MAX_STEP / max(float(np.abs(dq).max()), 1e-12))
        self._q[self._active] = np.clip(self._q[self._active] + dq, self._lower, self._upper)
        return self._errors()

    def current(self) -> FloatArray:
        return self._q[self._active].copy()

    def _errors(self) -> tuple[float, float]:
        pos, rot = self._ik._fk(self._q)
        e_pos = self._goal_p - pos
        pos_err, ori_err = math.sqrt(float(e_pos @ e_pos)), 0.0
        if self._goal_r is not None:
            e_rot = rotation_error_vector(self._goal_r, rot)
            ori_err = math.sqrt(float(e_rot @ e_rot))
            self._err = np.concatenate([e_pos, e_rot])
        elif self._axis is not None:
            z = rot[:, 2]
            cross = np.cross(z, self._axis)  # rotating z about this brings it onto the axis
            sin, cos = math.sqrt(float(cross @ cross)), float(z @ self._axis)
            ori_err = math.atan2(sin, cos)
            self._basis = rot[:, :2].T  # tcp x and y: the rotations that move z
            # aligned (no error) or opposite (turn about any perpendicular axis, here x)
            e_axis = cross * (ori_err / sin) if sin > 1e-9 else rot[:, 0] * ori_err
            self._err = np.concatenate([e_pos, self._basis @ e_axis])
        else:
            self._err = e_pos
        self._score = pos_err + 0.1 * ori_err
        return pos_err, ori_err
