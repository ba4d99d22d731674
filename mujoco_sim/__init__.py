"""The MuJoCo simulation of skimesh's robots and appliances.

:class:`SimWorld` runs a scenario's world in a thread beside the event loop (real-time or
fast pacing); :func:`sim_devices` gives in-process drivers that implement the
:mod:`device_drivers` interfaces over it, and :class:`SimTruth` its ground truth (where the
objects really are: :class:`device_drivers.truth.GroundTruth`, served on ``sim/truth``). The
sub-packages hold the concepts: ``models`` (MuJoCo model building), ``control``
(controllers of each device), ``ik`` and ``placo_ik`` (inverse kinematics), ``motion``
(trajectories and paths), ``physics`` (state, options, health) and ``recording`` (rerun).

This is the only package that imports ``mujoco`` or ``placo``.
"""

from __future__ import annotations

from ._drivers import SimAppliance as SimAppliance
from ._drivers import SimArm as SimArm
from ._drivers import SimBase as SimBase
from ._drivers import SimGripper as SimGripper
from ._drivers import SimSensor as SimSensor
from ._drivers import sim_devices as sim_devices
from ._loop_post import LoopPost as LoopPost
from ._loop_post import loop_post as loop_post
from ._plant import Batch as Batch
from ._plant import DeviceKind as DeviceKind
from ._plant import Plant as Plant
from ._robot_ik import WorldIK as WorldIK
from ._snapshot import DeviceStates as DeviceStates
from ._snapshot import ObjectInfo as ObjectInfo
from ._snapshot import SceneFacts as SceneFacts
from ._snapshot import Snapshot as Snapshot
from ._snapshot import object_in as object_in
from ._truth import SimTruth as SimTruth
from ._world import SimWorld as SimWorld
from ._world import WorldOptions as WorldOptions
from ._world import WorldStatistics as WorldStatistics
from ._world import running_world as running_world

__all__ = [
    "Batch",
    "DeviceKind",
    "DeviceStates",
    "LoopPost",
    "ObjectInfo",
    "Plant",
    "SceneFacts",
    "SimAppliance",
    "SimArm",
    "SimBase",
    "SimGripper",
    "SimSensor",
    "SimTruth",
    "SimWorld",
    "Snapshot",
    "WorldIK",
    "WorldOptions",
    "WorldStatistics",
    "loop_post",
    "object_in",
    "running_world",
    "sim_devices",
]
