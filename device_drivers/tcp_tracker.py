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

from device_drivers.ik import rotation_error_vector
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
        self._jacp = np.zeros((3, self._model.nv))
        self._jacr = np.zeros((3, self._model.nv))

    def fk(self, q: Array) -> tuple[Array, Array]:
        """Tool position and rotation matrix at chain configuration ``q`` (copies)."""
        self._data.qpos[self._qadr] = q
        mujoco.mj_kinematics(self._model, self._data)
        mujoco.mj_comPos(self._model, self._data)  # cdof, which mj_jacSite reads
        site = self._site
        return self._data.site_xpos[site].copy(), self._data.site_xmat[site].reshape(3, 3).copy()

    def step(
        self,
        q: Array,
        position: Array,
        rotation: Array,
        *,
        whole_body: bool,
        iterations: int = 4,
        tolerance: float = 5e-5,
    ) -> tuple[Array, float, float]:
        """Move ``q`` towards the tool pose (``position``, ``rotation`` matrix); return the new
        configuration and its position (m) and orientation (rad) errors."""
        q = q.copy()
        active = slice(0, None) if whole_body else slice(self.n_base, None)
        weights = np.ones(len(self.chain))[active]
        if whole_body:
            weights[: self.n_base] = _BASE_WEIGHT
        pos_err = rot_err = math.inf
        for _ in range(iterations):
            pos, rot = self.fk(q)
            e_pos = position - pos
            e_rot = rotation_error_vector(rotation, rot)
            pos_err, rot_err = float(np.linalg.norm(e_pos)), float(np.linalg.norm(e_rot))
            if pos_err < tolerance and rot_err < 10 * tolerance:
                break
            mujoco.mj_jacSite(self._model, self._data, self._jacp, self._jacr, self._site)
            jac = np.vstack([self._jacp, self._jacr])[:, self._dadr[active]] * weights
            err = np.concatenate([e_pos, e_rot])
            dq = jac.T @ np.linalg.solve(jac @ jac.T + _DAMPING**2 * np.eye(6), err)
            q[active] = np.clip(q[active] + weights * dq, self.lower[active], self.upper[active])
        else:
            pos, rot = self.fk(q)
            pos_err = float(np.linalg.norm(position - pos))
            rot_err = float(np.linalg.norm(rotation_error_vector(rotation, rot)))
        return q, pos_err, rot_err
