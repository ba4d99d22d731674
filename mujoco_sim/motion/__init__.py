"""Motion maths of the controllers: minimum-jerk timing and pose helpers, collision-checked
joint-space paths and routes, and the tcp tracker that follows a Cartesian path with IK.
"""

from __future__ import annotations

from ._joint_path import JointPathCheck as JointPathCheck
from ._joint_path import PathHit as PathHit
from ._joint_route import JointRouter as JointRouter
from ._joint_route import TimedRoute as TimedRoute
from ._math import PEAK_SPEED as PEAK_SPEED
from ._math import footprint_corners as footprint_corners
from ._math import minjerk as minjerk
from ._math import minjerk_rate as minjerk_rate
from ._math import pose_of as pose_of
from ._math import quat_angle as quat_angle
from ._math import quat_conj as quat_conj
from ._math import quat_mul as quat_mul
from ._math import quat_wxyz as quat_wxyz
from ._math import rect_corners as rect_corners
from ._math import rects_overlap as rects_overlap
from ._math import slerp as slerp
from ._math import tcp_target as tcp_target
from ._math import tool_down as tool_down
from ._math import wrap as wrap
from ._tcp_tracker import TcpTracker as TcpTracker

__all__ = [
    "PEAK_SPEED",
    "JointPathCheck",
    "JointRouter",
    "PathHit",
    "TcpTracker",
    "TimedRoute",
    "footprint_corners",
    "minjerk",
    "minjerk_rate",
    "pose_of",
    "quat_angle",
    "quat_conj",
    "quat_mul",
    "quat_wxyz",
    "rect_corners",
    "rects_overlap",
    "slerp",
    "tcp_target",
    "tool_down",
    "wrap",
]
