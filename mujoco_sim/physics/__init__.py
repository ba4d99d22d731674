"""The physics state and options: the simulation time step and solver options, joint and servo
state access, the divergence check of a state, and the record of contacts between robots.
"""

from __future__ import annotations

from ._contacts import RobotContact as RobotContact
from ._contacts import RobotContacts as RobotContacts
from ._health import DEFAULT_MAX_ACCELERATION as DEFAULT_MAX_ACCELERATION
from ._health import check_state as check_state
from ._options import TIMESTEP as TIMESTEP
from ._options import configure_physics as configure_physics
from ._state import hold_servos as hold_servos
from ._state import is_position_servo as is_position_servo
from ._state import joint_positions as joint_positions
from ._state import set_joint_positions as set_joint_positions
from ._state import site_pose as site_pose

__all__ = [
    "DEFAULT_MAX_ACCELERATION",
    "TIMESTEP",
    "RobotContact",
    "RobotContacts",
    "check_state",
    "configure_physics",
    "hold_servos",
    "is_position_servo",
    "joint_positions",
    "set_joint_positions",
    "site_pose",
]
