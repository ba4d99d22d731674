"""``open_drawer`` / ``close_drawer`` done by a robot arm: slide a cabinet's drawer by its handle.

What the world model knows of a drawer (``scenario.wm`` writes it): its pose (the
box's centre, x out of the cabinet's front), size, ``drawerOpen``, and its handle as a grasp
(``graspPose``: the tcp pointing down at the bar, fingers closing along the drawer's x;
``graspWidth``: the bar's thickness). The arm opens the gripper a little wider than the bar,
comes down onto it from above (one finger drops between the bar and the front panel), pinches
it, moves the tcp in a straight line ``pull`` m along the drawer's x (out to open, in to
close), lets go and goes back up. Because the bar sits between the fingers, the rear finger
pulls the drawer and the front one pushes it, whether the pads slip or not.

Verification, at the end of the slide: the gripper must still be closed on something as thick
as the bar (the pads' gap, not a closed gripper): a handle that slipped out of the fingers
fails the run instead of being believed, and a drawer that does not follow stops the arm (the
motion fails).
The drawer's new pose (and the poses of what lies in it, as ``navigate`` moves what a robot
carries: :func:`~skill_agent.skills._support.carried_ops`) are written with the predicted
``drawerOpen``.
"""

from __future__ import annotations

from typing import ClassVar

from device_drivers import DeviceError
from skill_agent._errors import SkillFailure
from skill_agent._skill import Skill, SkillContext
from skill_agent.primitives._arm import approach, move_cartesian, retreat
from skill_agent.primitives._gripper import close_gripper, open_gripper
from skill_agent.primitives.poses import axis, to_transform, to_world_pose
from skill_agent.protocol._skills import (
    Condition,
    ParamSpec,
    PropertyCond,
    RelationCond,
    SkillDescription,
)
from skill_agent.skills._manipulation import arm_of, gripper_of, make_safe
from skill_agent.skills._params import ARM, GRIPPER, LOCATION, ROBOT, at, empty, offline
from skill_agent.skills._support import (
    carried_ops,
    element_id,
    failure,
    float_param,
    geometry,
    tracked,
    wm_of,
    world_transform,
)
from wm_store import WmClient
from wm_store.ontology import Cls, Prop, Rel
from wm_store.protocol import Op
from wm_store.reasoners import Transform

__all__ = ["ArmCloseDrawer", "ArmOpenDrawer", "drawer_is", "slide_ops"]

SLACK = 0.024
"""How much wider than the bar the gripper opens to come down onto it, m."""
HOLD_MIN = 0.5
"""At the end of the slide the pads must still be at least this share of the bar apart."""


def drawer_is(drawer: str, open_: bool) -> PropertyCond:
    """``drawerOpen(drawer) == open_``."""
    return PropertyCond(param=drawer, property=Prop.drawerOpen, op="eq", value=open_)


def slide_ops(wm: WmClient, drawer: str, offset: float) -> list[Op]:
    """Ops moving ``drawer`` and everything in it ``offset`` m along the drawer's x."""
    pose = world_transform(wm, drawer)
    if pose is None:
        return []
    dx, dy, dz = (offset * a for a in axis(pose.rotation, 0))
    return carried_ops(wm, drawer, Transform((dx, dy, dz)), with_root=True)


_PARAMS = [
    ParamSpec(name="cabinet", type=Cls.Cabinet, doc="the cabinet the drawer slides out of"),
    ParamSpec(name="drawer", type=Cls.Drawer, doc="the drawer"),
    LOCATION,
    ROBOT,
    ARM,
    GRIPPER,
    offline("pull", "float", 0.20, "how far the drawer is pulled out (pushed back in), m"),
    offline("speed", "float", 0.05, "tool speed while the drawer slides, m/s"),
]
_WHERE: list[Condition] = [
    RelationCond(subject="cabinet", predicate=Rel.hasA, object="drawer"),
    at("robot", "location"),
    at("cabinet", "location"),
    empty("gripper"),
]


class _ArmDrawer(Skill):
    opening: ClassVar[bool] = True

    async def execute(self, ctx: SkillContext) -> None:
        wm, arm, gripper = wm_of(ctx), arm_of(ctx), gripper_of(ctx)
        drawer = geometry(wm, element_id(ctx, "drawer"))
        pose, _size = drawer.require(ctx.description.name)
        grasp, width = drawer.grasp_pose(), drawer.grasp_width()
        if grasp is None or width is None:
            raise SkillFailure(
                f"{ctx.description.name}: the world model has no handle (graspPose, "
                f"graspWidth) of {drawer.name}"
            )
        pull = float_param(ctx, "pull")
        direction = axis(pose.rotation, 0)  # out of the cabinet
        sign = 1.0 if self.opening else -1.0
        handle = pose.compose(to_transform(grasp))
        dx, dy, dz = (sign * pull * d for d in direction)
        end = Transform((dx, dy, dz)).compose(handle)
        try:
            await open_gripper(gripper, width + SLACK)
            await approach(arm, to_world_pose(handle), 0.08)
            await close_gripper(gripper)
            await tracked(
                ctx,
                f"{'pulling' if self.opening else 'pushing'} {drawer.name}",
                lambda cb: move_cartesian(
                    arm, to_world_pose(end), speed=float_param(ctx, "speed"), progress=cb
                ),
                step="slide",
            )
            held = (await gripper.state()).opening
            if held < HOLD_MIN * width:
                raise SkillFailure(
                    f"{ctx.description.name}: the handle of {drawer.name} slipped out of the "
                    f"gripper (pads {held * 1000:.0f} mm apart at the end, the bar is "
                    f"{width * 1000:.0f} mm)"
                )
            await open_gripper(gripper, width + SLACK)
            await retreat(arm, 0.08)
        except DeviceError as exc:
            raise failure(ctx.description.name, exc) from exc
        await wm.transact(slide_ops(wm, drawer.element.id, sign * pull))

    async def on_preempt(self, ctx: SkillContext) -> None:
        await make_safe(ctx)


class ArmOpenDrawer(_ArmDrawer):
    description = SkillDescription(
        name="open_drawer",
        skill_type="open_drawer",
        doc="Pull a cabinet's drawer out by its handle with the arm.",
        parameters=_PARAMS,
        pre=[*_WHERE, drawer_is("drawer", False)],
        post=[drawer_is("drawer", True)],
        duration=8.0,
    )
    opening = True


class ArmCloseDrawer(_ArmDrawer):
    description = SkillDescription(
        name="close_drawer",
        skill_type="close_drawer",
        doc="Push a cabinet's open drawer back in by its handle with the arm.",
        parameters=_PARAMS,
        pre=[*_WHERE, drawer_is("drawer", True)],
        post=[drawer_is("drawer", False)],
        duration=8.0,
    )
    opening = False
