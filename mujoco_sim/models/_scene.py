"""The MuJoCo world of a scenario (MjSpec): robots, furniture, containers, parts, appliances,
fixed cameras and the grasp welds.

Names (MuJoCo body = scenario label, so the world model's labels find their bodies)::

    <Label>                        body of a furniture, container, part or appliance
    <Label>/top                    support geom of a furniture (contact surface of a platform)
    <Label>/door                   microwave door body, hinge joint and door motor (actuator)
    <Drawer label>, <...>/slide    a cabinet's drawer body and its slide joint (drawer_model)
    <robot>/grasp/<Label>          weld equality gripper -> graspable object, inactive at start
    <Label>                        site + camera of a fixed camera

Bodies: a part's origin is its centre; a container's and an appliance's is their bottom centre
(the frame :class:`~scenario.Placement` uses). Parts and movable containers
have a free joint; a container whose parent is a robot is a child body of ``<robot>/base``
(carried rigidly); ``fixed`` containers, furniture and appliances have no joint.
"""

from __future__ import annotations

import math
from collections.abc import Sequence

import mujoco
import numpy as np

from device_drivers import ModelError
from mujoco_sim.models._drawer import add_cabinet
from mujoco_sim.models._robot import build_world
from scenario import (
    DOOR_HANDLE_INSET,
    DOOR_HANDLE_STANDOFF,
    ApplianceEntry,
    ContainerEntry,
    FurnitureEntry,
    PartEntry,
    Scenario,
    SensorEntry,
    WorldPlacement,
    resolve_placements,
    robot_layout,
)

__all__ = ["build_scene", "graspable_labels", "look_at_quat", "weld_name"]

_BOX = mujoco.mjtGeom.mjGEOM_BOX
_VISUAL = {"contype": 0, "conaffinity": 0, "group": 1}
_SLAB = 0.03  # furniture board thickness, m


def weld_name(robot: str, label: str) -> str:
    """Name of the (inactive) weld that attaches ``label`` to ``robot``'s gripper."""
    return f"{robot}/grasp/{label}"


def graspable_labels(s: Scenario) -> list[str]:
    """Objects a gripper may attach: every part and every free (movable) container."""
    return [p.label for p in s.parts] + [
        c.label for c in s.containers if not c.fixed and c.parent not in {r.name for r in s.robots}
    ]


def _quat(yaw: float) -> list[float]:
    return [math.cos(yaw / 2), 0.0, 0.0, math.sin(yaw / 2)]


def look_at_quat(position: Sequence[float], target: Sequence[float]) -> list[float]:
    """(w, x, y, z) of a camera frame at ``position`` whose -z looks at ``target``, x level."""
    view = np.asarray(target, float) - np.asarray(position, float)
    z = -view / np.linalg.norm(view)
    x = np.cross([0.0, 0.0, 1.0], z)
    x = x / np.linalg.norm(x) if np.linalg.norm(x) > 1e-9 else np.array([1.0, 0.0, 0.0])
    y = np.cross(z, x)
    quat = np.zeros(4)
    mujoco.mju_mat2Quat(quat, np.column_stack([x, y, z]).ravel())
    return [float(q) for q in quat]


def build_scene(s: Scenario) -> mujoco.MjSpec:
    """The world of ``s`` (a checked scenario) as an uncompiled-after-edit ``MjSpec``.

    Raises:
        ModelError: the world does not compile (names the scenario).
    """
    world = build_world([(r.spec, r.pose) for r in s.robots], floor_size=s.floor_size)
    placed = resolve_placements(s)
    for f in s.furniture:
        _furniture(world, f, placed[f.label])
    for c in s.containers:
        p = placed[c.label]
        if p.robot:
            x, y, z, yaw = p.local
            body = world.body(f"{p.robot}/base").add_body(
                name=c.label, pos=[x, y, z], quat=_quat(yaw)
            )
        else:
            body = world.worldbody.add_body(name=c.label, pos=[p.x, p.y, p.z], quat=_quat(p.yaw))
            if not c.fixed:
                body.add_freejoint(name=c.label)
        _container(body, c)
    for part in s.parts:
        _part(world.worldbody, part, placed[part.label])
    for a in s.appliances:
        _appliance(world, a, placed[a.label])
    for sensor in s.sensors:
        if sensor.kind == "camera" and not sensor.mount:
            _fixed_camera(world, sensor)
    for robot in s.robots:
        for label in graspable_labels(s):
            weld = world.add_equality(
                name=weld_name(robot.name, label),
                type=mujoco.mjtEq.mjEQ_WELD,
                objtype=mujoco.mjtObj.mjOBJ_BODY,
                name1=robot_layout(robot.spec).hand_body,
                name2=label,
                active=False,
            )
            # anchor 0, explicit relpose (identity: set again at attach), torquescale 1
            weld.data[0:11] = [0, 0, 0, 0, 0, 0, 1, 0, 0, 0, 1]
            weld.solref = [0.005, 1.0]
    # Islands at rest (parts in their boxes) sleep: faster stepping for the kitting scene (see
    # docs/benchmarks.md, section Simulation). A contact with an awake body or an activated
    # weld wakes them.
    world.option.enableflags |= mujoco.mjtEnableBit.mjENBL_SLEEP
    try:
        world.compile()
    except ValueError as exc:
        raise ModelError(f"the scenario's world does not compile: {exc}", source=s.name) from exc
    return world


