"""Recording a simulation to rerun: :class:`Recorder` logs poses, device states and (optionally)
camera images rendered on a :class:`CameraThread`; :class:`Mirror` poses a scenario's world
from the states a mesh reports, for a recording made without the physics (``skimesh
monitor``). Importing this package imports rerun.
"""

from __future__ import annotations

from ._camera import CameraThread as CameraThread
from ._mirror import Mirror as Mirror
from ._recorder import Recorder as Recorder
from ._recorder import RobotSeries as RobotSeries

__all__ = [
    "CameraThread",
    "Mirror",
    "Recorder",
    "RobotSeries",
]
