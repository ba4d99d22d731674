"""IK with placo: :class:`PlacoIK` (whole-body, QP-based) and the export of a MuJoCo robot to
the URDF placo loads. Importing this package imports placo.
"""

from __future__ import annotations

from ._export import IK_ROOT as IK_ROOT
from ._export import load_placo_robot as load_placo_robot
from ._export import placo_mjcf as placo_mjcf
from ._solver import PlacoIK as PlacoIK

__all__ = [
    "IK_ROOT",
    "PlacoIK",
    "load_placo_robot",
    "placo_mjcf",
]
