"""Scenario files: their schema, reading and checking them, and the maths they imply.

A :class:`Scenario` (a TOML file) names the robots (:class:`RobotSpec`), furniture,
appliances, containers, parts, sensors, agents and goal of a run. :func:`load_scenario` reads
and checks one; :func:`resolve_placements` computes world poses from the placement tree;
:func:`drawer_layout` the geometry of a cabinet's drawers. Building the world-model scene of a
scenario is :mod:`scenario.wm`. Every error is a :class:`ScenarioError`.
"""

from __future__ import annotations

from ._drawer_layout import HANDLE_HALF as HANDLE_HALF
from ._drawer_layout import PANEL as PANEL
from ._drawer_layout import SIDE as SIDE
from ._drawer_layout import WALL as WALL
from ._drawer_layout import DrawerLayout as DrawerLayout
from ._drawer_layout import drawer_layout as drawer_layout
from ._errors import ScenarioError as ScenarioError
from ._load import check_scenario as check_scenario
from ._load import known_scenarios as known_scenarios
from ._load import load_scenario as load_scenario
from ._load import parse_scenario as parse_scenario
from ._load import read_scenario as read_scenario
from ._placement import Footprint as Footprint
from ._placement import WorldPlacement as WorldPlacement
from ._placement import deck_point as deck_point
from ._placement import footprints as footprints
from ._placement import object_centres as object_centres
from ._placement import resolve_placements as resolve_placements
from ._robot_file import ERD_PREFIX as ERD_PREFIX
from ._robot_file import FileRobot as FileRobot
from ._robot_file import RobotFileError as RobotFileError
from ._robot_file import describe_file as describe_file
from ._robot_file import erd_share as erd_share
from ._robot_file import robot_file_path as robot_file_path
from ._robot_spec import ARM_JOINTS_6 as ARM_JOINTS_6
from ._robot_spec import ARM_JOINTS_7 as ARM_JOINTS_7
from ._robot_spec import RGBA as RGBA
from ._robot_spec import UR5E_HOME as UR5E_HOME
from ._robot_spec import UR5E_JOINTS as UR5E_JOINTS
from ._robot_spec import MjcfArm as MjcfArm
from ._robot_spec import RobotLayout as RobotLayout
from ._robot_spec import RobotSpec as RobotSpec
from ._robot_spec import robot_layout as robot_layout
from ._schema import CABINET_TOP as CABINET_TOP
from ._schema import DOOR_HANDLE_INSET as DOOR_HANDLE_INSET
from ._schema import DOOR_HANDLE_STANDOFF as DOOR_HANDLE_STANDOFF
from ._schema import DRAWER_CLEARANCE as DRAWER_CLEARANCE
from ._schema import ApplianceEntry as ApplianceEntry
from ._schema import ContainerEntry as ContainerEntry
from ._schema import DrawerSpec as DrawerSpec
from ._schema import FurnitureEntry as FurnitureEntry
from ._schema import PartEntry as PartEntry
from ._schema import Placement as Placement
from ._schema import RobotEntry as RobotEntry
from ._schema import Scenario as Scenario
from ._schema import SensorEntry as SensorEntry

__all__ = [
    "ARM_JOINTS_6",
    "ARM_JOINTS_7",
    "CABINET_TOP",
    "DOOR_HANDLE_INSET",
    "DOOR_HANDLE_STANDOFF",
    "DRAWER_CLEARANCE",
    "ERD_PREFIX",
    "HANDLE_HALF",
    "PANEL",
    "RGBA",
    "SIDE",
    "UR5E_HOME",
    "UR5E_JOINTS",
    "WALL",
    "ApplianceEntry",
    "ContainerEntry",
    "DrawerLayout",
    "DrawerSpec",
    "FileRobot",
    "Footprint",
    "FurnitureEntry",
    "MjcfArm",
    "PartEntry",
    "Placement",
    "RobotEntry",
    "RobotFileError",
    "RobotLayout",
    "RobotSpec",
    "Scenario",
    "ScenarioError",
    "SensorEntry",
    "WorldPlacement",
    "check_scenario",
    "deck_point",
    "describe_file",
    "drawer_layout",
    "erd_share",
    "footprints",
    "known_scenarios",
    "load_scenario",
    "object_centres",
    "parse_scenario",
    "read_scenario",
    "resolve_placements",
    "robot_file_path",
    "robot_layout",
]