def _box(
    body: mujoco.MjsBody, name: str, half: Sequence[float], pos: Sequence[float], **kw: object
) -> None:
    body.add_geom(name=name, type=_BOX, size=list(half), pos=list(pos), **kw)


def _furniture(world: mujoco.MjSpec, f: FurnitureEntry, p: WorldPlacement) -> None:
    body = world.worldbody.add_body(name=f.label, pos=[p.x, p.y, 0.0], quat=_quat(p.yaw))
    hx, hy, top = f.size[0] / 2, f.size[1] / 2, f.top
    rgba = list(f.rgba)
    if f.kind == "area":
        _box(body, f"{f.label}/area", [hx, hy, 0.001], [0, 0, 0.001], rgba=rgba, **_VISUAL)
        return
    if f.kind == "block":
        _box(body, f"{f.label}/top", [hx, hy, top / 2], [0, 0, top / 2], rgba=rgba)
        return
    if f.kind == "cabinet":
        add_cabinet(world, body, f)
        return
    _box(body, f"{f.label}/top", [hx, hy, _SLAB / 2], [0, 0, top - _SLAB / 2], rgba=rgba)
    leg = [0.02, 0.02, (top - _SLAB) / 2]
    for sx in (-1, 1):
        for sy in (-1, 1):
            pos = [sx * (hx - 0.03), sy * (hy - 0.03), leg[2]]
            _box(body, f"{f.label}/leg_{sx:+d}{sy:+d}", leg, pos, rgba=rgba)
    if f.kind == "shelf":  # a lower board and solid sides: a rack
        _box(body, f"{f.label}/board", [hx, hy, _SLAB / 2], [0, 0, 0.35 * top], rgba=rgba)
        for sy in (-1, 1):
            _box(
                body,
                f"{f.label}/side_{sy:+d}",
                [hx, 0.01, top / 2],
                [0, sy * hy, top / 2],
                rgba=rgba,
            )


def _container(body: mujoco.MjsBody, c: ContainerEntry) -> None:
    hx, hy, hz = c.size[0] / 2, c.size[1] / 2, c.size[2] / 2
    rgba = list(c.rgba)
    if c.closed:
        _box(body, f"{c.label}/shell", [hx, hy, hz], [0, 0, hz], rgba=rgba, mass=c.mass)
        return
    w = c.wall
    boards = [
        ("floor", [hx, hy, w / 2], [0, 0, w / 2]),
        ("wall_x+", [w / 2, hy, hz], [hx - w / 2, 0, hz]),
        ("wall_x-", [w / 2, hy, hz], [-hx + w / 2, 0, hz]),
        ("wall_y+", [hx - w, w / 2, hz], [0, hy - w / 2, hz]),
        ("wall_y-", [hx - w, w / 2, hz], [0, -hy + w / 2, hz]),
    ]
    volume = sum(h[0] * h[1] * h[2] for _, h, _ in boards)
    for name, half, pos in boards:
        mass = c.mass * half[0] * half[1] * half[2] / volume
        _box(body, f"{c.label}/{name}", half, pos, rgba=rgba, mass=mass)


def _part(root: mujoco.MjsBody, part: PartEntry, p: WorldPlacement) -> None:
    h = part.height
    body = root.add_body(name=part.label, pos=[p.x, p.y, p.z + h / 2 + 1e-4], quat=_quat(p.yaw))
    body.add_freejoint(name=part.label)
    kinds = {
        "cylinder": (mujoco.mjtGeom.mjGEOM_CYLINDER, [part.size[0], h / 2, 0]),
        "cuboid": (_BOX, [v / 2 for v in part.size]),
        "sphere": (mujoco.mjtGeom.mjGEOM_SPHERE, [part.size[0], 0, 0]),
    }
    kind, size = kinds[part.shape]
    body.add_geom(
        name=part.label, type=kind, size=size, mass=part.mass, rgba=list(part.rgba), condim=4
    )


