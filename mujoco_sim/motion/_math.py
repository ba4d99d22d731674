"""Small maths the controllers share: minimum-jerk timing, quaternions, planar footprints,
and :func:`tool_down`, the usual grasp-from-above tool pose.

Quaternions here are MuJoCo's ``(w, x, y, z)`` numpy arrays; :class:`WorldPose` on the device
interfaces stores ``(x, y, z, w)``: convert with :func:`pose_of` / :func:`quat_wxyz`.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from typing import TypeAlias

import mujoco
import numpy as np
import numpy.typing as npt

from device_drivers import WorldPose
from mujoco_sim.ik._core import TcpTarget
from scenario import Footprint

__all__ = [
    "PEAK_SPEED",
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

Array: TypeAlias = npt.NDArray[np.float64]

PEAK_SPEED = 1.875
"""Peak speed of a minimum-jerk move, in units of (distance / duration)."""


def minjerk(s: float) -> float:
    """Minimum-jerk progress (position fraction) at time fraction ``s`` (clipped to 0..1)."""
    s = min(max(s, 0.0), 1.0)
    return s * s * s * (10.0 + s * (-15.0 + 6.0 * s))


def minjerk_rate(s: float) -> float:
    """d(minjerk)/ds at ``s``: multiply by distance / duration for the speed."""
    s = min(max(s, 0.0), 1.0)
    return 30.0 * s * s * (1.0 - s) * (1.0 - s)


def wrap(angle: float) -> float:
    """``angle`` wrapped to (-pi, pi]."""
    return math.atan2(math.sin(angle), math.cos(angle))


def quat_mul(a: Array, b: Array) -> Array:
    w1, x1, y1, z1 = a
    w2, x2, y2, z2 = b
    return np.array(
        [
            w1 * w2 - x1 * x2 - y1 * y2 - z1 * z2,
            w1 * x2 + x1 * w2 + y1 * z2 - z1 * y2,
            w1 * y2 - x1 * z2 + y1 * w2 + z1 * x2,
            w1 * z2 + x1 * y2 - y1 * x2 + z1 * w2,
        ]
    )


def quat_conj(q: Array) -> Array:
    return np.array([q[0], -q[1], -q[2], -q[3]])


def slerp(a: Array, b: Array, t: float) -> Array:
    """Spherical interpolation between unit quaternions ``a`` and ``b`` (shortest way)."""
    dot = float(a @ b)
    if dot < 0.0:
        b, dot = -b, -dot
    if dot > 0.9995:
        q = a + t * (b - a)
        return np.asarray(q / np.linalg.norm(q), dtype=np.float64)
    theta = math.acos(dot)
    q = (math.sin((1 - t) * theta) * a + math.sin(t * theta) * b) / math.sin(theta)
    return np.asarray(q, dtype=np.float64)


def quat_angle(a: Array, b: Array) -> float:
    """Rotation angle between unit quaternions ``a`` and ``b``, rad."""
    return 2.0 * math.acos(min(1.0, abs(float(a @ b))))


def quat_wxyz(pose: WorldPose) -> Array:
    """The unit quaternion of ``pose`` as MuJoCo's (w, x, y, z)."""
    q = np.array([pose.qw, pose.qx, pose.qy, pose.qz], dtype=np.float64)
    norm = float(np.linalg.norm(q))
    if norm < 1e-9:
        raise ValueError("the pose's quaternion is zero")
    return np.asarray(q / norm, dtype=np.float64)


def pose_of(pos: Sequence[float] | Array, quat_wxyz_: Sequence[float] | Array) -> WorldPose:
    """A :class:`WorldPose` from a position and a MuJoCo (w, x, y, z) quaternion."""
    w, x, y, z = (float(v) for v in quat_wxyz_)
    return WorldPose(float(pos[0]), float(pos[1]), float(pos[2]), x, y, z, w)


def tcp_target(pose: WorldPose) -> TcpTarget:
    """The IK target of a tool pose (position and full orientation)."""
    w, x, y, z = (float(v) for v in quat_wxyz(pose))
    return TcpTarget(position=(pose.x, pose.y, pose.z), quat=(w, x, y, z))


def tool_down(x: float, y: float, z: float, yaw: float = 0.0) -> WorldPose:
    """A tool pose at ``(x, y, z)`` with the gripper pointing straight down and its fingers
    closing along the world direction ``yaw`` (0: along x). The usual grasp from above."""
    c, s = math.cos(yaw), math.sin(yaw)
    rot = np.array([[-s, c, 0.0], [c, s, 0.0], [0.0, 0.0, -1.0]])  # columns: tcp x, y, z
    quat = np.zeros(4)
    mujoco.mju_mat2Quat(quat, rot.ravel())
    return pose_of((x, y, z), quat)


def rect_corners(x: float, y: float, yaw: float, hx: float, hy: float) -> Array:
    """The 4 corners (4x2) of a rectangle centred at (x, y), turned by ``yaw``."""
    c, s = math.cos(yaw), math.sin(yaw)
    local = np.array([[hx, hy], [-hx, hy], [-hx, -hy], [hx, -hy]])
    return np.asarray(local @ np.array([[c, s], [-s, c]]) + [x, y], dtype=np.float64)


def rects_overlap(a: Array, b: Array) -> bool:
    """Whether two convex quadrilaterals (4x2 corners, in order) overlap (separating axes)."""
    for poly in (a, b):
        for i in range(4):
            edge = poly[(i + 1) % 4] - poly[i]
            axis = np.array([-edge[1], edge[0]])
            pa, pb = a @ axis, b @ axis
            if pa.max() < pb.min() or pb.max() < pa.min():
                return False
    return True


def footprint_corners(f: Footprint, margin: float = 0.0) -> Array:
    return rect_corners(f.x, f.y, f.yaw, f.hx + margin, f.hy + margin)
