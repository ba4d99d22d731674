"""Pose maths the primitives share (pure, quick, no I/O).

Frames and units: every pose here is in the **world** frame, positions in metres, quaternions
``(x, y, z, w)`` (the order of :class:`~device_drivers.WorldPose` and of the world
model's :class:`~wm_store.protocol.Orientation`). The tool centre point (tcp) frame of a
gripper has its z axis along the approach direction and its y axis along the finger closing
axis (``scenario.RobotLayout.tcp_site``).

Rigid transforms are :class:`wm_store.reasoners.Transform` (rotate, then translate),
so the skill layer and the world model's spatial reasoner compose poses the same way.
"""

from __future__ import annotations

import math

from device_drivers import WorldPose
from wm_store.protocol import Orientation, Pose, Position
from wm_store.reasoners import Transform, quat_multiply, quat_rotate

__all__ = [
    "Quat",
    "Vec3",
    "axis",
    "compose",
    "cross",
    "dot",
    "rotated_z",
    "to_transform",
    "to_wm_pose",
    "to_world_pose",
    "translated",
    "unit",
    "yaw_of",
]

Vec3 = tuple[float, float, float]
Quat = tuple[float, float, float, float]


def unit(v: Vec3) -> Vec3:
    """``v`` scaled to length 1; ValueError for a zero vector."""
    n = math.sqrt(v[0] * v[0] + v[1] * v[1] + v[2] * v[2])
    if n < 1e-12:
        raise ValueError("a direction must not be the zero vector")
    return (v[0] / n, v[1] / n, v[2] / n)


def cross(a: Vec3, b: Vec3) -> Vec3:
    return (a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0])


def dot(a: Vec3, b: Vec3) -> float:
    return a[0] * b[0] + a[1] * b[1] + a[2] * b[2]


def axis(q: Quat, index: int) -> Vec3:
    """Column ``index`` (0 = x, 1 = y, 2 = z) of the rotation ``q``: where that body axis
    points in the world."""
    basis: Vec3 = ((1.0, 0.0, 0.0), (0.0, 1.0, 0.0), (0.0, 0.0, 1.0))[index]
    return quat_rotate(q, basis)


def yaw_of(q: Quat) -> float:
    """Heading (rad) of the body x axis projected on the floor."""
    x = axis(q, 0)
    return math.atan2(x[1], x[0])


def to_transform(pose: WorldPose | Pose) -> Transform:
    """A device or world-model pose as a transform (the world-model pose's frame is ignored:
    pass world poses, e.g. from ``wm.spatial.world_pose``)."""
    if isinstance(pose, WorldPose):
        position = (pose.x, pose.y, pose.z)
        rotation = (pose.qx, pose.qy, pose.qz, pose.qw)
    else:
        p, o = pose.position, pose.orientation
        position, rotation = (p.x, p.y, p.z), (o.x, o.y, o.z, o.w)
    x, y, z = (float(c) for c in position)  # drivers may hand numpy floats
    return Transform((x, y, z), _normalised(rotation))


def to_world_pose(t: Transform) -> WorldPose:
    x, y, z = (float(c) for c in t.translation)
    qx, qy, qz, qw = (float(c) for c in t.rotation)
    return WorldPose(x, y, z, qx, qy, qz, qw)


def to_wm_pose(pose: WorldPose | Transform) -> Pose:
    """A world-frame world-model :class:`Pose` (frame ``""``)."""
    t = pose if isinstance(pose, Transform) else to_transform(pose)
    x, y, z = (float(c) for c in t.translation)
    qx, qy, qz, qw = (float(c) for c in t.rotation)
    return Pose(Position(x, y, z), Orientation(qx, qy, qz, qw))


def translated(pose: WorldPose, offset: Vec3) -> WorldPose:
    """``pose`` moved by ``offset`` (world frame, m); orientation kept."""
    return WorldPose(
        pose.x + offset[0],
        pose.y + offset[1],
        pose.z + offset[2],
        pose.qx,
        pose.qy,
        pose.qz,
        pose.qw,
    )


def rotated_z(pose: WorldPose) -> Vec3:
    """The tcp's approach direction (its z axis) in the world."""
    return axis((pose.qx, pose.qy, pose.qz, pose.qw), 2)


def compose(a: Quat, b: Quat) -> Quat:
    """``a ⊗ b`` (apply ``b`` first)."""
    return quat_multiply(a, b)


def _normalised(q: Quat) -> Quat:
    n = math.sqrt(sum(c * c for c in q))
    if n < 1e-12 or not math.isfinite(n):
        raise ValueError(f"not a rotation quaternion: {q}")
    qx, qy, qz, qw = (float(c) / n for c in q)
    return (qx, qy, qz, qw)
