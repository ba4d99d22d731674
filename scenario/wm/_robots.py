"""Robots in the world-model scene (see :func:`scenario.wm.scenario_ops`): the labels of their
devices and homes, each arm's home posture, and the reach that puts things ``at`` a robot's
home.
"""

from __future__ import annotations

import math

from scenario._schema import RobotEntry
from wm_store.ontology import Cls

__all__ = [
    "DEVICES",
    "HOME_6",
    "HOME_7",
    "REACH_FRACTION",
    "arm_home",
    "arm_reach",
    "device_label",
    "distance_to_footprint",
    "home_label",
    "robot_devices",
]

REACH_FRACTION = 0.8
"""A robot's arm reaches what lies within this fraction of its shoulder-to-tcp length
(horizontally, from the arm mount) — the test that puts things ``at`` a robot's home."""
HOME_6: tuple[float, ...] = (0.0, -0.7, 1.7, 0.0, 2.1, 0.0)
"""Home posture of a 6-joint arm, rad, in joint order (``ARM_JOINTS_6``): the gripper points
down just in front of the arm's mount, ~0.6 m above the deck (the default robot: tcp 0.2 m
ahead of the base centre, 0.93 m high), clear of a table or shelf at a station. Written as the
arm's ``jointPositions``: skills pass through it between a pick in front and a place behind."""
HOME_7: tuple[float, ...] = (0.0, -0.7, 0.0, 1.7, 0.0, 2.1, 0.0)
"""The same for a 7-joint arm (``ARM_JOINTS_7``: an upper-arm roll after the shoulder)."""
DEVICES = (("arm", Cls.Arm), ("gripper", Cls.Gripper), ("base", Cls.MobileBase))
"""A mobile robot's devices: label suffix and class (:func:`robot_devices`: of one robot)."""


def robot_devices(robot: RobotEntry) -> tuple[tuple[str, str], ...]:
    """``robot``'s devices, label suffix and class: :data:`DEVICES`, without the base for a
    fixed robot (``model.mount = "fixed"``)."""
    return tuple((d, cls) for d, cls in DEVICES if d in robot.spec.devices)


def device_label(robot: str, device: str) -> str:
    """World-model label of a robot's device: ``r1-arm``, ``r1-gripper``, ``r1-base``."""
    return f"{robot}-{device}"


def home_label(robot: str) -> str:
    """Label of the Location at a robot's start pose."""
    return f"{robot}-home"


def arm_reach(robot: RobotEntry) -> float:
    """How far, m, ``robot``'s arm reaches horizontally from its mount (``REACH_FRACTION``
    of its length)."""
    m = robot.spec
    if m.mjcf is not None:
        return REACH_FRACTION * m.mjcf.reach
    return REACH_FRACTION * (
        m.upper_arm_length + m.forearm_length + m.wrist_length + m.gripper_length
    )


def arm_home(robot: RobotEntry) -> tuple[float, ...]:
    """The arm's home posture: its file's (``MjcfArm.home``) or the generated arm's."""
    m = robot.model
    if m.mjcf is not None:
        return m.mjcf.home
    return HOME_6 if m.arm_dof == 6 else HOME_7


def distance_to_footprint(
    footprint: tuple[float, float, float, float, float], x: float, y: float
) -> float:
    """Distance from (x, y) to a rectangle (centre x, y, yaw, half sizes)."""
    cx, cy, yaw, hx, hy = footprint
    c, s = math.cos(yaw), math.sin(yaw)
    lx, ly = c * (x - cx) + s * (y - cy), -s * (x - cx) + c * (y - cy)
    return math.hypot(max(abs(lx) - hx, 0.0), max(abs(ly) - hy, 0.0))
