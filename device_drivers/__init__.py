"""skimesh device layer: typed device interfaces, the MuJoCo world, robot models and IK."""

from device_drivers.errors import DeviceError as DeviceError
from device_drivers.errors import IKError as IKError
from device_drivers.errors import ModelError as ModelError
from device_drivers.errors import SimulationDivergedError as SimulationDivergedError
from device_drivers.errors import UnknownElementError as UnknownElementError
from device_drivers.errors import UnreachableError as UnreachableError
from device_drivers.ik import IKOptions as IKOptions
from device_drivers.ik import IKResult as IKResult
from device_drivers.ik import IKSolver as IKSolver
from device_drivers.ik import TcpTarget as TcpTarget
from device_drivers.robot_spec import Pose2D as Pose2D
from device_drivers.robot_spec import RobotLayout as RobotLayout
from device_drivers.robot_spec import RobotSpec as RobotSpec
from device_drivers.robot_spec import robot_layout as robot_layout

__all__: list[str] = [
    "DeviceError",
    "IKError",
    "IKOptions",
    "IKResult",
    "IKSolver",
    "ModelError",
    "Pose2D",
    "RobotLayout",
    "RobotSpec",
    "SimulationDivergedError",
    "UnknownElementError",
    "UnreachableError",
    "robot_layout",
]
