"""Controllers: how a device command runs in the simulation thread.

A :class:`Job` carries one command from the event loop to its :class:`Controller`; each
control tick the plant ticks the active controllers (arm, base, gripper, appliance, sensors),
which write servo set-points. :class:`Grasping` attaches held objects; :class:`GripperDrive`
maps a gripper command onto the gripper model's actuators.
"""

from __future__ import annotations

from ._appliance import ApplianceController as ApplianceController
from ._arm import ArmController as ArmController
from ._base import BaseController as BaseController
from ._base import plan_path as plan_path
from ._grasp import Grasping as Grasping
from ._grasp import GraspMode as GraspMode
from ._gripper import GripperController as GripperController
from ._gripper_drive import Calibration as Calibration
from ._gripper_drive import GripperDrive as GripperDrive
from ._gripper_drive import PadDrive as PadDrive
from ._gripper_drive import TendonDrive as TendonDrive
from ._gripper_drive import calibrate as calibrate
from ._gripper_drive import gripper_drive as gripper_drive
from ._gripper_drive import pad_gap as pad_gap
from ._job import NOT_INSTANT as NOT_INSTANT
from ._job import Controller as Controller
from ._job import Job as Job
from ._sensing import CameraController as CameraController
from ._sensing import PlatformController as PlatformController

__all__ = [
    "NOT_INSTANT",
    "ApplianceController",
    "ArmController",
    "BaseController",
    "Calibration",
    "CameraController",
    "Controller",
    "GraspMode",
    "Grasping",
    "GripperController",
    "GripperDrive",
    "Job",
    "PadDrive",
    "PlatformController",
    "TendonDrive",
    "calibrate",
    "gripper_drive",
    "pad_gap",
    "plan_path",
]
