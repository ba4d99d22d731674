"""The example skill of docs/guides/write-a-skill.md: pick a part out of a container.

It has parameters of each kind, pre-, hold- and post-conditions, reports progress, honours
pause, and brings the gripper to a safe state when it is stopped. The motion itself is a
stand-in (it waits ``motion_time`` seconds); a real skill would drive the arm and gripper
through ``ctx.device(...)``.
"""

from __future__ import annotations

from typing import cast

import anyio

from skill_agent import Skill, SkillContext
from skill_agent.protocol import (
    EmptyCond,
    ParamSpec,
    RelationCond,
    SkillDescription,
)
from wm_store import WmClient

OPEN_WIDTH = 0.08
"""Gripper opening (m) written to the world model as the safe state after a stop."""


class PickPart(Skill):
    """Take ``part`` out of ``container`` with ``gripper``."""

    description = SkillDescription(
        name="pick_part",
        skill_type="pick",
        doc="Pick a part out of a container with the robot's gripper.",
        parameters=[
            ParamSpec(name="part", type="Part", doc="the part to pick"),
            ParamSpec(name="container", type="Container", doc="where the part is now"),
            ParamSpec(name="gripper", type="Gripper", kind="hardware", doc="the gripper to use"),
            ParamSpec(
                name="motion_time",
                type="float",
                kind="offline",
                default=0.2,
                doc="seconds the (stand-in) motion takes",
            ),
        ],
        pre=[
            RelationCond(subject="container", predicate="contain", object="part"),
            EmptyCond(param="gripper"),
        ],
        # While we reach for it, the part must stay where we reach: if someone takes it
        # away, the run stops (reason hold_violated) and on_preempt opens the gripper.
        hold=[RelationCond(subject="container", predicate="contain", object="part")],
        # The prediction: committed to the world model when the run succeeds (it also moves
        # the part out of the container, since `contain` keeps a tree).
        post=[RelationCond(subject="gripper", predicate="contain", object="part")],
        duration=0.5,
    )
    success_probability = 0.9  # in simulated-outcome mode, unless the config says otherwise

    async def execute(self, ctx: SkillContext) -> None:
        steps = 10
        motion_time = ctx.params["motion_time"]
        assert isinstance(motion_time, float)
        for i in range(steps):
            await ctx.checkpoint()  # a pause holds here
            await ctx.progress(f"approaching {ctx.params['part']}", fraction=i / steps)
            await anyio.sleep(motion_time / steps)  # a stop lands here as cancellation
        await ctx.progress("closing the gripper", fraction=1.0)

    async def on_preempt(self, ctx: SkillContext) -> None:
        """Open the gripper and record it: the safe state after a stop."""
        gripper = ctx.params["gripper"]
        assert isinstance(gripper, str)
        wm = cast(WmClient, ctx.wm)
        await wm.update_element(gripper, {"graspWidth": OPEN_WIDTH})
        await ctx.progress("gripper opened", step="safe_state")
