"""What a robot description file (URDF or MJCF) says about its arm and gripper.

Pure data: the file is read with :mod:`xml.etree` (no MuJoCo). :func:`describe_file` derives,
from one file that holds an arm and its gripper (:class:`~scenario.MjcfArm` with ``package``,
or ``arm_xml`` without ``gripper_xml``), the names the simulator and the IK need:

- the **kinematic chain**: the movable joints from ``base_link`` (default: the root link) to
  ``tool_link`` (default: the link the gripper joints hang from);
- the **gripper joints**: given (``gripper_joints``), or the joints of the first link where the
  tree branches into two or more moving subtrees (the Panda hand's two fingers), or a joint
  with a ``<mimic>`` and the joint it follows. The first one not mimicking another is driven;
  the others follow it (URDF ``<mimic>`` or MJCF joint equalities);
- the **fingers**: the driven joint's child link is the left finger, the next gripper joint's
  child the right one; a one-jaw gripper's fixed jaw is the tool link itself.

What cannot be derived raises :class:`RobotFileError` naming the file, what is missing and the
scenario key that supplies it. Geometry (the tool frame, the finger pads, open and closed
values) is derived when the model is built (:mod:`mujoco_sim.models`).

``package = "example-robot-data:<robot>"`` names a URDF of the ``example-robot-data`` wheel
(``panda`` -> ``robots/panda_description/urdf/panda.urdf``; or a path inside its ``robots``
folder, e.g. ``example-robot-data:ur_description/urdf/ur5_robot.urdf``).
"""

from __future__ import annotations

import importlib.metadata
import xml.etree.ElementTree as ET
from pathlib import Path

from msgspec import Struct

from ._errors import ScenarioError
from ._robot_spec import MjcfArm

__all__ = [
    "ERD_PREFIX",
    "FileRobot",
    "RobotFileError",
    "describe_file",
    "erd_share",
    "robot_file_path",
]

ERD_PREFIX = "example-robot-data:"
"""``package`` prefix naming a robot of the ``example-robot-data`` wheel."""
_MOVABLE_URDF = {"revolute", "continuous", "prismatic"}
_MOVABLE_MJCF = {"hinge", "slide", None}  # MJCF joint type default: hinge


class RobotFileError(ScenarioError):
    """A robot file is missing or lacks something the simulator needs.

    ``file`` is the file (or package name), ``key`` the ``[robots.model.mjcf]`` key that
    supplies what could not be derived ("" when the file itself is the problem)."""

    def __init__(self, file: str, message: str, *, key: str = "") -> None:
        hint = f" (set [robots.model.mjcf] {key})" if key else ""
        super().__init__(f"{message}{hint}", source=file)
        self.file, self.key = file, key


class FileRobot(Struct, frozen=True, kw_only=True):
    """What :func:`describe_file` found (element names as written in the file)."""

    path: str
    kind: str
    """``"urdf"`` or ``"mjcf"``."""
    base_link: str
    tool_link: str
    arm_joints: tuple[str, ...]
    gripper_joints: tuple[str, ...]
    """Driven joint first, then the joints following it."""
    left_finger: str
    """Link (body) carrying the left pad."""
    right_finger: str
    """Link carrying the right pad (the tool link for a one-jaw gripper)."""


class _Joint(Struct, frozen=True):
    name: str
    parent: str
    child: str
    mimic: str  # the joint this one follows, or ""


def robot_file_path(arm: MjcfArm) -> Path:
    """The one file of ``arm`` (``package`` or ``arm_xml``); :class:`RobotFileError` if absent."""
    if arm.package:
        if not arm.package.startswith(ERD_PREFIX):
            raise RobotFileError(
                arm.package, f"unknown package; use {ERD_PREFIX}<robot>", key="package"
            )
        return _erd_path(arm.package.removeprefix(ERD_PREFIX))
    path = Path(arm.arm_xml).expanduser()
    if not path.is_file():
        raise RobotFileError(arm.arm_xml, "no such file", key="arm_xml")
    return path.resolve()


def erd_share(what: str) -> Path:
    """The ``share/example-robot-data`` folder of the installed wheel (``package://
    example-robot-data/...`` mesh paths are relative to it); ``what`` names the file or robot
    that needs it in the :class:`RobotFileError` raised when the wheel is not installed."""
    try:
        dist = importlib.metadata.distribution("example-robot-data")
    except importlib.metadata.PackageNotFoundError:
        raise RobotFileError(
            what, "package not installed: pip install example-robot-data"
        ) from None
    return Path(str(dist.locate_file("cmeel.prefix/share/example-robot-data")))


def _erd_path(name: str) -> Path:
    robots = erd_share(ERD_PREFIX + name) / "robots"
    candidates = [robots / name] if "/" in name else []
    candidates += [robots / f"{name}_description/{d}/{name}.urdf" for d in ("urdf", "robots")]
    for path in candidates:
        if path.is_file():
            return path
    known = sorted(p.name.removesuffix("_description") for p in robots.glob("*_description"))
    raise RobotFileError(
        ERD_PREFIX + name, f"no such robot; the package has {known}", key="package"
    )


