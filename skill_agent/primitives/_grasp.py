"""Grasp and release poses from an object's pose, size and the ontology's grasp data (pure).

Frames and units: world frame, metres, quaternions ``(x, y, z, w)``. An object's pose is the
*centre* of its bounding volume (the world model's convention, ``wm_store.reasoners``);
its ``size`` is a ``SizeCuboid`` (x, y, z), ``SizeCylinder`` (radius, height along z) or
``SizeSphere`` in its own frame. The tcp frame: z = approach direction, y = finger closing axis.

:func:`plan_grasp` chooses the grasp:

- the object's ``graspPose`` (the tcp pose *relative to the object*, prior knowledge such as
  CAD grasp data) when the world model has one;
- otherwise **top-down**: the gripper points down (tcp z = world -z) over the object's centre;
  the fingers close across the narrower horizontal side that fits between them (a cuboid), or
  across the *shorter* horizontal side of the holder (a cylinder or sphere standing in a row
  along a box's long side, so the open fingers clear its neighbours); the pads' middle sits at
  the object's middle height, but at least ``pad_half_height + floor_clearance`` above its
  bottom, so the pads never touch the surface it stands on.

``graspWidth`` (the opening the object needs) is used when given, else derived from the size.
:func:`release_pose` and :func:`free_spot` / :func:`free_spots` (inside a container) or
:func:`surface_spots` (on top of a surface) plan where a held object goes down.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from typing import Literal

from msgspec import Struct

from device_drivers import WorldPose
from skill_agent._errors import SkillError
from skill_agent.primitives.poses import (
    Vec3,
    axis,
    cross,
    dot,
    to_transform,
    to_world_pose,
    translated,
)
from wm_store.protocol import Pose, SizeCuboid, SizeCylinder, SizeSphere, Value
from wm_store.reasoners import Transform, quat_from_axes

__all__ = [
    "Grasp",
    "GripperGeometry",
    "NoGraspError",
    "extents",
    "footprint_radius",
    "free_spot",
    "free_spots",
    "plan_grasp",
    "release_pose",
    "surface_spots",
]

_UPRIGHT = math.cos(math.radians(20.0))
_DOWN: Vec3 = (0.0, 0.0, -1.0)


class NoGraspError(SkillError):
    """No grasp fits: the object is wider than the gripper opens, tipped over, or has no size
    (raised before anything moves; the skills that plan grasps catch it and fail the run)."""


class GripperGeometry(Struct, frozen=True, kw_only=True):
    """What grasp planning needs to know of a parallel gripper (defaults: the generated robot's,
    ``scenario.RobotSpec`` and ``gripper_model``), metres."""

    max_opening: float = 0.085
    """Distance between the pads fully open."""
    pad_half_height: float = 0.02
    """Half the pads' length along the approach axis (the tcp is at the pads' middle)."""
    floor_clearance: float = 0.003
    """Gap kept between the pads' ends and the surface the object stands on."""
    width_margin: float = 0.008
    """An object must be this much narrower than ``max_opening`` to be grasped."""


class Grasp(Struct, frozen=True, kw_only=True):
    """A planned grasp: the tcp pose (world), the object's width across the fingers, and the
    object's pose in the tcp frame once grasped (used to put it down again)."""

    tcp: WorldPose
    width: float
    object_in_tcp: Transform
    strategy: Literal["graspPose", "top-down"]

    @property
    def approach(self) -> Vec3:
        """Unit approach direction (tcp z) in the world."""
        return axis((self.tcp.qx, self.tcp.qy, self.tcp.qz, self.tcp.qw), 2)


def extents(size: Value) -> Vec3 | None:
    """Full bounding-box extents (x, y, z) of a size value in the object's frame, or None."""
    match size:
        case SizeCuboid(x=x, y=y, z=z):
            return (x, y, z)
        case SizeCylinder(radius=r, height=h):
            return (2 * r, 2 * r, h)
        case SizeSphere(radius=r):
            return (2 * r, 2 * r, 2 * r)
    return None


def footprint_radius(size: Value) -> float:
    """Radius of the circle covering the object's floor footprint (m); 0.03 if unknown."""
    match size:
        case SizeCuboid(x=x, y=y):
            return math.hypot(x, y) / 2
        case SizeCylinder(radius=r) | SizeSphere(radius=r):
            return r
    return 0.03


