"""The placo export: keyframes and frames gone, a masked dummy floating base, and placo's forward
kinematics equal to MuJoCo's."""

from __future__ import annotations

import xml.etree.ElementTree as ET
from collections.abc import Callable, Mapping
from pathlib import Path
from typing import Any

import mujoco
import numpy as np
import numpy.typing as npt
import pytest

from device_drivers import ModelError
from mujoco_sim.models import build_robot
from mujoco_sim.physics import set_joint_positions, site_pose
from mujoco_sim.placo_ik import IK_ROOT, PlacoIK, load_placo_robot, placo_mjcf
from scenario import RobotLayout, RobotSpec

pytestmark = pytest.mark.sim

ASSET = Path(__file__).parents[2] / "assets" / "arm_with_frames.xml"
Pose = tuple[npt.NDArray[np.float64], npt.NDArray[np.float64]]


def test_export_fixes_the_quirks() -> None:
    root = ET.fromstring(placo_mjcf(mujoco.MjSpec.from_file(str(ASSET))))
    assert root.find("keyframe") is None
    assert root.find("actuator") is None
    assert not list(root.iter("frame"))
    assert {b.get("name") for b in root.iter("body")} == {IK_ROOT, "base", "link1", "link2"}
    wrapper = root.find("worldbody/body")
    assert wrapper is not None
    assert wrapper.get("name") == IK_ROOT
    assert wrapper.get("pos") is None
    assert [j.get("name") for j in wrapper.findall("freejoint")] == [IK_ROOT]


def _placo_vs_mujoco(spec: Any, site: str, rng: np.random.Generator, n: int) -> tuple[float, float]:
    """Largest position (m) and rotation-matrix entry difference over ``n`` random configs."""
    robot = load_placo_robot(spec)
    model = spec.compile()
    data = mujoco.MjData(model)
    joints = [model.joint(i).name for i in range(model.njnt)]
    worst_pos = worst_rot = 0.0
    for _ in range(n):
        q = {}
        for name in joints:
            low, high = model.joint(name).range
            q[name] = float(rng.uniform(low, high) if high > low else rng.uniform(-2, 2))
            robot.set_joint(name, q[name])
        robot.update_kinematics()
        set_joint_positions(model, data, q, hold=False)
        mujoco.mj_kinematics(model, data)
        pos, rot = site_pose(model, data, site)
        t = np.asarray(robot.get_T_world_frame(site))
        worst_pos = max(worst_pos, float(np.abs(t[:3, 3] - pos).max()))
        worst_rot = max(worst_rot, float(np.abs(t[:3, :3] - rot).max()))
    return worst_pos, worst_rot


def test_fk_parity_generated_robot(spec: RobotSpec, layout: RobotLayout) -> None:
    """50 random configurations, base joints included: placo's tcp frame == MuJoCo's site."""
    worst_pos, worst_rot = _placo_vs_mujoco(
        build_robot(spec), layout.tcp_site, np.random.default_rng(11), 50
    )
    assert worst_pos < 1e-9
    assert worst_rot < 1e-9


def test_fk_parity_seven_dof_robot() -> None:
    spec = RobotSpec(name="seven", arm_dof=7)
    worst = _placo_vs_mujoco(build_robot(spec), "seven/tcp", np.random.default_rng(12), 20)
    assert max(worst) < 1e-9


@pytest.mark.parametrize("site", ["tool", "pinch"])
def test_fk_parity_model_with_frames(site: str) -> None:
    """Nested frames, a posed root body, a site two static bodies deep. Element poses are
    written with 6 digits by ``to_xml``; frames flattened here keep full precision."""
    worst = _placo_vs_mujoco(
        mujoco.MjSpec.from_file(str(ASSET)), site, np.random.default_rng(13), 20
    )
    assert max(worst) < 1e-5


def test_placo_fk_matches_solver_view(
    spec: RobotSpec, layout: RobotLayout, fk: Callable[[Mapping[str, float]], Pose]
) -> None:
    ik = PlacoIK.for_robot(spec)
    q = dict.fromkeys(layout.servo_joints, 0.3)
    pos, rot = ik.tcp_pose(q)
    ref_pos, ref_rot = fk(q)
    assert np.allclose(pos, ref_pos, atol=1e-12)
    assert np.allclose(rot, ref_rot, atol=1e-12)


def test_model_that_does_not_compile_is_a_model_error() -> None:
    broken = mujoco.MjSpec()
    broken.modelname = "broken"
    body = broken.worldbody.add_body(name="b")
    body.add_joint(name="j", type=mujoco.mjtJoint.mjJNT_HINGE)  # a moving body without mass
    with pytest.raises(ModelError, match="broken"):
        placo_mjcf(broken)
