"""What pick- and place-like skills share: their devices, geometry look-ups, safe stops.

Frames and units: world frame, metres. An appliance's pose has its x axis pointing out of its
front (the cavity opens at +x: ``device_drivers.scene_model``), so things go in along -x.
"""

from __future__ import annotations

import math

from device_drivers.interfaces import Arm, Gripper
from wm_store.client import WmClient

from ..errors import SkillFailure
from ..primitives import halt, open_gripper
from ..primitives.poses import Vec3, axis
from ..skill import SkillContext
from .support import device, world_transform

__all__ = ["UP", "arm_of", "front_of", "gripper_of", "make_safe"]

UP: Vec3 = (0.0, 0.0, 1.0)


def arm_of(ctx: SkillContext) -> Arm:
    return device(ctx, "arm", Arm)  # type: ignore[type-abstract]  # a runtime Protocol


def gripper_of(ctx: SkillContext) -> Gripper:
    return device(ctx, "gripper", Gripper)  # type: ignore[type-abstract]  # a runtime Protocol


def front_of(wm: WmClient, appliance: str) -> Vec3:
    """The horizontal direction out of the appliance's front (its x axis), unit, world."""
    pose = world_transform(wm, appliance)
    if pose is None:
        raise SkillFailure(f"the world model has no pose of {appliance}: where is its front?")
    x = axis(pose.rotation, 0)
    n = math.hypot(x[0], x[1])
    if n < 1e-6:
        raise SkillFailure(f"{appliance} lies on its back: its front points up")
    return (x[0] / n, x[1] / n, 0.0)


async def make_safe(ctx: SkillContext) -> None:
    """The safe state after a stop: the arm halts where it is; the gripper keeps what it
    holds (dropping it mid-air is worse) and opens if it holds nothing."""
    arm, gripper = arm_of(ctx), gripper_of(ctx)
    await halt(arm, gripper)
    state = await gripper.state()
    if state.holding:
        await ctx.progress(f"halted, still holding {state.holding}", step="safe_state")
        return
    await open_gripper(gripper)
    await ctx.progress("halted, gripper open", step="safe_state")
