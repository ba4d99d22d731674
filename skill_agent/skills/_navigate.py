"""``navigate``: drive a mobile robot from one location to another.

A location's ``pose`` (world frame) is where the robot's base frame goes: a station's pose is
the parking pose to work there, a robot's home its start pose. After the drive the base's own
report is written to the world model: the robot's pose (observed, source = the base), and
everything the robot carries (a kit box and the parts in it: its spatial descendants with a
world-frame pose) is moved by the same rigid motion, so the world model's geometry follows
the robot. A stop (or timeout) halts the base and records where it stopped.

Room for robots (``skill_agent/skills/_spots.py``): before the base moves, the robot reserves
a place at the goal in the world model (compare-and-set on the goal's revision); while the
goal is full it waits, up to ``wait_for_room`` seconds, for a robot to leave, and then fails
naming who is there. Once the base has arrived, the robot gives back every other place it
held (its start), in the transaction that records where the base stands; when the drive
fails or is stopped, it gives back the goal unless the base stopped within
:data:`NEAR_GOAL` of it (it then stands in the way there).
"""

from __future__ import annotations

import math

from device_drivers import MobileBase, MotionError, Pose2D
from skill_agent._errors import SkillFailure
from skill_agent._skill import Skill, SkillContext
from skill_agent.primitives._base import navigate_to
from skill_agent.primitives._supervise import halt
from skill_agent.primitives.poses import to_wm_pose, yaw_of
from skill_agent.protocol._skills import HasPropertyCond, ParamSpec, SkillDescription
from skill_agent.skills._params import BASE, ROBOT, at, offline
from skill_agent.skills._spots import release, release_ops, reserve
from skill_agent.skills._support import (
    carried_ops,
    device,
    element_id,
    failure,
    float_param,
    tracked,
    wm_of,
    world_transform,
)
from wm_store import ConflictError, WmClient, display_name
from wm_store.ontology import Prop
from wm_store.protocol import Observe, Op, UpdateElement
from wm_store.reasoners import Transform, quat_from_yaw

__all__ = ["NEAR_GOAL", "POSITION_TOLERANCE", "YAW_TOLERANCE", "Navigate", "follow_ops"]

POSITION_TOLERANCE = 0.05
"""How far (m) from the goal pose the base may stop and still count as there."""
YAW_TOLERANCE = 0.1
"""Heading error (rad) allowed at the goal."""
NEAR_GOAL = 0.6
"""A base stopped within this distance (m) of the goal keeps its reservation there."""


def _pose2d(t: Transform) -> Pose2D:
    return Pose2D(t.translation[0], t.translation[1], yaw_of(t.rotation))


def _transform(p: Pose2D) -> Transform:
    return Transform((p.x, p.y, 0.0), quat_from_yaw(p.yaw))


def follow_ops(wm: WmClient, robot: str, source: str, reached: Pose2D) -> list[Op]:
    """Ops recording that ``robot``'s base now stands at ``reached``: its pose (an observation
    by ``source``) and the same rigid motion applied to every spatial descendant with a
    world-frame pose."""
    old = world_transform(wm, robot)
    new = _transform(reached)
    ops: list[Op] = [
        UpdateElement(id=robot, remove=[Prop.pose]),
        Observe(id=robot, property=Prop.pose, value=to_wm_pose(new), source=source),
    ]
    if old is None:
        return ops
    return ops + carried_ops(wm, robot, new.compose(old.inverse()))


