"""Inverse kinematics: the solver interface, targets, results, and the restart loop both
solvers share. Pure numpy: no MuJoCo or placo import (those live in ``ik_dls`` / ``ik_placo``).

Frames and units: targets are in the *model frame* of the robot model the solver was built
from. For the generated mobile robots that is the world frame (their base joints are absolute
world coordinates). Positions in metres, angles in radians, quaternions ``(w, x, y, z)``.

Solvers are blocking numeric code (callers run them through ``anyio.to_thread``). Each instance
owns its model copy and scratch state: use one instance per thread.
"""

from __future__ import annotations

import math
from collections.abc import Iterable, Mapping, Sequence
from typing import Annotated, Protocol, TypeAlias, runtime_checkable

import numpy as np
import numpy.typing as npt
from msgspec import Meta, Struct

from device_drivers import IKError, UnreachableError

__all__ = [
    "FloatArray",
    "IKOptions",
    "IKResult",
    "IKSolver",
    "IterativeProblem",
    "TcpTarget",
    "gather",
    "orientation_error",
    "quat_to_matrix",
    "random_configurations",
    "rotation_error_vector",
    "solve_with_restarts",
]

FloatArray: TypeAlias = npt.NDArray[np.float64]
Vec3: TypeAlias = tuple[float, float, float]
Quat: TypeAlias = tuple[float, float, float, float]


class TcpTarget(Struct, frozen=True, forbid_unknown_fields=True):
    """Where the tool centre point should go, in the model frame.

    ``position`` is required (m). Orientation is one of: ``quat`` (full orientation of the tcp
    frame, ``(w, x, y, z)``), ``approach`` (direction of the tcp z axis, rotation about it
    free: e.g. ``(0, 0, -1)`` for "gripper pointing down, any yaw"), or neither (position only).
    """

    position: Vec3
    quat: Quat | None = None
    approach: Vec3 | None = None

    def __post_init__(self) -> None:
        if self.quat is not None and self.approach is not None:
            raise ValueError("give either quat (full orientation) or approach (axis), not both")
        if self.quat is not None and math.hypot(*self.quat) < 1e-9:
            raise ValueError(f"quat must be non-zero, got {self.quat}")
        if self.approach is not None and math.hypot(*self.approach) < 1e-9:
            raise ValueError(f"approach must be a non-zero direction, got {self.approach}")

    @classmethod
    def pointing_down(cls, position: Iterable[float]) -> TcpTarget:
        """The tcp at ``position`` with the gripper pointing down (world -z), yaw free."""
        x, y, z = (float(v) for v in position)
        return cls(position=(x, y, z), approach=(0.0, 0.0, -1.0))


class IKResult(Struct, frozen=True):
    """A converged IK solution.

    ``joints`` holds the solved joints (joint name → rad or m): the arm joints, plus the base
    joints when solved with ``whole_body=True``. Errors are those of the returned configuration
    (position in m, orientation in rad, 0 if unconstrained); ``iterations`` counts all restarts.
    """

    joints: dict[str, float]
    position_error: float
    orientation_error: float
    iterations: int
    solver: str
    whole_body: bool


class IKOptions(Struct, frozen=True, forbid_unknown_fields=True):
    """Tolerances and effort limits shared by the solvers (solver-specific fields say so)."""

    position_tolerance: Annotated[float, Meta(gt=0)] = 1e-4
    """Converged when the tcp is this close to the target, m."""
    orientation_tolerance: Annotated[float, Meta(gt=0)] = 1e-3
    """... and its orientation error is below this, rad."""
    max_iterations: Annotated[int, Meta(ge=1)] = 100
    """Iterations per attempt (the start configuration, then each restart)."""
    patience: Annotated[int, Meta(ge=1)] = 12
    """An attempt that has not improved its error by 5 % in this many iterations is dropped."""
    restarts: Annotated[int, Meta(ge=0)] = 24
    """Extra attempts from seeded random arm configurations (base kept at its start)."""
    seed: int = 0
    """Seed of the restart configurations (fixed at construction: solves are deterministic)."""
    regularization: Annotated[float, Meta(gt=0)] = 1e-3
    """placo: weight of the joint-velocity regularisation task."""
    damping: Annotated[float, Meta(gt=0)] = 0.02
    """DLS: damping λ of the least-squares step (rad·m units mixed, see ``ik_dls``)."""


@runtime_checkable
class IKSolver(Protocol):
    """What every IK solver offers. ``solve`` blocks; it raises :class:`UnreachableError`
    (with the residual) when no attempt converges and :class:`IKError` on bad input."""

    name: str
    base_joints: tuple[str, ...]
    arm_joints: tuple[str, ...]

    def solve(
        self, q0: Mapping[str, float], target: TcpTarget, *, whole_body: bool = False
    ) -> IKResult: ...


