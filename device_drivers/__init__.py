"""The device layer of skimesh: what any robot's drivers implement and how they travel.

- The typed **device interfaces** (:class:`Arm`, :class:`MobileBase`, :class:`Gripper`,
  :class:`Appliance`, :class:`ObjectSensor`) and their state values, which the skills call;
  :class:`Pausable` for a device whose motion can be held and continued.
- The **errors** every driver raises, all under :class:`DeviceError`; they cross the wire by
  class name.
- The **wire protocol** (:mod:`device_drivers.protocol`) and serving / proxying devices over
  the mesh (:mod:`device_drivers.remote`).

Importing the package loads no simulator: the MuJoCo simulation is the package
:mod:`mujoco_sim`, scenario files are :mod:`scenario`.
"""

from __future__ import annotations

from ._errors import CollisionError as CollisionError
from ._errors import CommandError as CommandError
from ._errors import DeviceBusyError as DeviceBusyError
from ._errors import DeviceError as DeviceError
from ._errors import DeviceUnavailableError as DeviceUnavailableError
from ._errors import GraspLostError as GraspLostError
from ._errors import IKError as IKError
from ._errors import ModelError as ModelError
from ._errors import MotionError as MotionError
from ._errors import MotionStoppedError as MotionStoppedError
from ._errors import MotionTimeoutError as MotionTimeoutError
from ._errors import SimulationDivergedError as SimulationDivergedError
from ._errors import UnknownElementError as UnknownElementError
from ._errors import UnreachableError as UnreachableError
from ._interfaces import Appliance as Appliance
from ._interfaces import ApplianceState as ApplianceState
from ._interfaces import Arm as Arm
from ._interfaces import ArmState as ArmState
from ._interfaces import BaseState as BaseState
from ._interfaces import Detection as Detection
from ._interfaces import Device as Device
from ._interfaces import DeviceKey as DeviceKey
from ._interfaces import Gripper as Gripper
from ._interfaces import GripperState as GripperState
from ._interfaces import MobileBase as MobileBase
from ._interfaces import ObjectSensor as ObjectSensor
from ._interfaces import Pausable as Pausable
from ._interfaces import Pose2D as Pose2D
from ._interfaces import ProgressCallback as ProgressCallback
from ._interfaces import Twist2D as Twist2D
from ._interfaces import WorldPose as WorldPose

__all__ = [
    "Appliance",
    "ApplianceState",
    "Arm",
    "ArmState",
    "BaseState",
    "CollisionError",
    "CommandError",
    "Detection",
    "Device",
    "DeviceBusyError",
    "DeviceError",
    "DeviceKey",
    "DeviceUnavailableError",
    "GraspLostError",
    "Gripper",
    "GripperState",
    "IKError",
    "MobileBase",
    "ModelError",
    "MotionError",
    "MotionStoppedError",
    "MotionTimeoutError",
    "ObjectSensor",
    "Pausable",
    "Pose2D",
    "ProgressCallback",
    "SimulationDivergedError",
    "Twist2D",
    "UnknownElementError",
    "UnreachableError",
    "WorldPose",
]
