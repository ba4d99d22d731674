"""The parallel gripper of the generated robot (MjSpec), attached to the tool-roll body.

Two slide fingers open symmetrically along the gripper's y axis; each carries a finger plate and
a high-friction pad (``<prefix>left_pad`` / ``<prefix>right_pad``, condim 4, priority 1, so the
pad's friction wins against the part's). A fixed tendon ``<prefix>gripper`` whose length is the
pad-to-pad opening (m) carries a position servo of the same name; a joint equality
``<prefix>finger_coupling`` keeps the fingers symmetric. Each finger squeezes with at most
``RobotSpec.gripper_force`` N.
"""

from __future__ import annotations

import mujoco

from scenario import RobotSpec

__all__ = ["GRIPPER_KP", "add_gripper_drive", "add_parallel_gripper"]

GRIPPER_KP = 1000.0
"""Opening servo stiffness, N/m (critically damped)."""

_PAD = (0.012, 0.004, 0.02)  # finger pad half sizes: along x, thickness (y), along z; m
_FINGER_T = 0.005  # finger plate half thickness, m
_PALM_HZ = 0.02  # palm half height along the approach axis, m
_BOX = mujoco.mjtGeom.mjGEOM_BOX
_TIMESTEP_FLOOR = 0.002  # solref time constants must stay >= 2 timesteps


def add_parallel_gripper(
    mj: mujoco.MjSpec, hand: mujoco.MjsBody, spec: RobotSpec, p: str, *, flange_z: float
) -> None:
    """Palm, fingers with pads, and the ``<p>tcp`` and ``<p>wrist_camera`` sites (plus camera).

    In the ``hand`` body frame: z is the approach axis, the flange is at ``flange_z`` (m), the
    pads' inner faces are at y = ±opening/2 and their centres at the tcp,
    ``flange_z + spec.gripper_length``. The tcp frame: z along the approach, y along the
    closing axis.
    """
    tcp_z = flange_z + spec.gripper_length
    half_open = spec.gripper_max_opening / 2
    palm_hy = half_open + 2 * _PAD[1] + 2 * _FINGER_T + 0.01
    hand.add_geom(
        name=f"{p}palm",
        type=_BOX,
        size=[0.03, palm_hy, _PALM_HZ],
        pos=[0, 0, flange_z + _PALM_HZ],
        rgba=list(spec.gripper_rgba),
        mass=max(spec.gripper_mass - 0.1, 0.05),
    )
    hand.add_site(name=f"{p}tcp", pos=[0, 0, tcp_z], size=[0.008, 0, 0], rgba=[1, 0, 0, 0.5])
    # A camera looks along its -z: turned 180° about x, it looks along the approach axis.
    cam = {"pos": [0.04, 0, flange_z + 0.02], "quat": [0.0, 1.0, 0.0, 0.0]}
    hand.add_site(name=f"{p}wrist_camera", size=[0.01, 0, 0], **cam)
    hand.add_camera(name=f"{p}wrist_camera", fovy=70.0, **cam)

    plate_lo, plate_hi = 2 * _PALM_HZ, spec.gripper_length + _PAD[2]
    for side, sign in (("left", 1.0), ("right", -1.0)):
        finger = hand.add_body(name=f"{p}{side}_finger", pos=[0, 0, flange_z])
        finger.add_joint(
            name=f"{p}{side}_finger",
            type=mujoco.mjtJoint.mjJNT_SLIDE,
            axis=[0, sign, 0],
            range=[0, half_open],
            armature=0.01,
            damping=5.0,
        )
        finger.add_geom(
            type=_BOX,
            size=[_PAD[0], _FINGER_T, (plate_hi - plate_lo) / 2],
            pos=[0, sign * (2 * _PAD[1] + _FINGER_T), (plate_hi + plate_lo) / 2],
            rgba=list(spec.gripper_rgba),
            mass=0.04,
        )
        finger.add_geom(
            name=f"{p}{side}_pad",
            type=_BOX,
            size=list(_PAD),
            pos=[0, sign * _PAD[1], spec.gripper_length],
            rgba=list(spec.pad_rgba),
            mass=0.01,
            condim=4,
            priority=1,
            friction=[1.5, 0.02, 0.001],
            solref=[2 * _TIMESTEP_FLOOR, 1.0],  # stiff: ~1 mm squeeze into a part, not 3
            solimp=[0.95, 0.99, 0.001, 0.5, 2.0],
        )
    mj.add_exclude(bodyname1=f"{p}left_finger", bodyname2=f"{p}right_finger")


def add_gripper_drive(mj: mujoco.MjSpec, spec: RobotSpec, p: str) -> None:
    """Tendon ``<p>gripper`` (length = opening), finger coupling, and the opening servo
    (control range 0 .. ``spec.gripper_max_opening`` m). Add after the other actuators so the
    gripper comes last in ``ctrl``."""
    opening = mj.add_tendon(name=f"{p}gripper")
    opening.wrap_joint(f"{p}left_finger", 1.0)
    opening.wrap_joint(f"{p}right_finger", 1.0)
    coupling = mj.add_equality(
        name=f"{p}finger_coupling",
        type=mujoco.mjtEq.mjEQ_JOINT,
        objtype=mujoco.mjtObj.mjOBJ_JOINT,
        name1=f"{p}left_finger",
        name2=f"{p}right_finger",
    )
    coupling.data[0:5] = [0, 1, 0, 0, 0]  # left = 0 + 1 · right
    act = mj.add_actuator(
        name=f"{p}gripper", target=f"{p}gripper", trntype=mujoco.mjtTrn.mjTRN_TENDON
    )
    act.set_to_position(kp=GRIPPER_KP, dampratio=1.0)
    act.ctrllimited = mujoco.mjtLimited.mjLIMITED_TRUE
    act.ctrlrange = [0.0, spec.gripper_max_opening]
    act.forcelimited = mujoco.mjtLimited.mjLIMITED_TRUE
    act.forcerange = [-spec.gripper_force, spec.gripper_force]
