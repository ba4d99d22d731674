"""An arm with its gripper from one URDF or MJCF file, on the generated base.

A :class:`~scenario.MjcfArm` with ``package`` (``example-robot-data:panda``) or ``arm_xml``
alone is built by :func:`add_file_robot`. The names come from :func:`scenario.describe_file`
(chain, gripper joints, fingers); the geometry is derived here from the file compiled alone:

- **loading**: a URDF's ``package://`` mesh paths become absolute (``example-robot-data``'s
  resolve inside the wheel, others against the file's folder); ``<visual>`` elements are
  dropped (they are often COLLADA, which MuJoCo does not read; the collision geometry is drawn
  instead, in ``arm_rgba``); static links are kept as bodies (``fusestatic="false"``) so the
  tool link exists. MuJoCo turns a URDF ``<mimic>`` into a joint equality. An MJCF file is read
  as for the two-file route (:func:`load_mjcf`); its actuators are dropped.
- **servos**: a position servo per arm joint, named after it (stiffness ``arm_kp``, critically
  damped, force limit the joint's effort limit if the file gives one), and ``gripper`` on the
  driven gripper joint (force limit ``gripper_force``, N or N·m for a hinge jaw).
- **open / closed**: the ends of the driven joint's range, the open one where the fingers'
  collision geometry is farthest apart (``gripper_open`` / ``gripper_closed`` override).
- **pads**: per finger, its collision geom farthest along the approach direction (from the
  tool link's origin towards the fingers), renamed ``left_pad`` / ``right_pad`` and given the
  generated gripper's pad friction; ``left_pads`` / ``right_pads`` name them instead.
- **tool frame**: a site ``tcp`` on the tool link between the pads (open), z along the
  approach, y from the right pad to the left one; ``tcp_offset`` moves it (tool link frame).

Everything is named ``<prefix><name in the file>``; a wrist camera is added to the tool link.
A problem is a :class:`~scenario.RobotFileError` naming the file and the key to set.
"""

from __future__ import annotations

import xml.etree.ElementTree as ET
from pathlib import Path
from typing import Any

import mujoco
import numpy as np
import numpy.typing as npt

from mujoco_sim.models._menagerie import load_mjcf, rename_clashes
from mujoco_sim.physics._options import configure_physics
from scenario import (
    FileRobot,
    MjcfArm,
    RobotFileError,
    RobotLayout,
    RobotSpec,
    describe_file,
    erd_share,
)

__all__ = ["GripperGeometry", "add_file_robot", "derive_gripper", "load_robot_file", "set_gripper"]

FloatArray = npt.NDArray[np.float64]
_MESH_SUFFIXES = {".stl", ".obj", ".msh"}
_WRIST_CAMERA = {"pos": [0.05, 0.0, 0.0], "quat": [0.0, 1.0, 0.0, 0.0]}
_PAD = {
    "condim": 4,
    "priority": 1,
    "friction": [1.5, 0.02, 0.001],
    "solref": [0.004, 1.0],
    "solimp": [0.95, 0.99, 0.001, 0.5, 2.0],
}


def load_robot_file(robot: FileRobot) -> mujoco.MjSpec:
    """The file of ``robot`` as an :class:`mujoco.MjSpec` (see the module doc)."""
    path = Path(robot.path)
    if robot.kind == "mjcf":
        mj = load_mjcf(path)
        for act in list(mj.actuators):
            mj.delete(act)
        return mj
    root = ET.parse(path).getroot()
    for link in root.iter("link"):
        for visual in link.findall("visual"):
            link.remove(visual)
    for mesh in root.iter("mesh"):
        file = _mesh_path(mesh.get("filename", ""), path)
        if file.suffix.lower() not in _MESH_SUFFIXES:
            raise RobotFileError(
                robot.path, f"collision mesh {file.name}: MuJoCo reads only STL, OBJ and MSH"
            )
        mesh.set("filename", str(file))
    ext = root.find("mujoco")
    if ext is None:
        ext = ET.SubElement(root, "mujoco")
    compiler = ext.find("compiler")
    if compiler is None:
        compiler = ET.SubElement(ext, "compiler")
    compiler.attrib.update({"fusestatic": "false", "strippath": "false", "meshdir": ""})
    try:
        mj = mujoco.MjSpec.from_string(ET.tostring(root, encoding="unicode"))
    except ValueError as exc:
        raise RobotFileError(robot.path, f"MuJoCo cannot load the URDF: {exc}") from None
    configure_physics(mj)
    for joint in root.iter("joint"):  # MuJoCo's URDF import keeps no effort limit
        limit, element = joint.find("limit"), mj.joint(joint.get("name", ""))
        effort = float(limit.get("effort", "0")) if limit is not None else 0.0
        if element is not None and effort > 0:
            element.actfrclimited = mujoco.mjtLimited.mjLIMITED_TRUE
            element.actfrcrange = [-effort, effort]
    return mj


