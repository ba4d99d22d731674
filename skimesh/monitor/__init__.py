"""``skimesh monitor``: everything a site does, followed into rerun from any host of the mesh.

:func:`run_monitor` mirrors the scenario's world from the devices' states and the objects'
poses (the simulator's ground truth, else the world model's beliefs), and records the mission
through the path ``skimesh demo`` uses (:class:`skimesh.recording.MissionFeed`): each task
from its kept history, the plan, each robot's step and progress, world-model changes and
beliefs, the agents' event logs; with the demo's layout (:class:`MonitorOptions`,
:class:`Monitor`). :class:`WorldFeed` is the world's part, :class:`MeshClock` its clock.

Importing this package imports rerun and MuJoCo: the command line imports it only when it runs.
"""

from ._clock import MeshClock as MeshClock
from ._run import Monitor as Monitor
from ._run import MonitorOptions as MonitorOptions
from ._run import run_monitor as run_monitor
from ._world import WorldFeed as WorldFeed

__all__ = ["MeshClock", "Monitor", "MonitorOptions", "WorldFeed", "run_monitor"]