def _appliance(world: mujoco.MjSpec, a: ApplianceEntry, p: WorldPlacement) -> None:
    """Walls around a cavity open at +x; a door hinged on the left or right front edge."""
    body = world.worldbody.add_body(name=a.label, pos=[p.x, p.y, p.z], quat=_quat(p.yaw))
    d, w, h, t = a.size[0] / 2, a.size[1] / 2, a.size[2], a.wall
    rgba = list(a.rgba)
    for name, half, pos in (
        ("bottom", [d, w, t / 2], [0, 0, t / 2]),
        ("top", [d, w, t / 2], [0, 0, h - t / 2]),
        ("back", [t / 2, w, h / 2], [-d + t / 2, 0, h / 2]),
        ("side_y+", [d, t / 2, h / 2], [0, w - t / 2, h / 2]),
        ("side_y-", [d, t / 2, h / 2], [0, -w + t / 2, h / 2]),
    ):
        _box(body, f"{a.label}/{name}", half, pos, rgba=rgba)
    side = -1.0 if a.hinge == "left" else 1.0  # seen from the front (+x), left is -y
    door = body.add_body(name=f"{a.label}/door", pos=[d, side * w, 0])
    door.add_joint(
        name=f"{a.label}/door",
        type=mujoco.mjtJoint.mjJNT_HINGE,
        # the free edge sits at -side*w from the hinge; turning about +side*z moves it to +x
        axis=[0, 0, side],
        range=[0, a.door_open_angle],
        damping=0.5 if a.door_motor else 1.0,
        frictionloss=0.0 if a.door_motor else 0.2,  # a motorless door stays where it is left
        armature=0.01,
    )
    dt = 0.012
    half_h = h / 2 - 0.003  # clear of the surface the microwave stands on
    _box(door, f"{a.label}/door", [dt, w, half_h], [dt, -side * w, h / 2], rgba=rgba, mass=1.0)
    # the housing is a static body, so MuJoCo's parent-child contact filter does not apply
    world.add_exclude(bodyname1=a.label, bodyname2=f"{a.label}/door")
    _box(
        door,
        f"{a.label}/window",
        [0.002, 0.6 * w, 0.3 * h],
        [2 * dt + 0.002, -side * 0.8 * w, h / 2],
        rgba=[0.1, 0.1, 0.12, 1],
        **_VISUAL,
    )
    if not a.door_motor:
        _door_handle(door, a.label, 2 * dt, -side * (2 * w - DOOR_HANDLE_INSET), h / 2)
        return
    act = world.add_actuator(
        name=f"{a.label}/door", target=f"{a.label}/door", trntype=mujoco.mjtTrn.mjTRN_JOINT
    )
    act.set_to_position(kp=40.0, dampratio=1.0)
    act.forcelimited = mujoco.mjtLimited.mjLIMITED_TRUE
    act.forcerange = [-20.0, 20.0]
    act.ctrllimited = mujoco.mjtLimited.mjLIMITED_TRUE
    act.ctrlrange = [0.0, a.door_open_angle]


def _door_handle(door: mujoco.MjsBody, label: str, face: float, y: float, z: float) -> None:
    """A horizontal bar handle on a door's outer face (x = ``face`` in the door body's frame),
    centred at (``y``, ``z``), standing :data:`DOOR_HANDLE_STANDOFF` m out on two posts."""
    dark = [0.25, 0.25, 0.28, 1.0]
    bar_x = face + DOOR_HANDLE_STANDOFF
    _box(door, f"{label}/handle", [0.008, 0.06, 0.008], [bar_x, y, z], rgba=dark, mass=0.05)
    post = (DOOR_HANDLE_STANDOFF - 0.008) / 2
    for n, dy in enumerate((-0.045, 0.045)):
        _box(door, f"{label}/handle_post{n}", [post, 0.005, 0.005], [face + post, y + dy, z],
             rgba=dark, mass=0.01)  # fmt: skip


def _fixed_camera(world: mujoco.MjSpec, sensor: SensorEntry) -> None:
    assert sensor.position is not None and sensor.look_at is not None  # checked at load
    quat = look_at_quat(sensor.position, sensor.look_at)
    pos = list(sensor.position)
    world.worldbody.add_site(name=sensor.label, pos=pos, quat=quat, size=[0.02, 0, 0])
    world.worldbody.add_camera(name=sensor.label, pos=pos, quat=quat, fovy=sensor.fov)
