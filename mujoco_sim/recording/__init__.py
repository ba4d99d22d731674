"""Recording a simulation to rerun: :class:`Recorder` logs poses, device states and (optionally)
camera images rendered on a :class:`CameraThread`. Importing this package imports rerun.
"""

from __future__ import annotations

from ._camera import CameraThread as CameraThread
from ._recorder import Recorder as Recorder
from ._recorder import RobotSeries as RobotSeries

__all__ = [
    "CameraThread",
    "Recorder",
    "RobotSeries",
]
