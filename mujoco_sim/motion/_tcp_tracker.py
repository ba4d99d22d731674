"""Resolved-rate IK for straight tool paths: a few damped-least-squares iterations per control
tick, from the previous set-points to the next point of the path.

Why not a full solver per tick: :class:`~mujoco_sim.placo_ik.PlacoIK` costs several times the
physics of a control tick (mostly its generic restart loop); this tracker is much cheaper
because each tick starts a few millimetres from its target (see docs/benchmarks.md, section
Simulation). The full
solvers still check the end pose before a motion starts (placo, then DLS as fallback) and take
over when the tracker loses the path (:meth:`TcpTracker.step` reports the residual).

The tracker owns a compiled model of the robot alone (base joints = world coordinates; a fixed
robot built where it stands) and its own ``MjData``: use one instance per thread (the
simulation thread).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

import mujoco
import numpy as np
import numpy.typing as npt

from device_drivers import Pose2D
from mujoco_sim.models._robot import build_robot
from mujoco_sim.motion._math import Array
from scenario import RobotSpec, robot_layout

__all__ = ["TcpTracker"]

_DAMPING = 0.01
_BASE_WEIGHT = 0.35  # whole body: base columns scaled down, so the arm does most of the work


class TcpTracker:
    """Tool-path tracking for robot ``spec`` (see module doc). Vectors are ordered
    ``chain`` = base joints then arm joints (full names)."""

    def __init__(self, spec: RobotSpec, *, at: Pose2D | None = None) -> None:
        layout = robot_layout(spec)
        self.chain = layout.base_joints + layout.arm_joints
        self.n_base = len(layout.base_joints)
        self._model = build_robot(spec, at=at).compile()  # a fixed robot: where it stands
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

    @property
    def model(self) -> Any:
        """The private compiled model of the robot alone (read it; never step it)."""
        return self._model

    def fk(self, q: Array) -> tuple[Array, Array]:
        """Tool position and rotation matrix at chain configuration ``q`` (copies)."""
        pos, rot = self._kinematics(q)
        return pos.copy(), rot.copy()

    def _kinematics(self, q: Array) -> tuple[Array, Array]:
        """Views of the tool pose at ``q`` (valid until the next call)."""
        self._data.qpos[self._mode(True).qpos] = q
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
        its second-order error is micrometres at the path speeds used here).

        Runs every control tick of a straight move, so it avoids numpy's per-call overheads
        where they dominate these 6 x n problems: the 6 x 6 system is solved by MuJoCo's
        Cholesky routines (it is symmetric positive definite: ``J J^T + damping``), norms
        are taken on Python floats."""
        q = q.copy()
        mode = self._mode(whole_body)
        first, weights, lower, upper = mode.first, mode.weights, mode.lower, mode.upper
        err, y = np.empty(6), np.empty(6)
        residual: Array | None = None
        for _ in range(iterations):
            pos, rot = self._kinematics(q)
            np.subtract(position, pos, out=err[:3])
            err[3:] = _rotation_error(rotation, rot)
            e = err.tolist()
            if (
                math.hypot(e[0], e[1], e[2]) < tolerance
                and math.hypot(e[3], e[4], e[5]) < 10 * tolerance
            ):
                return q, math.hypot(e[0], e[1], e[2]), math.hypot(e[3], e[4], e[5])
            mujoco.mj_comPos(self._model, self._data)  # cdof, which mj_jacSite reads
            mujoco.mj_jacSite(self._model, self._data, self._jac[:3], self._jac[3:], self._site)
            jac = self._jac[:, mode.columns]
            if weights is not None:
                jac = jac * weights
            gram = jac @ jac.T
            gram += self._damping
            mujoco.mju_cholFactor(gram, 0.0)
            mujoco.mju_cholSolve(y, gram, err)
            now = q[first:]
            step = jac.T @ y
            if weights is not None:
                step *= weights
            moved = now + step
            np.minimum(np.maximum(moved, lower, out=moved), upper, out=moved)
            step = moved - now
            if weights is not None:
                step /= weights
            residual = err - jac @ step
            q[first:] = moved
        if residual is None:  # no iteration asked for
            return q, math.inf, math.inf
        r = residual.tolist()
        return q, math.hypot(r[0], r[1], r[2]), math.hypot(r[3], r[4], r[5])

    def _mode(self, whole_body: bool) -> _Mode:
        """What :meth:`step` uses in each mode, worked out on first use."""
        modes: dict[bool, _Mode] | None = getattr(self, "_modes", None)
        if modes is None:
            modes = self._modes = {
                whole: _Mode(
                    first=0 if whole else self.n_base,
                    weights=_unless_ones(self._weights_wb if whole else self._weights_arm),
                    lower=self.lower[0 if whole else self.n_base :],
                    upper=self.upper[0 if whole else self.n_base :],
                    columns=_as_slice(self._dadr[0 if whole else self.n_base :]),
                    qpos=_as_slice(self._qadr),
                )
                for whole in (False, True)
            }
        return modes[whole_body]


@dataclass(frozen=True)
class _Mode:
    first: int
    """Index in the chain of the first joint that moves (0: the base too)."""
    weights: Array | None
    """Column scales (``None``: all 1, nothing to scale)."""
    lower: Array
    upper: Array
    columns: slice | npt.NDArray[np.intp]
    """Jacobian columns of the joints that move."""
    qpos: slice | npt.NDArray[np.intp]
    """``qpos`` addresses of the whole chain."""


def _unless_ones(weights: Array) -> Array | None:
    return None if np.all(weights == 1.0) else weights


def _as_slice(index: npt.NDArray[Any]) -> slice | npt.NDArray[np.intp]:
    """A slice for consecutive indices (numpy then returns a view instead of copying)."""
    start = int(index[0]) if len(index) else 0
    if np.array_equal(index, np.arange(start, start + len(index))):
        return slice(start, start + len(index))
    return np.asarray(index, dtype=np.intp)


def _rotation_error(goal: Array, current: Array) -> Array:
    """Rotation vector taking ``current`` to ``goal`` for the small errors of tracking:
    ``½ Σ current_i × goal_i`` over the frame axes (sin θ · axis; exact direction, and within
    1 % of θ below 0.25 rad)."""
    m = (current @ goal.T).ravel()  # m[3 a + b] = sum_i current[a, i] goal[b, i]
    return np.asarray(0.5 * (m[_PLUS] - m[_MINUS]), dtype=np.float64)


_PLUS, _MINUS = np.array([5, 6, 1]), np.array([7, 2, 3])  # (1,2) (2,0) (0,1) - (2,1) (0,2) (1,0)