def _mesh_path(name: str, urdf: Path) -> Path:
    if name.startswith("package://"):
        package, _, rest = name.removeprefix("package://").partition("/")
        if package == "example-robot-data":  # <share>/example-robot-data/robots/...
            return erd_share(str(urdf)) / rest
        for parent in urdf.parents:  # a ROS package: the folder named like it
            if parent.name == package:
                return parent / rest
        return urdf.parent / rest
    file = Path(name)
    return file if file.is_absolute() else urdf.parent / file


def add_file_robot(mj: mujoco.MjSpec, spec: RobotSpec, names: RobotLayout) -> None:
    """Attach ``spec``'s one-file arm and gripper at ``<prefix>arm_mount`` in ``mj``."""
    arm = spec.mjcf
    assert arm is not None and arm.one_file
    robot = describe_file(arm)
    p = names.prefix
    sub = load_robot_file(robot)
    arm_joints = [j.removeprefix(p) for j in names.arm_joints]
    if len(arm.home) != len(arm_joints):
        raise RobotFileError(
            robot.path,
            f"home has {len(arm.home)} values for the {len(arm_joints)} arm joints {arm_joints}",
            key="home",
        )
    for name in (*arm_joints, *robot.gripper_joints):
        if sub.joint(name) is None:
            raise RobotFileError(robot.path, f"no joint named {name!r}", key="arm_joints")
    for i, geom in enumerate(sub.geoms):  # unnamed URDF geoms: names to find them again
        if not geom.name:
            geom.name = f"geom{i}"
        geom.rgba = list(spec.arm_rgba)
    for joint_name in arm_joints:
        _servo(sub, joint_name, arm.arm_kp, effort=_effort(sub, joint_name))
    geometry = derive_gripper(sub, robot, arm, names)
    driven = sub.joint(robot.gripper_joints[0])
    slide = driven.type == mujoco.mjtJoint.mjJNT_SLIDE
    force = spec.gripper_force if slide else spec.gripper_force * 0.05
    act = _servo(
        sub, "gripper", force / (0.005 if slide else 0.1), effort=force, target=driven.name
    )
    act.ctrlrange = sorted((geometry.open, geometry.closed))
    act.ctrllimited = mujoco.mjtLimited.mjLIMITED_TRUE
    for body in sub.bodies:
        body.gravcomp = 1.0 if arm.gravity_compensation else 0.0
    hand = sub.body(robot.tool_link)
    if not arm.given("tcp_site"):
        hand.add_site(name="tcp", pos=list(geometry.tcp_pos), quat=list(geometry.tcp_quat),
                      size=[0.008, 0, 0])  # fmt: skip
    hand.add_site(name="wrist_camera", size=[0.01, 0, 0], **_WRIST_CAMERA)
    hand.add_camera(name="wrist_camera", fovy=70.0, **_WRIST_CAMERA)
    rename_clashes(sub, mj, p)
    try:
        mj.attach(sub, site=f"{p}arm_mount", prefix=p)
    except ValueError as exc:
        raise RobotFileError(robot.path, f"cannot attach the robot: {exc}") from None


def _effort(sub: mujoco.MjSpec, name: str) -> float:
    joint = sub.joint(name)
    limited = joint.actfrclimited == mujoco.mjtLimited.mjLIMITED_TRUE
    return float(max(abs(joint.actfrcrange[0]), abs(joint.actfrcrange[1]))) if limited else 0.0


def _servo(sub: mujoco.MjSpec, name: str, kp: float, *, effort: float, target: str = "") -> Any:
    joint = sub.joint(target or name)
    joint.armature = max(joint.armature, 0.01)
    joint.actfrclimited = mujoco.mjtLimited.mjLIMITED_FALSE
    act = sub.add_actuator(name=name, target=target or name, trntype=mujoco.mjtTrn.mjTRN_JOINT)
    act.set_to_position(kp=kp, dampratio=1.0, inheritrange=not target)
    if effort > 0:
        act.forcelimited = mujoco.mjtLimited.mjLIMITED_TRUE
        act.forcerange = [-effort, effort]
    return act


class GripperGeometry:
    """Open and closed values of the driven joint, and the tool frame in the tool link."""

    def __init__(self, open_: float, closed: float, pos: FloatArray, quat: FloatArray) -> None:
        self.open, self.closed = open_, closed
        self.tcp_pos, self.tcp_quat = pos, quat


