"""Gripper openings in metres, whatever the gripper's actuator takes (simulation thread only).

A gripper controller speaks metres (pad-to-pad opening) and newtons (squeeze force); a
gripper's actuator may not. :func:`gripper_drive` returns the drive of a robot's gripper:

- :class:`TendonDrive`, the generated gripper: its servo's set-point *is* the opening (a fixed
  tendon measures it), its force limit the squeeze force.
- :class:`PadDrive`, a gripper from a file (the Robotiq 2F-85: control 0 open .. 255
  closed through a four-bar linkage). The opening is measured as the gap between the inner
  faces of the two pads along the tool's closing axis. The control for an opening comes from a
  calibration made once, when the world is built: the gripper file alone, without gravity, is
  stepped to rest at a few controls and the gap measured at each (its cost: docs/benchmarks.md,
  section Robot models and IK); between those points it is interpolated. A
  squeeze force ``f`` sets the actuator's force limit to ``f / gripper_force`` of the file's
  own limit (``gripper_force``: the rated force of :class:`~scenario.RobotSpec`).
"""

from __future__ import annotations

from typing import Any

import mujoco
import numpy as np
import numpy.typing as npt

from mujoco_sim.models._file_robot import set_gripper
from mujoco_sim.models._menagerie import load_mjcf, menagerie_paths
from scenario import MjcfArm, RobotLayout, RobotSpec

__all__ = [
    "Calibration",
    "GripperDrive",
    "PadDrive",
    "TendonDrive",
    "calibrate",
    "calibrate_in",
    "gripper_drive",
    "pad_gap",
]

FloatArray = npt.NDArray[np.float64]
Calibration = tuple[FloatArray, FloatArray, float]
"""Controls, the pad gaps (m) they settle at, and |d gap / d finger angle| (m/rad)."""
_CALIBRATION_POINTS = 6
_SETTLE_STEPS = 400


class GripperDrive:
    """Opening (m) <-> actuator control of one gripper (the interface; see the subclasses)."""

    def __init__(self, model: Any, layout: RobotLayout, spec: RobotSpec) -> None:
        self.m = model
        self.act = model.actuator(layout.gripper_actuator).id
        self.max_opening = spec.gripper_max_opening
        self.rated_force = spec.gripper_force

    def opening(self, data: Any) -> float:
        """Pad-to-pad opening now, m."""
        raise NotImplementedError

    def speed(self, data: Any) -> float:
        """How fast the opening changes now (absolute), m/s."""
        raise NotImplementedError

    def control(self, opening: float) -> float:
        """The actuator control that drives the fingers to ``opening`` (m)."""
        raise NotImplementedError

    def limit_force(self, force: float) -> None:
        """Squeeze with at most ``force`` N (at most the rated force)."""
        raise NotImplementedError

    def start_open(self, data: Any) -> None:
        """Put the fingers fully open now (before the first step)."""
        data.ctrl[self.act] = self.control(self.max_opening)


class TendonDrive(GripperDrive):
    """The generated gripper: set-point = opening, force limit = squeeze force."""

    def __init__(self, model: Any, layout: RobotLayout, spec: RobotSpec) -> None:
        super().__init__(model, layout, spec)
        self.tendon = model.tendon(layout.gripper_tendon).id
        self.fingers = [model.jnt_qposadr[model.joint(j).id] for j in layout.finger_joints]

    def opening(self, data: Any) -> float:
        return float(data.ten_length[self.tendon])

    def speed(self, data: Any) -> float:
        return abs(float(data.ten_velocity[self.tendon]))

    def control(self, opening: float) -> float:
        return float(np.clip(opening, 0.0, self.max_opening))

    def limit_force(self, force: float) -> None:
        force = min(force, self.rated_force)
        self.m.actuator_forcerange[self.act] = [-force, force]

    def start_open(self, data: Any) -> None:
        data.qpos[self.fingers] = self.max_opening / 2
        super().start_open(data)


class PadDrive(GripperDrive):
    """A gripper from a file: the opening measured at the pads, the control calibrated."""

    def __init__(
        self,
        model: Any,
        layout: RobotLayout,
        spec: RobotSpec,
        calibration: Calibration,
    ) -> None:
        super().__init__(model, layout, spec)
        self.left = np.array([model.geom(g).id for g in layout.pad_geoms[0]])
        self.right = np.array([model.geom(g).id for g in layout.pad_geoms[1]])
        self.site = model.site(layout.tcp_site).id
        self.fingers = [model.jnt_dofadr[model.joint(j).id] for j in layout.finger_joints]
        controls, gaps, self.slope = calibration
        order = np.argsort(gaps)
        self.gaps, self.controls = gaps[order], controls[order]
        limited = bool(model.actuator_forcelimited[self.act])
        self.full_force = float(np.max(np.abs(model.actuator_forcerange[self.act]))) * limited

    def opening(self, data: Any) -> float:
        return pad_gap(self.m, data, self.left, self.right, self.site)

    def speed(self, data: Any) -> float:
        return float(np.mean(np.abs(data.qvel[self.fingers]))) * self.slope

    def control(self, opening: float) -> float:
        return float(np.interp(opening, self.gaps, self.controls))

    def limit_force(self, force: float) -> None:
        if not self.full_force:  # the file sets no force limit: squeeze as it does
            return
        share = min(force, self.rated_force) / self.rated_force
        self.m.actuator_forcerange[self.act] = [-share * self.full_force, share * self.full_force]


