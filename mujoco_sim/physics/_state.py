"""Read and write a MuJoCo state by element name: joint positions, servo set-points, site poses.

Small helpers the drivers and tests share, so that nobody indexes ``qpos`` or ``ctrl`` by hand.
``model``/``data`` are ``MjModel``/``MjData`` (typed ``Any``: the bindings ship no types).
Arrays returned are copies: ``MjData`` arrays are live views and must not cross threads.
"""

from __future__ import annotations

from collections.abc import Iterable, Mapping
from typing import Any

import mujoco
import numpy as np
import numpy.typing as npt

from device_drivers import UnknownElementError

__all__ = [
    "hold_servos",
    "is_position_servo",
    "joint_positions",
    "set_joint_positions",
    "site_pose",
]


def _joint_id(model: Any, name: str) -> int:
    index = int(mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_JOINT, name))
    if index < 0:
        raise UnknownElementError("joint", name, (model.joint(j).name for j in range(model.njnt)))
    return index


def joint_positions(model: Any, data: Any, names: Iterable[str]) -> dict[str, float]:
    """Positions (rad or m) of the named 1-DOF joints; :class:`UnknownElementError` if one is
    missing."""
    return {n: float(data.qpos[model.jnt_qposadr[_joint_id(model, n)]]) for n in names}


def set_joint_positions(
    model: Any, data: Any, values: Mapping[str, float], *, hold: bool = True
) -> None:
    """Write joint positions (rad or m) into ``qpos``; with ``hold``, also set the position
    servo of the same name (if any) to that value so the joint stays there. Velocities are
    left alone; call ``mj_forward`` before reading derived quantities."""
    for name, value in values.items():
        data.qpos[model.jnt_qposadr[_joint_id(model, name)]] = value
        if hold:
            act = int(mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_ACTUATOR, name))
            if act >= 0 and is_position_servo(model, act):
                data.ctrl[act] = value


def is_position_servo(model: Any, actuator: int) -> bool:
    """Whether actuator ``actuator`` is a position servo: force = kp (ctrl - length) - kv v."""
    kp = float(model.actuator_gainprm[actuator, 0])
    return bool(
        model.actuator_gaintype[actuator] == mujoco.mjtGain.mjGAIN_FIXED
        and model.actuator_biastype[actuator] == mujoco.mjtBias.mjBIAS_AFFINE
        and kp > 0
        and np.isclose(model.actuator_biasprm[actuator, 1], -kp)
    )


def hold_servos(model: Any, data: Any) -> None:
    """Set every position servo's set-point to where its joint or tendon is now, clipped to
    the control range: after ``mj_resetData`` the robots then stay put instead of being pulled
    to zero. Runs ``mj_forward`` first (tendon lengths)."""
    mujoco.mj_forward(model, data)
    for act in range(model.nu):
        if not is_position_servo(model, act):
            continue
        target = int(model.actuator_trnid[act, 0])
        trn = model.actuator_trntype[act]
        if trn == mujoco.mjtTrn.mjTRN_JOINT:
            value = float(data.qpos[model.jnt_qposadr[target]])
        elif trn == mujoco.mjtTrn.mjTRN_TENDON:
            value = float(data.ten_length[target])
        else:
            continue
        if model.actuator_ctrllimited[act]:
            low, high = model.actuator_ctrlrange[act]
            value = min(max(value, float(low)), float(high))
        data.ctrl[act] = value


def site_pose(
    model: Any, data: Any, name: str
) -> tuple[npt.NDArray[np.float64], npt.NDArray[np.float64]]:
    """Position (m) and 3x3 rotation matrix of a site in the world frame (copies), as of the
    last kinematics pass."""
    site = int(mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_SITE, name))
    if site < 0:
        raise UnknownElementError("site", name, (model.site(i).name for i in range(model.nsite)))
    return data.site_xpos[site].copy(), data.site_xmat[site].reshape(3, 3).copy()