def derive_gripper(
    sub: mujoco.MjSpec, robot: FileRobot, arm: MjcfArm, names: RobotLayout
) -> GripperGeometry:
    """Pads (renamed in ``sub`` unless given), open/closed values and the tool frame."""
    try:
        model = sub.compile()
    except ValueError as exc:
        raise RobotFileError(robot.path, f"does not compile: {exc}") from None
    data = mujoco.MjData(model)
    driven = model.joint(robot.gripper_joints[0])
    low, high = (float(v) for v in model.jnt_range[driven.id])
    if not model.jnt_limited[driven.id] and (
        arm.gripper_open is None or arm.gripper_closed is None
    ):
        raise RobotFileError(
            robot.path,
            f"gripper joint {driven.name!r} has no range",
            key="gripper_open and gripper_closed",
        )
    tool = model.body(robot.tool_link).id
    pads = []
    for side, finger, given in (
        ("left", robot.left_finger, arm.left_pads if arm.given("left_pads") else None),
        ("right", robot.right_finger, arm.right_pads if arm.given("right_pads") else None),
    ):
        pads.append(_pad(model, data, sub, robot, side, finger, tool, given))
    gaps = {}
    for value in (low, high):
        set_gripper(model, data, robot.gripper_joints, value)
        gaps[value] = float(np.linalg.norm(data.geom_xpos[pads[0]] - data.geom_xpos[pads[1]]))
    open_default = high if gaps[high] >= gaps[low] else low
    open_ = open_default if arm.gripper_open is None else arm.gripper_open
    closed_default = low if open_default == high else high
    closed = closed_default if arm.gripper_closed is None else arm.gripper_closed
    set_gripper(model, data, robot.gripper_joints, open_)
    rot = data.xmat[tool].reshape(3, 3)
    left, right = data.geom_xpos[pads[0]], data.geom_xpos[pads[1]]
    mid = (left + right) / 2
    approach = mid - data.xpos[tool]
    approach /= np.linalg.norm(approach)
    y = left - right
    y -= (y @ approach) * approach
    if np.linalg.norm(y) < 1e-6:
        raise RobotFileError(robot.path, "the pads do not face each other", key="left_pads")
    y /= np.linalg.norm(y)
    frame = np.column_stack([np.cross(y, approach), y, approach])  # world
    local = rot.T @ frame
    quat = np.zeros(4)
    mujoco.mju_mat2Quat(quat, local.flatten())
    pos = rot.T @ (mid - data.xpos[tool]) if arm.tcp_offset is None else np.array(arm.tcp_offset)
    return GripperGeometry(open_, closed, pos, quat)


def _pad(
    model: Any,
    data: Any,
    sub: mujoco.MjSpec,
    robot: FileRobot,
    side: str,
    finger: str,
    tool: int,
    given: tuple[str, ...] | None,
) -> int:
    """The pad geom of ``finger`` (id in ``model``), renamed ``<side>_pad`` in ``sub``."""
    if given is not None:
        for name in given:
            if sub.geom(name) is None:
                raise RobotFileError(robot.path, f"no geom named {name!r}", key=f"{side}_pads")
        return int(model.geom(given[0]).id)
    mujoco.mj_kinematics(model, data)
    body = model.body(finger).id
    geoms = [g for g in range(model.ngeom) if model.geom_bodyid[g] == body]
    if not geoms:
        raise RobotFileError(
            robot.path, f"finger link {finger!r} has no collision geometry", key=f"{side}_pads"
        )
    fingers = [model.body(robot.left_finger).id, model.body(robot.right_finger).id]
    approach = np.mean(data.xpos[fingers], axis=0) - data.xpos[tool]
    best = max(geoms, key=lambda g: float(data.geom_xpos[g] @ approach))
    geom = sub.geom(model.geom(best).name)
    geom.name = f"{side}_pad"
    for key, value in _PAD.items():
        setattr(geom, key, value)
    return int(best)


def set_gripper(model: Any, data: Any, joints: tuple[str, ...], value: float) -> None:
    """Set the driven gripper joint to ``value`` and its followers by their joint equalities
    (in ``model``; prefixed names), then run the kinematics."""
    driven = model.joint(joints[0]).id
    data.qpos[model.jnt_qposadr[driven]] = value
    for eq in range(model.neq):
        if model.eq_type[eq] == mujoco.mjtEq.mjEQ_JOINT and model.eq_obj2id[eq] == driven:
            c = model.eq_data[eq]
            q = c[0] + c[1] * value + c[2] * value**2 + c[3] * value**3 + c[4] * value**4
            data.qpos[model.jnt_qposadr[model.eq_obj1id[eq]]] = q
    mujoco.mj_kinematics(model, data)
