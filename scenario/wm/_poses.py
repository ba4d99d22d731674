"""Rotation helpers of the scene builder (world frame, quaternions ``(x, y, z, w)``, the order of
the world model's :class:`~wm_store.protocol.Orientation`)."""

from __future__ import annotations

import math

from wm_store.protocol import Orientation, Pose, Position
from wm_store.reasoners import Transform

__all__ = ["quat_from_axes", "quat_from_yaw", "to_wm_pose"]

Vec3 = tuple[float, float, float]
Quat = tuple[float, float, float, float]


def quat_from_axes(x: Vec3, y: Vec3, z: Vec3) -> Quat:
    """The rotation whose columns are the orthonormal axes ``x``, ``y``, ``z`` (Shepperd's
    method, numerically safe for every rotation)."""
    m00, m10, m20 = x
    m01, m11, m21 = y
    m02, m12, m22 = z
    trace = m00 + m11 + m22
    if trace > 0:
        s = 2.0 * math.sqrt(trace + 1.0)
        q = ((m21 - m12) / s, (m02 - m20) / s, (m10 - m01) / s, 0.25 * s)
    elif m00 > m11 and m00 > m22:
        s = 2.0 * math.sqrt(1.0 + m00 - m11 - m22)
        q = (0.25 * s, (m01 + m10) / s, (m02 + m20) / s, (m21 - m12) / s)
    elif m11 > m22:
        s = 2.0 * math.sqrt(1.0 + m11 - m00 - m22)
        q = ((m01 + m10) / s, 0.25 * s, (m12 + m21) / s, (m02 - m20) / s)
    else:
        s = 2.0 * math.sqrt(1.0 + m22 - m00 - m11)
        q = ((m02 + m20) / s, (m12 + m21) / s, 0.25 * s, (m10 - m01) / s)
    n = math.sqrt(sum(c * c for c in q))
    qx, qy, qz, qw = (c / n for c in q)
    return (qx, qy, qz, qw) if qw >= 0 else (-qx, -qy, -qz, -qw)


def quat_from_yaw(yaw: float) -> Quat:
    """Rotation by ``yaw`` radians about the world z axis."""
    return (0.0, 0.0, math.sin(yaw / 2), math.cos(yaw / 2))


def to_wm_pose(t: Transform) -> Pose:
    """A world-frame world-model :class:`Pose` (frame ``""``)."""
    x, y, z = (float(c) for c in t.translation)
    qx, qy, qz, qw = (float(c) for c in t.rotation)
    return Pose(Position(x, y, z), Orientation(qx, qy, qz, qw))
