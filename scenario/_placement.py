"""World poses of a scenario's elements at the start (pure maths on the scenario; no MuJoCo).

Each element's :class:`~scenario.Placement` is relative to its parent's support
surface; :func:`resolve_placements` chains them into world poses of each element's bottom
centre. :func:`object_centres` gives the centres instead (the world model's pose convention).

Support surfaces, in the parent's own frame (origin at its bottom centre, or for a robot on the
floor under its base centre): furniture top ``(0, 0, top)``; container and appliance inner
floor ``(0, 0, wall)``; robot deck point :func:`deck_point`.
"""

from __future__ import annotations

import math

from msgspec import Struct

from scenario._robot_spec import RobotSpec
from scenario._schema import Scenario

__all__ = [
    "Footprint",
    "WorldPlacement",
    "deck_point",
    "footprints",
    "object_centres",
    "resolve_placements",
]


class WorldPlacement(Struct, frozen=True):
    """World pose of an element's bottom centre at the start, and what it rests on.

    ``robot`` names the robot that carries it rigidly (a container on a deck); ``local`` is
    then its pose in that robot's base frame ``(x, y, z, yaw)``.
    """

    x: float
    y: float
    z: float
    yaw: float
    parent: str = ""
    robot: str = ""
    local: tuple[float, float, float, float] = (0.0, 0.0, 0.0, 0.0)


class Footprint(Struct, frozen=True):
    """An obstacle on the floor: a rectangle centred at ``(x, y)`` turned by ``yaw``, half
    sizes ``hx``, ``hy`` (m)."""

    label: str
    x: float
    y: float
    yaw: float
    hx: float
    hy: float


def deck_point(spec: RobotSpec) -> tuple[float, float, float]:
    """The free middle of the deck behind the arm pedestal, in the base frame (the same point
    as the model's ``<name>/deck`` site; a test keeps the two equal)."""
    return ((-spec.base_length / 2 + spec.arm_mount_x - 0.08) / 2, 0.0, spec.base_height)


def _compose(
    frame: tuple[float, float, float, float], local: tuple[float, float, float, float]
) -> tuple[float, float, float, float]:
    x, y, z, yaw = frame
    lx, ly, lz, lyaw = local
    c, s = math.cos(yaw), math.sin(yaw)
    return (x + c * lx - s * ly, y + s * lx + c * ly, z + lz, yaw + lyaw)


def resolve_placements(s: Scenario) -> dict[str, WorldPlacement]:
    """World placements of every furniture, container, part and appliance (by label). Assumes
    a checked scenario (:func:`~scenario.check_scenario`)."""
    out: dict[str, WorldPlacement] = {}
    robots = {r.name: r for r in s.robots}
    furniture = {f.label: f for f in s.furniture}
    containers = {c.label: c for c in s.containers}
    appliances = {a.label: a for a in s.appliances}
    for f in s.furniture:
        out[f.label] = WorldPlacement(f.pose.x, f.pose.y, 0.0, f.pose.yaw)

    def support(label: str) -> tuple[tuple[float, float, float, float], str]:
        """World frame of ``label``'s support surface, and the robot carrying it."""
        if label in robots:
            r = robots[label]
            dx, dy, dz = deck_point(r.spec)
            return _compose((r.pose.x, r.pose.y, 0.0, r.pose.yaw), (dx, dy, dz, 0.0)), label
        if label in furniture:
            p = out[label]
            return (p.x, p.y, furniture[label].top, p.yaw), ""
        holder = container(label) if label in containers else appliance(label)
        wall = containers[label].wall if label in containers else appliances[label].wall
        return (holder.x, holder.y, holder.z + wall, holder.yaw), holder.robot

    def place(label: str, parent: str, pose: tuple[float, float, float, float]) -> WorldPlacement:
        if not parent:
            return WorldPlacement(pose[0], pose[1], pose[2], pose[3])
        frame, robot = support(parent)
        x, y, z, yaw = _compose(frame, pose)
        local = (0.0, 0.0, 0.0, 0.0)
        if robot and parent == robot:
            dx, dy, dz = deck_point(robots[robot].spec)
            local = _compose((dx, dy, dz, 0.0), pose)
        return WorldPlacement(x, y, z, yaw, parent=parent, robot=robot, local=local)

    def container(label: str) -> WorldPlacement:
        if label not in out:
            c = containers[label]
            out[label] = place(label, c.parent, (c.pose.x, c.pose.y, c.pose.z, c.pose.yaw))
        return out[label]

    def appliance(label: str) -> WorldPlacement:
        if label not in out:
            a = appliances[label]
            out[label] = place(label, a.parent, (a.pose.x, a.pose.y, a.pose.z, a.pose.yaw))
        return out[label]

    for c in s.containers:
        container(c.label)
    for a in s.appliances:
        appliance(a.label)
    for p in s.parts:
        placed = place(p.label, p.parent, (p.pose.x, p.pose.y, p.pose.z, p.pose.yaw))
        # parts are free bodies: they never ride rigidly on a robot, whatever their holder does
        out[p.label] = WorldPlacement(placed.x, placed.y, placed.z, placed.yaw, parent=p.parent)
    return out


def object_centres(s: Scenario) -> dict[str, tuple[float, float, float, float]]:
    """World ``(x, y, z, yaw)`` of the *centre* of every furniture, container, part and
    appliance at the start: the pose convention of the world model (placements are bottom
    centres)."""
    heights = {f.label: f.top for f in s.furniture}
    heights.update({c.label: c.size[2] for c in s.containers})
    heights.update({p.label: p.height for p in s.parts})
    heights.update({a.label: a.size[2] for a in s.appliances})
    return {
        label: (p.x, p.y, p.z + heights[label] / 2, p.yaw)
        for label, p in resolve_placements(s).items()
    }


def footprints(s: Scenario) -> list[Footprint]:
    """The floor obstacles a mobile base must avoid: solid furniture and floor-standing
    fixed containers and appliances."""
    found = [
        Footprint(f.label, f.pose.x, f.pose.y, f.pose.yaw, f.size[0] / 2, f.size[1] / 2)
        for f in s.furniture
        if f.kind != "area"
    ]
    for c in s.containers:
        if not c.parent and c.fixed:
            found.append(Footprint(c.label, c.pose.x, c.pose.y, c.pose.yaw, *_half(c.size)))
    for a in s.appliances:
        if not a.parent:
            found.append(Footprint(a.label, a.pose.x, a.pose.y, a.pose.yaw, *_half(a.size)))
    return found


def _half(size: tuple[float, float, float]) -> tuple[float, float]:
    return size[0] / 2, size[1] / 2
