"""skimesh device layer: typed device interfaces, the MuJoCo world, robot models and IK.

Importing the package loads only its pure core (interfaces, errors, scenario files, wire
schema); MuJoCo, placo and rerun load with the modules that need them:
``device_drivers.world`` (``SimWorld``, ``running_world``), ``device_drivers.drivers``
(in-process drivers), ``device_drivers.remote`` / ``device_drivers.remote_client`` (Zenoh),
``device_drivers.recorder`` (rerun).
"""

from device_drivers.errors import CollisionError as CollisionError
from device_drivers.errors import CommandError as CommandError
from device_drivers.errors import DeviceBusyError as DeviceBusyError
from device_drivers.errors import DeviceError as DeviceError
from device_drivers.errors import DeviceUnavailableError as DeviceUnavailableError
from device_drivers.errors import GraspLostError as GraspLostError
from device_drivers.errors import IKError as IKError
from device_drivers.errors import ModelError as ModelError
from device_drivers.errors import MotionError as MotionError
from device_drivers.errors import MotionStoppedError as MotionStoppedError
from device_drivers.errors import MotionTimeoutError as MotionTimeoutError
from device_drivers.errors import ScenarioError as ScenarioError
from device_drivers.errors import SimulationDivergedError as SimulationDivergedError
from device_drivers.errors import UnknownElementError as UnknownElementError
from device_drivers.errors import UnreachableError as UnreachableError
from device_drivers.ik import IKOptions as IKOptions
from device_drivers.ik import IKResult as IKResult
from device_drivers.ik import IKSolver as IKSolver
from device_drivers.ik import TcpTarget as TcpTarget
from device_drivers.interfaces import Appliance as Appliance
from device_drivers.interfaces import ApplianceState as ApplianceState
from device_drivers.interfaces import Arm as Arm
from device_drivers.interfaces import ArmState as ArmState
from device_drivers.interfaces import BaseState as BaseState
from device_drivers.interfaces import Detection as Detection
from device_drivers.interfaces import Device as Device
from device_drivers.interfaces import Gripper as Gripper
from device_drivers.interfaces import GripperState as GripperState
from device_drivers.interfaces import MobileBase as MobileBase
from device_drivers.interfaces import ObjectSensor as ObjectSensor
from device_drivers.interfaces import ProgressCallback as ProgressCallback
from device_drivers.interfaces import Twist2D as Twist2D
from device_drivers.interfaces import WorldPose as WorldPose
from device_drivers.placement import object_centres as object_centres
from device_drivers.placement import resolve_placements as resolve_placements
from device_drivers.robot_spec import MjcfArm as MjcfArm
from device_drivers.robot_spec import Pose2D as Pose2D
from device_drivers.robot_spec import RobotLayout as RobotLayout
from device_drivers.robot_spec import RobotSpec as RobotSpec
from device_drivers.robot_spec import robot_layout as robot_layout
from device_drivers.scenario import Scenario as Scenario
from device_drivers.scenario_load import load_scenario as load_scenario
from device_drivers.scenario_load import parse_scenario as parse_scenario

__all__: list[str] = [
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
    "DeviceUnavailableError",
    "GraspLostError",
    "Gripper",
    "GripperState",
    "IKError",
    "IKOptions",
    "IKResult",
    "IKSolver",
    "MjcfArm",
    "MobileBase",
    "ModelError",
    "MotionError",
    "MotionStoppedError",
    "MotionTimeoutError",
    "ObjectSensor",
    "Pose2D",
    "ProgressCallback",
    "RobotLayout",
    "RobotSpec",
    "Scenario",
    "ScenarioError",
    "SimulationDivergedError",
    "Twist2D",
    "UnknownElementError",
    "UnreachableError",
    "WorldPose",
    "load_scenario",
    "object_centres",
    "parse_scenario",
    "resolve_placements",
    "robot_layout",
]
