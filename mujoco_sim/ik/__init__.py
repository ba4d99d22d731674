"""Inverse kinematics over a MuJoCo model: the target and result types, the
:class:`IKSolver` protocol and the damped-least-squares solver :class:`DlsIK`.

The placo-based solver is :mod:`mujoco_sim.placo_ik` (it loads placo, which this package does
not).
"""

from __future__ import annotations

from ._chain import ChainSolver as ChainSolver
from ._core import IKOptions as IKOptions
from ._core import IKResult as IKResult
from ._core import IKSolver as IKSolver
from ._core import TcpTarget as TcpTarget
from ._core import orientation_error as orientation_error
from ._core import quat_to_matrix as quat_to_matrix
from ._core import random_configurations as random_configurations
from ._core import rotation_error_vector as rotation_error_vector
from ._core import solve_with_restarts as solve_with_restarts
from ._dls import DlsIK as DlsIK

__all__ = [
    "ChainSolver",
    "DlsIK",
    "IKOptions",
    "IKResult",
    "IKSolver",
    "TcpTarget",
    "orientation_error",
    "quat_to_matrix",
    "random_configurations",
    "rotation_error_vector",
    "solve_with_restarts",
]