def plan_grasp(
    obj: Transform,
    size: Value,
    *,
    grasp_pose: Pose | None = None,
    grasp_width: float | None = None,
    holder: tuple[Transform, Vec3] | None = None,
    current: WorldPose | None = None,
    geometry: GripperGeometry = GripperGeometry(),  # noqa: B008  # frozen Struct: immutable
) -> Grasp:
    """The grasp of an object at ``obj`` (world pose of its centre) with ``size`` (see the
    module doc). ``holder``: the world pose and extents of what the object stands in;
    ``current``: the tcp now (of the two symmetric finger orientations, the one closer to it
    is chosen). Raises :class:`NoGraspError`."""
    ext = extents(size)
    if grasp_pose is not None:
        tcp = obj.compose(to_transform(grasp_pose))
        closing = axis(tcp.rotation, 1)
        width = grasp_width
        if width is None:
            width = _width_along(obj, ext, closing) if ext is not None else 0.0
        return _grasp(tcp, obj, width, "graspPose", geometry)
    if ext is None:
        raise NoGraspError("the object has no size (and no graspPose): cannot plan a grasp")
    up = axis(obj.rotation, 2)
    if up[2] < _UPRIGHT:
        raise NoGraspError(f"the object is tipped over (its z axis is {up}); no top-down grasp")
    closing, width = _closing_axis(obj, size, ext, holder, geometry)
    if current is not None and dot(axis(_rotation(current), 1), closing) < 0:
        closing = (-closing[0], -closing[1], -closing[2])
    x_axis = cross(closing, _DOWN)
    bottom = obj.translation[2] - ext[2] / 2
    z = bottom + max(ext[2] / 2, geometry.pad_half_height + geometry.floor_clearance)
    tcp = Transform(
        (obj.translation[0], obj.translation[1], z), quat_from_axes(x_axis, closing, _DOWN)
    )
    return _grasp(tcp, obj, grasp_width if grasp_width is not None else width, "top-down", geometry)


def _grasp(
    tcp: Transform,
    obj: Transform,
    width: float,
    strategy: Literal["graspPose", "top-down"],
    geometry: GripperGeometry,
) -> Grasp:
    if width > geometry.max_opening - geometry.width_margin:
        raise NoGraspError(
            f"the object is {width * 1000:.0f} mm across the fingers; the gripper opens "
            f"{geometry.max_opening * 1000:.0f} mm (needs {geometry.width_margin * 1000:.0f} mm "
            "to spare)"
        )
    return Grasp(
        tcp=to_world_pose(tcp),
        width=width,
        object_in_tcp=tcp.inverse().compose(obj),
        strategy=strategy,
    )


def _rotation(pose: WorldPose) -> tuple[float, float, float, float]:
    return (pose.qx, pose.qy, pose.qz, pose.qw)


def _horizontal(v: Vec3) -> Vec3:
    n = math.hypot(v[0], v[1])
    return (v[0] / n, v[1] / n, 0.0) if n > 1e-9 else (1.0, 0.0, 0.0)


def _closing_axis(
    obj: Transform,
    size: Value,
    ext: Vec3,
    holder: tuple[Transform, Vec3] | None,
    geometry: GripperGeometry,
) -> tuple[Vec3, float]:
    """Closing direction (horizontal, world) and the object's width along it."""
    x_axis, y_axis = _horizontal(axis(obj.rotation, 0)), _horizontal(axis(obj.rotation, 1))
    if isinstance(size, SizeCuboid):
        fits = geometry.max_opening - geometry.width_margin
        options = sorted([(ext[0], x_axis), (ext[1], y_axis)], key=lambda o: o[0])
        width, direction = options[0]
        if width > fits:
            raise NoGraspError(
                f"the object is {ext[0] * 1000:.0f} x {ext[1] * 1000:.0f} mm; neither side fits "
                f"the gripper's {geometry.max_opening * 1000:.0f} mm"
            )
        return direction, width
    if holder is not None:
        pose, hext = holder
        hx, hy = _horizontal(axis(pose.rotation, 0)), _horizontal(axis(pose.rotation, 1))
        return (hx if hext[0] <= hext[1] else hy), ext[0]
    return x_axis, ext[0]


def _width_along(obj: Transform, ext: Vec3, direction: Vec3) -> float:
    """Width of the object's bounding box along a world direction."""
    return sum(abs(dot(axis(obj.rotation, i), direction)) * ext[i] for i in range(3))


