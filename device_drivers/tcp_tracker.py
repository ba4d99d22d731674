"""Resolved-rate IK for straight tool paths: a few damped-least-squares iterations per control
tick, from the previous set-points to the next point of the path.

Why not a full solver per tick: :class:`~device_drivers.ik_placo.PlacoIK` costs ~0.5 ms per
call here (mostly its generic restart loop), four times the physics of a control tick; this
tracker costs ~0.05-0.1 ms because each tick starts a few millimetres from its target. The full
solvers still check the end pose before a motion starts (placo, then DLS as fallback) and take
over when the tracker loses the path (:meth:`TcpTracker.step` reports the residual).

The tracker owns a compiled model of the robot alone (base joints = world coordinates) and its
own ``MjData``: use one instance per thread (the simulation thread).
"""

from __future__ import annotations

import math

import mujoco
import numpy as np

from device_drivers.motion_math import Array
from device_drivers.robot_model import build_robot
from device_drivers.robot_spec import RobotSpec, robot_layout

__all__ = ["TcpTracker"]

_DAMPING = 0.01
_BASE_WEIGHT = 0.35  # whole body: base columns scaled down, so the arm does most of the work


class TcpTracker:
    """Tool-path tracking for robot ``spec`` (see module doc). Vectors are ordered
    ``chain`` = base joints then arm joints (full names)."""

    def __init__(self, spec: RobotSpec) -> None:
        layout = robot_layout(spec)
        self.chain = layout.base_joints + layout.arm_joints
        self.n_base = len(layout.base_joints)
        self._model = build_robot(spec).compile()
        self._data = mujoco.MjData(self._model)
        joints = [self._model.joint(name).id for name in self.chain]
        self._qadr = np.array([self._model.jnt_qposadr[j] for j in joints])
        self._dadr = np.array([self._model.jnt_dofadr[j] for j in joints])
        limited = np.array([bool(self._model.jnt_limited[j]) for j in joints])
        ranges = np.array([self._model.jnt_range[j] for j in joints])
        self.lower = np.where(limited, ranges[:, 0], -np.inf)
        self.upper = np.where(limited, ranges[:, 1], np.inf)
        self._site = self._model.site(layout.tcp_site).id
        self._jac = np.zeros((6, self._model.nv))  # rows: translation, rotation
        self._damping = _DAMPING**2 * np.eye(6)
        self._weights_arm = np.ones(len(self.chain) - self.n_base)
        self._weights_wb = np.ones(len(self.chain))
        self._weights_wb[: self.n_base] = _BASE_WEIGHT

    def fk(self, q: Array) -> tuple[Array, Array]:
        """Tool position and rotation matrix at chain configuration ``q`` (copies)."""
        pos, rot = self._kinematics(q)
        return pos.copy(), rot.copy()

    def _kinematics(self, q: Array) -> tuple[Array, Array]:
        """Views of the tool pose at ``q`` (valid until the next call)."""
        self._data.qpos[self._qadr] = q
        mujoco.mj_kinematics(self._model, self._data)
        site = self._site
        return self._data.site_xpos[site], self._data.site_xmat[site].reshape(3, 3)

    def step(
        self,
        q: Array,
        position: Array,
        rotation: Array,
        *,
        whole_body: bool,
        iterations: int = 1,
        tolerance: float = 1e-4,
    ) -> tuple[Array, float, float]:
        """Move ``q`` towards the tool pose (``position``, ``rotation`` matrix) by up to
        ``iterations`` damped-least-squares steps; return the new configuration and its
        position (m) and orientation (rad) errors: measured if it converged, else the
        linear prediction of the last step (one step per tick is the resolved-rate scheme;
        its second-order error is micrometres at the path speeds used here)."""
        q = q.copy()
        active = slice(0, None) if whole_body else slice(self.n_base, None)
        weights = self._weights_wb if whole_body else self._weights_arm
        residual = np.full(6, math.inf)
        for _ in range(iterations):
            pos, rot = self._kinematics(q)
            err = np.concatenate([position - pos, _rotation_error(rotation, rot)])
            pos_err, rot_err = float(np.linalg.norm(err[:3])), float(np.linalg.norm(err[3:]))
            if pos_err < tolerance and rot_err < 10 * tolerance:
                return q, pos_err, rot_err
            mujoco.mj_comPos(self._model, self._data)  # cdof, which mj_jacSite reads
            mujoco.mj_jacSite(self._model, self._data, self._jac[:3], self._jac[3:], self._site)
            jac = self._jac[:, self._dadr[active]] * weights
            dq = jac.T @ np.linalg.solve(jac @ jac.T + self._damping, err)
            moved = np.clip(q[active] + weights * dq, self.lower[active], self.upper[active])
            residual = err - jac @ ((moved - q[active]) / weights)
            q[active] = moved
        return q, float(np.linalg.norm(residual[:3])), float(np.linalg.norm(residual[3:]))


def _rotation_error(goal: Array, current: Array) -> Array:
    """Rotation vector taking ``current`` to ``goal`` for the small errors of tracking:
    ``½ Σ current_i × goal_i`` over the frame axes (sin θ · axis; exact direction, and within
    1 % of θ below 0.25 rad)."""
    m = current @ goal.T  # m[a, b] = sum_i current[a, i] goal[b, i]
    return 0.5 * np.array([m[1, 2] - m[2, 1], m[2, 0] - m[0, 2], m[0, 1] - m[1, 0]])