def quat_to_matrix(quat: Sequence[float]) -> FloatArray:
    """Rotation matrix of the (not necessarily unit) quaternion ``(w, x, y, z)``."""
    w, x, y, z = np.asarray(quat, dtype=np.float64) / np.linalg.norm(quat)
    return np.array(
        [
            [1 - 2 * (y * y + z * z), 2 * (x * y - w * z), 2 * (x * z + w * y)],
            [2 * (x * y + w * z), 1 - 2 * (x * x + z * z), 2 * (y * z - w * x)],
            [2 * (x * z - w * y), 2 * (y * z + w * x), 1 - 2 * (x * x + y * y)],
        ]
    )


def rotation_error_vector(r_target: FloatArray, r_current: FloatArray) -> FloatArray:
    """Rotation vector (axis × angle, world frame, rad) taking ``r_current`` to ``r_target``."""
    r = r_target @ r_current.T
    axis = np.array([r[2, 1] - r[1, 2], r[0, 2] - r[2, 0], r[1, 0] - r[0, 1]])
    sin2 = float(np.linalg.norm(axis))  # 2 sin(angle)
    angle = math.atan2(sin2, float(np.trace(r)) - 1.0)
    if sin2 < 1e-9:
        if angle < 1.0:  # identity
            return np.zeros(3)
        # 180°: the axis is the column of r + I with the largest norm
        b = r + np.eye(3)
        col = b[:, int(np.argmax(np.linalg.norm(b, axis=0)))]
        return math.pi * col / np.linalg.norm(col)
    return angle * axis / sin2


def orientation_error(target: TcpTarget, r_current: FloatArray) -> float:
    """Orientation error of a tcp with rotation matrix ``r_current`` w.r.t. ``target``, rad."""
    if target.quat is not None:
        return float(np.linalg.norm(rotation_error_vector(quat_to_matrix(target.quat), r_current)))
    if target.approach is not None:
        z = r_current[:, 2]
        a = np.asarray(target.approach) / np.linalg.norm(target.approach)
        return math.atan2(float(np.linalg.norm(np.cross(z, a))), float(z @ a))
    return 0.0


class IterativeProblem(Protocol):
    """One IK problem as a solver iterates it (what :func:`solve_with_restarts` drives)."""

    def reset(self, q: FloatArray) -> tuple[float, float]:
        """Start from the active-joint vector ``q``; return (position, orientation) error."""
        ...

    def step(self) -> tuple[float, float]:
        """One solver iteration; return the errors after it."""
        ...

    def current(self) -> FloatArray:
        """The active-joint vector now."""
        ...


def solve_with_restarts(
    *,
    solver: str,
    names: Sequence[str],
    start: FloatArray,
    restarts: Sequence[FloatArray],
    problem: IterativeProblem,
    options: IKOptions,
    whole_body: bool,
) -> IKResult:
    """Iterate ``problem`` from ``start``, then from each of ``restarts``, until converged.

    An attempt ends when it converges, after ``options.max_iterations``, or when it stalls
    (its score ``position error + 0.1 m/rad × orientation error`` has not improved by 5 %
    in ``options.patience`` iterations: a local minimum or a joint-limit corner).
    ``names`` label the active-joint vectors; the result holds them all.
    Raises :class:`UnreachableError` with the best residual if no attempt converges.
    """
    best: tuple[float, FloatArray, float, float] | None = None
    total = 0
    for q_start in (start, *restarts):
        pos_err, ori_err = problem.reset(q_start)
        best_score, best_at = math.inf, 0
        for it in range(options.max_iterations + 1):
            if pos_err <= options.position_tolerance and ori_err <= options.orientation_tolerance:
                joints = {n: float(v) for n, v in zip(names, problem.current(), strict=True)}
                return IKResult(joints, pos_err, ori_err, total, solver, whole_body)
            score = pos_err + 0.1 * ori_err
            if score < 0.95 * best_score:
                best_score, best_at = score, it
            if it == options.max_iterations or it - best_at >= options.patience:
                break
            pos_err, ori_err = problem.step()
            total += 1
        if best is None or score < best[0]:
            best = (score, problem.current(), pos_err, ori_err)
    assert best is not None
    raise UnreachableError(
        position_error=best[2],
        orientation_error=best[3],
        iterations=total,
        solver=solver,
        joints={n: float(v) for n, v in zip(names, best[1], strict=True)},
        whole_body=whole_body,
    )


def gather(q0: Mapping[str, float], names: Sequence[str], solver: str) -> FloatArray:
    """The values of ``names`` from ``q0``; :class:`IKError` lists any missing joint."""
    missing = [n for n in names if n not in q0]
    if missing:
        raise IKError(f"{solver}: q0 lacks joints {missing}; give every base and arm joint")
    return np.array([float(q0[n]) for n in names])


def random_configurations(
    lower: FloatArray, upper: FloatArray, count: int, seed: int
) -> list[FloatArray]:
    """``count`` seeded uniform samples inside ``[lower, upper]`` (shrunk by 5 % per side)."""
    rng = np.random.default_rng(seed)
    margin = 0.05 * (upper - lower)
    return [rng.uniform(lower + margin, upper - margin) for _ in range(count)]
