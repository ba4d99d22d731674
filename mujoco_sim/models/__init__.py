"""MuJoCo model building: the generated mobile manipulator (:func:`build_robot`,
:func:`build_world`), grippers, arms from MJCF files (Menagerie) or an arm with its gripper
from one URDF or MJCF file (:func:`add_file_robot`), cabinets with drawers, and the whole scene
of a scenario (:func:`build_scene`). ``python -m mujoco_sim.models SCENARIO`` prints what each
robot's files gave.
"""

from __future__ import annotations

from ._drawer import add_cabinet as add_cabinet
from ._file_robot import add_file_robot as add_file_robot
from ._file_robot import load_robot_file as load_robot_file
from ._gripper import GRIPPER_KP as GRIPPER_KP
from ._gripper import add_gripper_drive as add_gripper_drive
from ._gripper import add_parallel_gripper as add_parallel_gripper
from ._menagerie import add_mjcf_arm as add_mjcf_arm
from ._menagerie import load_mjcf as load_mjcf
from ._menagerie import menagerie_paths as menagerie_paths
from ._robot import build_robot as build_robot
from ._robot import build_world as build_world
from ._scene import build_scene as build_scene
from ._scene import graspable_labels as graspable_labels
from ._scene import look_at_quat as look_at_quat
from ._scene import weld_name as weld_name

__all__ = [
    "GRIPPER_KP",
    "add_cabinet",
    "add_file_robot",
    "add_gripper_drive",
    "add_mjcf_arm",
    "add_parallel_gripper",
    "build_robot",
    "build_scene",
    "build_world",
    "graspable_labels",
    "load_mjcf",
    "load_robot_file",
    "look_at_quat",
    "menagerie_paths",
    "weld_name",
]