def release_pose(
    tcp_now: WorldPose, object_in_tcp: Transform, bottom_target: Vec3, height: float
) -> WorldPose:
    """Where the tcp goes so that the held object's bottom centre reaches ``bottom_target``
    (world, m), keeping the present orientation. ``object_in_tcp``: the object's pose in the
    tcp frame (:attr:`Grasp.object_in_tcp`); ``height``: the object's height (m), upright."""
    obj_now = to_transform(tcp_now).compose(object_in_tcp)
    x, y, z = obj_now.translation
    bottom = (x, y, z - height / 2)
    return translated(
        tcp_now,
        (
            bottom_target[0] - bottom[0],
            bottom_target[1] - bottom[1],
            bottom_target[2] - bottom[2],
        ),
    )


def free_spots(
    container: Transform,
    ext: Vec3,
    radius: float,
    occupied: Sequence[tuple[Vec3, float]] = (),
    *,
    wall: float = 0.008,
    gap: float = 0.012,
) -> list[Vec3]:
    """Free points on the container's inner floor (world, m) for an object of footprint
    ``radius``: on a grid over the floor, away from the walls and from each ``(position,
    radius)`` in ``occupied`` by ``gap``; nearest the centre first. ``container`` is the
    world pose of the container's centre, ``ext`` its outside extents."""
    hx, hy = ext[0] / 2 - wall - radius - gap / 2, ext[1] / 2 - wall - radius - gap / 2
    return _spots(container, hx, hy, -ext[2] / 2 + wall, radius, occupied, gap, None)


def surface_spots(
    surface: Transform,
    ext: Vec3,
    radius: float,
    occupied: Sequence[tuple[Vec3, float]] = (),
    *,
    edge: float = 0.03,
    gap: float = 0.012,
    near: Vec3 | None = None,
) -> list[Vec3]:
    """Free points on the *top* of a surface (a shelf board, a table; world, m) for an object
    of footprint ``radius``: on a grid over the top, ``edge`` m in from its edges and away
    from each ``(position, radius)`` in ``occupied`` (what stands on it: boxes, parts) by
    ``gap``. Nearest ``near`` first (a world point, compared on the floor plane: the robot,
    so the most reachable spots come first), else nearest the centre. ``surface`` is the
    world pose of the surface's centre, ``ext`` its extents (the top is at ``+ext[2] / 2``)."""
    hx, hy = ext[0] / 2 - edge - radius, ext[1] / 2 - edge - radius
    return _spots(surface, hx, hy, ext[2] / 2, radius, occupied, gap, near)


def _spots(
    frame: Transform,
    hx: float,
    hy: float,
    z: float,
    radius: float,
    occupied: Sequence[tuple[Vec3, float]],
    gap: float,
    near: Vec3 | None,
) -> list[Vec3]:
    """Grid points ``(lx, ly, z)`` of ``frame`` within ``|lx| <= hx``, ``|ly| <= hy``, clear of
    ``occupied``, as world points sorted by distance to ``near`` (or to the frame's centre)."""
    if hx < 0 or hy < 0:
        return []
    step = 2 * radius + gap
    found: list[tuple[float, Vec3]] = []
    for lx in _grid(hx, step):
        for ly in _grid(hy, step):
            point = frame.apply((lx, ly, z))
            clear = all(
                math.hypot(point[0] - p[0], point[1] - p[1]) >= radius + r + gap
                for p, r in occupied
            )
            if clear:
                key = (
                    math.hypot(lx, ly)
                    if near is None
                    else math.hypot(point[0] - near[0], point[1] - near[1])
                )
                found.append((key, point))
    return [point for _, point in sorted(found, key=lambda f: f[0])]


def free_spot(
    container: Transform,
    ext: Vec3,
    radius: float,
    occupied: Sequence[tuple[Vec3, float]] = (),
    *,
    wall: float = 0.008,
    gap: float = 0.012,
) -> Vec3 | None:
    """The first of :func:`free_spots` (nearest the centre), or None: no room."""
    spots = free_spots(container, ext, radius, occupied, wall=wall, gap=gap)
    return spots[0] if spots else None


def _grid(half: float, step: float) -> list[float]:
    """Symmetric grid points in ``[-half, half]`` including 0."""
    n = int(half // step) if step > 0 else 0
    points = [k * step for k in range(-n, n + 1)]
    return sorted({*points, -half, half, 0.0})
