"""What pick- and place-like skills share: their devices, geometry look-ups, safe stops.

Frames and units: world frame, metres. An appliance's pose has its x axis pointing out of its
front (the cavity opens at +x: ``mujoco_sim.models``), so things go in along -x.
"""

from __future__ import annotations

import math

from device_drivers import Arm, Gripper, WorldPose
from skill_agent._errors import SkillFailure
from skill_agent._skill import SkillContext
from skill_agent.primitives._arm import move_joints
from skill_agent.primitives._grasp import extents
from skill_agent.primitives._gripper import open_gripper
from skill_agent.primitives._supervise import halt
from skill_agent.primitives.poses import Vec3, axis
from skill_agent.skills._support import device, element_id, tracked, wm_of, world_transform
from wm_store import WmClient
from wm_store.ontology import Prop

__all__ = ["UP", "arm_of", "depth_inside", "front_of", "go_home", "gripper_of", "make_safe"]

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


def depth_inside(wm: WmClient, appliance: str, tcp: WorldPose) -> float:
    """How far (m) the tcp is behind the appliance's front plane (0 when in front of it): what
    a straight move out along the front must cover before the hand is clear."""
    pose, front = world_transform(wm, appliance), front_of(wm, appliance)
    size = extents(wm.get_element(appliance).properties.get(Prop.size))
    if pose is None or size is None:
        return 0.0
    cx, cy, _ = pose.translation
    plane = (cx + front[0] * size[0] / 2, cy + front[1] * size[0] / 2)
    return max(0.0, (plane[0] - tcp.x) * front[0] + (plane[1] - tcp.y) * front[1])


async def go_home(ctx: SkillContext, arm: Arm) -> None:
    """Move the arm to its home posture (the arm element's ``jointPositions``, one value per
    joint in the arm's joint order, rad), by a joint motion: the safe way between a pick in
    front and a place behind, whatever IK branch the last motion ended on. Nothing to do if
    the world model has no home posture for the arm."""
    home = wm_of(ctx).get_element(element_id(ctx, "arm")).properties.get(Prop.jointPositions)
    if not isinstance(home, list):
        return
    names = list((await arm.state()).joints)
    values = [float(v) for v in home if isinstance(v, int | float) and not isinstance(v, bool)]
    if len(values) != len(names):
        raise SkillFailure(
            f"{arm.name}: jointPositions has {len(values)} values for {len(names)} joints"
        )
    await tracked(
        ctx,
        f"{arm.name} to its home posture",
        lambda cb: move_joints(arm, dict(zip(names, values, strict=True)), progress=cb),
        step="home",
    )


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
