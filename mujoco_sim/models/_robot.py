"""The embedded default robot and the world, generated with ``mujoco.MjSpec`` (no files).

Kinematic tree of robot ``r1`` (bodies, with the one joint each carries)::

    r1/base_x          slide x (world)      ┐ holonomic base: the three joint values are the base
      r1/base_y        slide y (world)      │ pose in the world frame (x, y in m, yaw in rad)
        r1/base        hinge z, r1/base_yaw ┘ chassis, deck, wheels (visual), pedestal
          r1/shoulder_link   hinge z, r1/shoulder_pan
            r1/upper_arm     hinge y, r1/shoulder_lift
              [r1/upper_arm_2   hinge z, r1/upper_arm_roll]      7-DOF only
                r1/forearm       hinge y, r1/elbow
                  r1/wrist_roll_link   hinge z, r1/wrist_roll
                    r1/wrist_pitch_link  hinge y, r1/wrist_pitch   (the wrist centre)
                      r1/gripper           hinge z, r1/tool_roll   palm, site r1/tcp
                        r1/left_finger     slide +y, r1/left_finger   pad geom r1/left_pad
                        r1/right_finger    slide -y, r1/right_finger  pad geom r1/right_pad

One joint per body, so placo (pinocchio's MJCF parser) sees the same joints as MuJoCo. At joint
value 0 the arm points straight up. Each base and arm joint has a position servo named like it;
``r1/gripper`` servos the pad-to-pad opening (m) through a fixed tendon, and an equality keeps
the fingers symmetric. The world places a robot by the ``ref`` of its base joints, so base joint
values are absolute world coordinates and :func:`mujoco.mj_resetData` puts it at its pose.

A fixed robot (``mount = "fixed"``) has no ``base_x`` / ``base_y`` / ``base_yaw``: its body
``r1/base`` stands in the world at the robot's pose, without joints, and carries the pedestal
(geom ``r1/pedestal``, ``stand_height`` high) with the arm on top.
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence

import mujoco
import numpy as np

from device_drivers import ModelError, Pose2D
from mujoco_sim.models._file_robot import add_file_robot
from mujoco_sim.models._gripper import add_gripper_drive, add_parallel_gripper
from mujoco_sim.models._menagerie import add_mjcf_arm
from mujoco_sim.physics._options import TIMESTEP, configure_physics
from scenario import RobotSpec, robot_layout

__all__ = ["TIMESTEP", "build_robot", "build_world", "configure_physics"]

_CLEARANCE = 0.04  # chassis bottom above the floor, m
_WHEEL_RADIUS = 0.06
_STAND_RADIUS = 0.08  # fixed mount: the pedestal's radius, m
_WRIST_ROLL_OFFSET = 0.05  # wrist-roll joint before the wrist centre, m
_TOOL_ROLL_OFFSET = 0.03  # tool-roll body origin after the wrist centre, m

# Servo gains: (kp in N·m/rad or N/m, force limit in N·m or N, armature in kg·m², damping).
_ARM_GAINS: dict[str, tuple[float, float, float, float]] = {
    "shoulder_pan": (2500.0, 80.0, 0.10, 2.0),
    "shoulder_lift": (4000.0, 120.0, 0.10, 2.0),
    "upper_arm_roll": (1500.0, 60.0, 0.05, 1.0),
    "elbow": (3000.0, 80.0, 0.05, 1.0),
    "wrist_roll": (400.0, 20.0, 0.01, 0.3),
    "wrist_pitch": (600.0, 25.0, 0.01, 0.3),
    "tool_roll": (200.0, 10.0, 0.005, 0.2),
}
_ARM_RANGE: dict[str, float] = {  # symmetric joint limits, rad
    "shoulder_pan": 3.0,
    "shoulder_lift": 2.2,
    "upper_arm_roll": 3.0,
    "elbow": 2.6,
    "wrist_roll": 3.0,
    "wrist_pitch": 2.2,
    "tool_roll": 3.1,
}
_BASE_GAINS = {"xy": (8000.0, 500.0), "yaw": (3000.0, 200.0)}  # kp, force limit


_BOX = mujoco.mjtGeom.mjGEOM_BOX
_CAPSULE = mujoco.mjtGeom.mjGEOM_CAPSULE
_CYLINDER = mujoco.mjtGeom.mjGEOM_CYLINDER
_HINGE = mujoco.mjtJoint.mjJNT_HINGE
_SLIDE = mujoco.mjtJoint.mjJNT_SLIDE
_VISUAL = {"contype": 0, "conaffinity": 0, "group": 1, "mass": 0.0}


def build_robot(
    spec: RobotSpec, prefix: str | None = None, *, at: Pose2D | None = None
) -> mujoco.MjSpec:
    """Generate robot ``spec.name`` as a stand-alone :class:`mujoco.MjSpec` (see module doc).

    ``prefix`` starts every element name (default ``spec.prefix``, i.e. ``"<name>/"``). ``at``
    is the initial base pose in the world frame (default: the origin); it becomes the ``ref``
    of the base joints, so that joint values stay absolute world coordinates. Export a mobile
    robot for IK with ``at=None``; a fixed one (``spec.mount = "fixed"``: a pedestal body
    ``<prefix>base`` without joints) at its pose, where its pedestal stands in the world.
    With ``spec.mjcf`` the arm and gripper come from files, attached at the site
    ``<prefix>arm_mount`` on top of the pedestal (:func:`mujoco_sim.models.add_mjcf_arm`).
    Raises :class:`ModelError` if the spec does not compile.
    """
    mj = mujoco.MjSpec()
    mj.modelname = spec.name
    configure_physics(mj)
    _add_robot(mj, spec, spec.prefix if prefix is None else prefix, at or Pose2D())
    _check_compiles(mj, spec.name)
    return mj


def _add_robot(mj: mujoco.MjSpec, spec: RobotSpec, p: str, at: Pose2D) -> None:
    """Add robot ``spec`` with element prefix ``p`` at base pose ``at`` to ``mj``."""
    names = robot_layout(spec, p)
    base = _add_stand(mj, spec, p, at) if spec.fixed else _add_base(mj, spec, p, at)
    top = spec.mount_height
    if spec.mjcf is not None:
        base.add_site(name=f"{p}arm_mount", pos=[spec.arm_mount_x, 0, top], size=[0.02, 0, 0])
        for jname in names.base_joints:
            _add_servo(mj, jname, jname.removeprefix(p))
        if spec.mjcf.one_file:
            add_file_robot(mj, spec, names)
        else:
            add_mjcf_arm(mj, spec.mjcf, names)
        return

    # Arm: link lengths along +z at joint value 0.
    link = base.add_body(name=f"{p}shoulder_link", pos=[spec.arm_mount_x, 0, top])
    chain = [link]
    _joint(link, f"{p}shoulder_pan", [0, 0, 1])
    _link_geom(link, spec.shoulder_height, 1.5 * spec.link_radius, spec, _CYLINDER)
    link = link.add_body(name=f"{p}upper_arm", pos=[0, 0, spec.shoulder_height])
    chain.append(link)
    _joint(link, f"{p}shoulder_lift", [0, 1, 0])
    upper = spec.upper_arm_length
    if spec.arm_dof == 7:
        _link_geom(link, upper / 2, spec.link_radius, spec)
        link = link.add_body(name=f"{p}upper_arm_2", pos=[0, 0, upper / 2])
        chain.append(link)
        _joint(link, f"{p}upper_arm_roll", [0, 0, 1])
        upper /= 2
    _link_geom(link, upper, spec.link_radius, spec)
    link = link.add_body(name=f"{p}forearm", pos=[0, 0, upper])
    chain.append(link)
    _joint(link, f"{p}elbow", [0, 1, 0])
    fore = spec.forearm_length - _WRIST_ROLL_OFFSET
    _link_geom(link, fore, 0.9 * spec.link_radius, spec)
    link = link.add_body(name=f"{p}wrist_roll_link", pos=[0, 0, fore])
    chain.append(link)
    _joint(link, f"{p}wrist_roll", [0, 0, 1])
    _link_geom(link, _WRIST_ROLL_OFFSET, 0.8 * spec.link_radius, spec, _CYLINDER)
    link = link.add_body(name=f"{p}wrist_pitch_link", pos=[0, 0, _WRIST_ROLL_OFFSET])
    chain.append(link)
    _joint(link, f"{p}wrist_pitch", [0, 1, 0])
    _link_geom(link, _TOOL_ROLL_OFFSET, 0.8 * spec.link_radius, spec)
    hand = link.add_body(name=f"{p}gripper", pos=[0, 0, _TOOL_ROLL_OFFSET])
    chain.append(hand)
    _joint(hand, f"{p}tool_roll", [0, 0, 1])
    add_parallel_gripper(mj, hand, spec, p, flange_z=spec.wrist_length - _TOOL_ROLL_OFFSET)
    # Links two apart overlap at the short wrist links; MuJoCo only skips parent-child pairs.
    for near, far in zip(chain, chain[2:], strict=False):
        mj.add_exclude(bodyname1=near.name, bodyname2=far.name)

    for jname in names.servo_joints:
        _add_servo(mj, jname, jname.removeprefix(p))
    add_gripper_drive(mj, spec, p)


def _add_base(mj: mujoco.MjSpec, spec: RobotSpec, p: str, at: Pose2D) -> mujoco.MjsBody:
    """Holonomic base: x slide, y slide, yaw hinge, one per body; returns the chassis body."""
    bx = mj.worldbody.add_body(name=f"{p}base_x", pos=[at.x, 0, 0])
    by = bx.add_body(name=f"{p}base_y", pos=[0, at.y, 0])
    base = by.add_body(name=f"{p}base", quat=_yaw_quat(at.yaw))
    for body in (bx, by):  # massless in spirit; MuJoCo needs some mass on moving bodies
        body.explicitinertial = True
        body.mass, body.inertia = 0.1, [1e-3, 1e-3, 1e-3]
    free = mujoco.mjtLimited.mjLIMITED_FALSE
    bx.add_joint(name=f"{p}base_x", type=_SLIDE, axis=[1, 0, 0], ref=at.x, limited=free)
    by.add_joint(name=f"{p}base_y", type=_SLIDE, axis=[0, 1, 0], ref=at.y, limited=free)
    base.add_joint(name=f"{p}base_yaw", type=_HINGE, axis=[0, 0, 1], ref=at.yaw, limited=free)
    _add_chassis(base, spec, p)
    return base


def _add_stand(mj: mujoco.MjSpec, spec: RobotSpec, p: str, at: Pose2D) -> mujoco.MjsBody:
    """Fixed mount: a pedestal on the floor at ``at`` (no joints), ``arm_mount_x`` ahead of
    it, ``stand_height`` high, on a foot plate; returns its body (the robot's base frame)."""
    stand = mj.worldbody.add_body(name=f"{p}base", pos=[at.x, at.y, 0], quat=_yaw_quat(at.yaw))
    h = spec.stand_height
    stand.add_geom(
        name=f"{p}pedestal",
        type=_CYLINDER,
        size=[_STAND_RADIUS, h / 2, 0],
        pos=[spec.arm_mount_x, 0, h / 2],
        rgba=list(spec.base_rgba),
        mass=20.0,
    )
    stand.add_geom(  # the foot plate, bolted to the floor (visual)
        type=_BOX,
        size=[2 * _STAND_RADIUS, 2 * _STAND_RADIUS, 0.01],
        pos=[spec.arm_mount_x, 0, 0.01],
        rgba=list(spec.deck_rgba),
        **_VISUAL,
    )
    stand.add_site(name=f"{p}base_site", pos=[0, 0, 0], size=[0.02, 0, 0])
    return stand


def _yaw_quat(yaw: float) -> list[float]:
    return [math.cos(yaw / 2), 0.0, 0.0, math.sin(yaw / 2)]


def _joint(body: mujoco.MjsBody, name: str, axis: list[float]) -> None:
    key = name.rsplit("/", 1)[-1]
    limit = _ARM_RANGE[key]
    _kp, _force, armature, damping = _ARM_GAINS[key]
    body.add_joint(
        name=name, type=_HINGE, axis=axis, range=[-limit, limit], armature=armature, damping=damping
    )


def _link_geom(
    body: mujoco.MjsBody, length: float, radius: float, spec: RobotSpec, kind: int = _CAPSULE
) -> None:
    """A link from the body origin along +z; mass is a share of ``spec.arm_mass`` by length."""
    reach = spec.shoulder_height + spec.upper_arm_length + spec.forearm_length + spec.wrist_length
    mass = max(spec.arm_mass * length / reach, 0.05)
    end = length if kind == _CAPSULE else length - 0.005
    body.add_geom(
        type=kind,
        fromto=[0, 0, 0, 0, 0, end],
        size=[radius, 0, 0],
        rgba=list(spec.arm_rgba),
        mass=mass,
    )


def _add_chassis(base: mujoco.MjsBody, spec: RobotSpec, p: str) -> None:
    hx, hy = spec.base_length / 2, spec.base_width / 2
    hz = (spec.base_height - _CLEARANCE) / 2
    base.add_geom(
        name=f"{p}chassis",
        type=_BOX,
        size=[hx, hy, hz],
        pos=[0, 0, _CLEARANCE + hz],
        rgba=list(spec.base_rgba),
        mass=spec.base_mass,
    )
    base.add_geom(  # a contrasting deck plate (visual; the chassis top is the contact surface)
        name=f"{p}deck_plate",
        type=_BOX,
        size=[hx - 0.01, hy - 0.01, 0.002],
        pos=[0, 0, spec.base_height],
        rgba=list(spec.deck_rgba),
        **_VISUAL,
    )
    wheel_quat = [math.cos(math.pi / 4), math.sin(math.pi / 4), 0, 0]  # cylinder axis along y
    for sx in (-1, 1):
        for sy in (-1, 1):
            base.add_geom(
                type=_CYLINDER,
                size=[_WHEEL_RADIUS, 0.025, 0],
                quat=wheel_quat,
                pos=[sx * (hx - 0.08), sy * (hy - 0.02), _WHEEL_RADIUS],
                rgba=[0.05, 0.05, 0.05, 1],
                **_VISUAL,
            )
    base.add_geom(  # pedestal from the deck up to the shoulder-pan joint
        type=_CYLINDER,
        size=[0.06, spec.pedestal_height / 2, 0],
        pos=[spec.arm_mount_x, 0, spec.base_height + spec.pedestal_height / 2],
        rgba=list(spec.base_rgba),
        mass=2.0,
    )
    base.add_site(name=f"{p}base_site", pos=[0, 0, 0], size=[0.02, 0, 0])
    deck_x = (-hx + spec.arm_mount_x - 0.08) / 2  # middle of the deck behind the pedestal
    base.add_site(name=f"{p}deck", pos=[deck_x, 0, spec.base_height], size=[0.02, 0, 0])
    # Front camera under the shoulder, looking forward and 30° down: camera -z = view direction.
    tilt = math.radians(30)
    cam = {
        "pos": [spec.arm_mount_x + 0.07, 0, spec.base_height + 0.6 * spec.pedestal_height],
        "quat": _camera_quat(view=[math.cos(tilt), 0, -math.sin(tilt)], right=[0, -1, 0]),
    }
    base.add_site(name=f"{p}front_camera", size=[0.01, 0, 0], **cam)
    base.add_camera(name=f"{p}front_camera", fovy=60.0, **cam)


def _camera_quat(view: list[float], right: list[float]) -> list[float]:
    """Quaternion of a camera frame whose -z axis is ``view`` and x axis is ``right``."""
    z = [-v for v in view]
    y = [
        z[1] * right[2] - z[2] * right[1],
        z[2] * right[0] - z[0] * right[2],
        z[0] * right[1] - z[1] * right[0],
    ]
    mat = np.array([right[0], y[0], z[0], right[1], y[1], z[1], right[2], y[2], z[2]])
    quat = np.zeros(4)
    mujoco.mju_mat2Quat(quat, mat)
    return [float(q) for q in quat]


def _add_servo(mj: mujoco.MjSpec, jname: str, key: str) -> None:
    act = mj.add_actuator(name=jname, target=jname, trntype=mujoco.mjtTrn.mjTRN_JOINT)
    if key in _ARM_GAINS:
        kp, force, _armature, _damping = _ARM_GAINS[key]
        act.set_to_position(kp=kp, dampratio=1.0, inheritrange=True)
    else:
        kp, force = _BASE_GAINS["yaw" if key == "base_yaw" else "xy"]
        act.set_to_position(kp=kp, dampratio=1.0)
    act.forcelimited = mujoco.mjtLimited.mjLIMITED_TRUE
    act.forcerange = [-force, force]


def _check_compiles(mj: mujoco.MjSpec, what: str) -> None:
    try:
        mj.compile()
    except ValueError as exc:  # the bindings raise ValueError with the compiler's message
        raise ModelError(f"generated model does not compile: {exc}", source=what) from exc


def build_world(
    robots: Sequence[tuple[RobotSpec, Pose2D]],
    *,
    extras: Mapping[str, mujoco.MjSpec] | None = None,
    floor_size: float = 10.0,
) -> mujoco.MjSpec:
    """One world: a floor (geom ``floor``, half size ``floor_size`` m), a light, each robot at
    its initial base pose, then each spec of ``extras`` (tables, shelves, parts..., in world
    coordinates) attached at the world origin with the prefix ``<key>/``.

    Robots keep the names of :func:`robot_layout`. An extra should author no physics options,
    or the same as :func:`configure_physics` (MuJoCo warns about conflicting ones). The extras
    are attached by reference: they cannot be attached again. Raises :class:`ModelError` on a
    name used twice or if the world does not compile.
    """
    names = [spec.name for spec, _ in robots] + list(extras or {})
    dupes = sorted({n for n in names if names.count(n) > 1})
    if dupes:
        raise ModelError(f"robot and extra names must be unique, repeated: {dupes}", source="world")
    world = mujoco.MjSpec()
    world.modelname = "skimesh_world"
    configure_physics(world)
    world.worldbody.add_geom(
        name="floor",
        type=mujoco.mjtGeom.mjGEOM_PLANE,
        size=[floor_size, floor_size, 0.05],
        rgba=[0.82, 0.82, 0.78, 1],
    )
    world.worldbody.add_light(
        name="sun", pos=[0, 0, 4], dir=[0.2, 0.3, -1], type=mujoco.mjtLightType.mjLIGHT_DIRECTIONAL
    )
    for spec, pose in robots:
        _add_robot(world, spec, spec.prefix, pose)
    for name, extra in (extras or {}).items():
        world.attach(extra, frame=world.worldbody.add_frame(), prefix=f"{name}/")
    _check_compiles(world, "world")
    return world