class Navigate(Skill):
    """Drive the robot from ``start`` to ``goal``."""

    description = SkillDescription(
        name="navigate",
        skill_type="navigate",
        doc="Drive a mobile robot from one location to another (to the goal location's pose).",
        parameters=[
            ROBOT,
            BASE,
            ParamSpec(name="start", type="Location", doc="where the robot is now"),
            ParamSpec(
                name="goal", type="Location", doc="where it goes (its pose: the parking pose)"
            ),
            offline("speed", "float", 0.5, "driving speed, m/s"),
            offline(
                "wait_for_room",
                "float",
                120.0,
                "how long to wait for room at the goal while other robots are there, s",
            ),
        ],
        pre=[
            at("robot", "start"),
            at("robot", "goal", holds=False),
            HasPropertyCond(param="goal", property=Prop.pose),
        ],
        post=[at("robot", "goal"), at("robot", "start", holds=False)],
        duration=5.0,
    )
    success_probability = 0.98

    async def execute(self, ctx: SkillContext) -> None:
        wm = wm_of(ctx)
        goal = element_id(ctx, "goal")
        where = world_transform(wm, goal)
        if where is None:
            raise SkillFailure(f"navigate: the world model has no pose of {goal}")
        base = device(ctx, "base", MobileBase)  # type: ignore[type-abstract]
        target = _pose2d(where)
        await self.take_room(ctx)
        try:
            await tracked(
                ctx,
                f"driving to {display_name(wm.find_element(goal), goal)}",
                lambda cb: navigate_to(base, target, speed=float_param(ctx, "speed"), progress=cb),
                step="drive",
            )
        except MotionError as exc:
            await self._give_back(ctx, await self._record(ctx))
            raise failure("navigate", exc) from exc

    async def take_room(self, ctx: SkillContext) -> None:
        """Reserve a place at the goal, waiting for room (see the module doc)."""

        async def waiting(message: str) -> None:
            await ctx.progress(message, step="wait for room")

        wait = float_param(ctx, "wait_for_room")
        goal = element_id(ctx, "goal")
        await reserve(wm_of(ctx), element_id(ctx, "robot"), goal, wait=wait, waiting=waiting)

    def leave_start(self, ctx: SkillContext) -> list[Op]:
        """Once arrived: the ops giving back every other place the robot held (its start),
        committed with the base's report."""
        return list(release_ops(wm_of(ctx), element_id(ctx, "robot"), keep=element_id(ctx, "goal")))

    async def _give_back(self, ctx: SkillContext, reached: Pose2D) -> None:
        """After a failed or stopped drive: release the goal unless the base stands near it."""
        wm = wm_of(ctx)
        goal = element_id(ctx, "goal")
        where = world_transform(wm, goal)
        if where is not None:
            target = _pose2d(where)
            if math.hypot(reached.x - target.x, reached.y - target.y) <= NEAR_GOAL:
                return
        await release(wm, element_id(ctx, "robot"), only=goal)

    async def post_sense(self, ctx: SkillContext) -> None:
        reached = await self._record(ctx, arrived=True)
        where = world_transform(wm_of(ctx), element_id(ctx, "goal"))
        assert where is not None  # checked in execute
        goal = _pose2d(where)
        off = math.hypot(reached.x - goal.x, reached.y - goal.y)
        turn = abs(math.remainder(reached.yaw - goal.yaw, math.tau))
        if off > POSITION_TOLERANCE or turn > YAW_TOLERANCE:
            raise SkillFailure(
                f"navigate: the base stopped {off:.3f} m / {turn:.3f} rad from the goal pose"
            )

    async def on_preempt(self, ctx: SkillContext) -> None:
        base = device(ctx, "base", MobileBase)  # type: ignore[type-abstract]
        await halt(base)
        await self._give_back(ctx, await self._record(ctx))

    async def _record(self, ctx: SkillContext, *, arrived: bool = False) -> Pose2D:
        """Write where the base stands now (robot pose and what it carries); ``arrived``: with
        the places the robot left given back, in the same transaction."""
        base = device(ctx, "base", MobileBase)  # type: ignore[type-abstract]
        reached = (await base.state()).pose
        wm = wm_of(ctx)
        robot = element_id(ctx, "robot")
        for _ in range(20):  # a place given back changed meanwhile: read again
            ops = follow_ops(wm, robot, element_id(ctx, "base"), reached)
            try:
                await wm.transact(ops + (self.leave_start(ctx) if arrived else []))
                return reached
            except ConflictError:
                await release(wm, robot, keep=element_id(ctx, "goal"))  # then record alone
                arrived = False
        raise SkillFailure("navigate: could not record where the base stands")