def gripper_drive(
    model: Any,
    layout: RobotLayout,
    spec: RobotSpec,
    calibrations: dict[MjcfArm, Calibration] | None = None,
) -> GripperDrive:
    """The drive of robot ``spec``'s gripper in ``model`` (calibrated now for an MJCF one;
    ``calibrations``: ones made before, for robots with the same files, reused and added to)."""
    if spec.mjcf is None:
        return TendonDrive(model, layout, spec)
    known = {} if calibrations is None else calibrations
    if spec.mjcf not in known:
        one_file = spec.mjcf.one_file
        known[spec.mjcf] = calibrate_in(model, layout) if one_file else calibrate(spec.mjcf)
    return PadDrive(model, layout, spec, known[spec.mjcf])


def pad_gap(
    model: Any, data: Any, left: npt.NDArray[np.int_], right: npt.NDArray[np.int_], site: int
) -> float:
    """Gap between the inner faces of the ``left`` and ``right`` pad geoms (boxes) along the
    y axis of ``site`` (the closing axis), m; from the last forward pass."""
    axis = data.site_xmat[site].reshape(3, 3)[:, 1]
    sides = []
    for geoms in (left, right):
        centre = float(np.mean(data.geom_xpos[geoms] @ axis))
        rot = data.geom_xmat[geoms[0]].reshape(3, 3)
        half = float(np.abs(rot.T @ axis) @ model.geom_size[geoms[0]])
        sides.append((centre, half))
    (c1, h1), (c2, h2) = sides
    return abs(c1 - c2) - h1 - h2


def calibrate(arm: MjcfArm) -> Calibration:
    """Controls, the gaps (m) they settle at, and the mean |d gap / d finger angle| (m/rad) of
    ``arm``'s gripper file alone, without gravity (see the module doc)."""
    _arm_path, path = menagerie_paths(arm)
    model = load_mjcf(path).compile()
    model.opt.gravity[:] = 0.0
    data = mujoco.MjData(model)
    act = model.actuator(arm.gripper_actuator).id
    low, high = model.actuator_ctrlrange[act] if model.actuator_ctrllimited[act] else (0.0, 1.0)
    left = np.array([model.geom(g).id for g in arm.left_pads])
    right = np.array([model.geom(g).id for g in arm.right_pads])
    site = model.site(arm.tcp_site).id
    finger = model.jnt_qposadr[model.joint(arm.finger_joints[0]).id]
    controls = np.linspace(low, high, _CALIBRATION_POINTS)
    gaps, angles = np.zeros_like(controls), np.zeros_like(controls)
    for i, ctrl in enumerate(controls):
        mujoco.mj_resetData(model, data)
        data.ctrl[act] = ctrl
        mujoco.mj_step(model, data, nstep=_SETTLE_STEPS)
        mujoco.mj_forward(model, data)
        gaps[i] = pad_gap(model, data, left, right, site)
        angles[i] = data.qpos[finger]
    span = abs(angles[-1] - angles[0])
    slope = abs(gaps[-1] - gaps[0]) / span if span > 1e-9 else 0.0
    return controls, gaps, slope


def calibrate_in(model: Any, layout: RobotLayout) -> Calibration:
    """The calibration of a one-file robot's gripper, kinematically in ``model``: its servo
    (``layout.gripper_actuator``) is a position servo on the driven joint, so a control is the
    joint value it settles at unloaded; the followers are set by their joint equalities and
    the gap between the pads measured."""
    data = mujoco.MjData(model)
    act = model.actuator(layout.gripper_actuator).id
    joint = int(model.actuator_trnid[act, 0])
    left = np.array([model.geom(g).id for g in layout.pad_geoms[0]])
    right = np.array([model.geom(g).id for g in layout.pad_geoms[1]])
    site = model.site(layout.tcp_site).id
    low, high = (float(v) for v in model.actuator_ctrlrange[act])
    controls = np.linspace(low, high, _CALIBRATION_POINTS)
    gaps = np.zeros_like(controls)
    for i, ctrl in enumerate(controls):
        set_gripper(model, data, (model.joint(joint).name,), float(ctrl))
        gaps[i] = pad_gap(model, data, left, right, site)
    span = abs(controls[-1] - controls[0])
    slope = abs(gaps[-1] - gaps[0]) / span if span > 1e-9 else 0.0
    return controls, gaps, slope