def describe_file(arm: MjcfArm) -> FileRobot:
    """Derive the chain, gripper joints and fingers of ``arm``'s one file (module doc)."""
    path = robot_file_path(arm)
    try:
        root = ET.parse(path).getroot()
    except (ET.ParseError, OSError) as exc:
        raise RobotFileError(str(path), f"cannot read: {exc}") from None
    kind = "urdf" if root.tag == "robot" else "mjcf"
    joints, links = _urdf_tree(root) if kind == "urdf" else _mjcf_tree(root)
    file = str(path)
    by_name = {j.name: j for j in joints if not j.name.startswith("fixed:")}
    children = {link: [j for j in joints if j.parent == link] for link in links}
    roots = [link for link in links if all(j.child != link for j in joints)]
    base = arm.base_link or (roots[0] if roots else "")
    if base not in links:
        raise RobotFileError(file, f"no link named {base!r}", key="base_link")
    above = (_path(roots[0], base, joints) if roots else None) or []
    if any(j in by_name for j in above):  # the links above base_link are fixed on the mount
        raise RobotFileError(
            file,
            f"movable joints above {base!r}: {[j for j in above if j in by_name]}",
            key="base_link",
        )
    gripper = arm.gripper_joints or _gripper_joints(base, children, by_name)
    if not gripper:
        raise RobotFileError(
            file, "cannot tell which joints open and close the gripper", key="gripper_joints"
        )
    for name in gripper:
        if name not in by_name:
            raise RobotFileError(file, f"no movable joint named {name!r}", key="gripper_joints")
    gripper = tuple(sorted(gripper, key=lambda n: by_name[n].mimic != ""))  # driven first
    tool = arm.tool_link or by_name[gripper[0]].parent
    if tool not in links:
        raise RobotFileError(file, f"no link named {tool!r}", key="tool_link")
    chain = _path(base, tool, joints)
    if chain is None:
        raise RobotFileError(file, f"{tool!r} does not hang from {base!r}", key="tool_link")
    arm_joints = tuple(j for j in chain if j in by_name)
    if not arm_joints:
        raise RobotFileError(file, f"no movable joint from {base!r} to {tool!r}", key="base_link")
    fingers = [by_name[j].child for j in gripper if by_name[j].parent == tool] or [tool]
    return FileRobot(
        path=file,
        kind=kind,
        base_link=base,
        tool_link=tool,
        arm_joints=arm_joints,
        gripper_joints=gripper,
        left_finger=fingers[0],
        right_finger=fingers[1] if len(fingers) > 1 else tool,
    )


def _gripper_joints(
    base: str, children: dict[str, list[_Joint]], by_name: dict[str, _Joint]
) -> tuple[str, ...]:
    """The joints of the first link below ``base`` with two moving subtrees, or mimic pairs."""

    def moves(link: str) -> bool:
        return any(j.name in by_name or moves(j.child) for j in children.get(link, []))

    link = base
    while True:
        branches = [j for j in children.get(link, []) if j.name in by_name or moves(j.child)]
        if len(branches) >= 2:
            return tuple(j.name for j in branches if j.name in by_name)
        if not branches:
            break
        link = branches[0].child
    for joint in by_name.values():
        if joint.mimic in by_name:
            return (joint.mimic, joint.name)
    return ()


def _path(base: str, tool: str, joints: list[_Joint]) -> list[str] | None:
    """Joint names (movable or not) from ``base`` down to ``tool``, or None."""
    parent = {j.child: j for j in joints}
    names: list[str] = []
    link = tool
    while link != base:
        if link not in parent:
            return None
        names.append(parent[link].name)
        link = parent[link].parent
    return names[::-1]


def _urdf_tree(root: ET.Element) -> tuple[list[_Joint], list[str]]:
    """Movable joints (fixed ones too, named ``fixed:<name>``, so paths go through them)."""
    joints = []
    for j in root.iter("joint"):
        parent, child = j.find("parent"), j.find("child")
        if parent is None or child is None:
            continue
        mimic = j.find("mimic")
        movable = j.get("type") in _MOVABLE_URDF
        joints.append(
            _Joint(
                name=j.get("name", "") if movable else f"fixed:{j.get('name', '')}",
                parent=parent.get("link", ""),
                child=child.get("link", ""),
                mimic="" if mimic is None else mimic.get("joint", ""),
            )
        )
    return joints, [link.get("name", "") for link in root.iter("link")]


def _mjcf_tree(root: ET.Element) -> tuple[list[_Joint], list[str]]:
    """A body's one movable joint links it to its parent (``fixed:<body>`` without one)."""
    joints: list[_Joint] = []
    links: list[str] = []
    followers = {
        e.get("joint1", ""): e.get("joint2", "")
        for e in root.iter("joint")
        if e.get("joint1") is not None
    }

    def walk(body: ET.Element, parent: str) -> None:
        name = body.get("name", "")
        links.append(name)
        movable = [j for j in body.findall("joint") if j.get("type") in _MOVABLE_MJCF]
        jname = movable[0].get("name", "") if movable else f"fixed:{name}"
        joints.append(_Joint(jname, parent, name, followers.get(jname, "")))
        for child in body.findall("body"):
            walk(child, name)

    worldbody = root.find("worldbody")
    for body in [] if worldbody is None else worldbody.findall("body"):
        walk(body, "world")
    links.append("world")
    return joints, links
