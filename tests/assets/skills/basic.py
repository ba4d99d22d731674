"""Example skills with no conditions: no-op, waiting, slow with progress, failing, buggy."""

from __future__ import annotations

import anyio

from skill_agent import Skill, SkillContext, SkillFailure
from skill_agent.protocol import ParamSpec, SkillDescription

from .probe import Probe

__all__ = ["Buggy", "Fail", "Noop", "ProbedSkill", "Slow", "Wait"]

GRIPPER = ParamSpec(name="gripper", type="Gripper", kind="hardware", doc="the gripper used")


class ProbedSkill(Skill):
    """Reports every lifecycle call to its probe; ``on_preempt`` records a safe state."""

    def __init__(self, probe: Probe | None = None) -> None:
        self.probe = probe if probe is not None else Probe()

    async def pre_sense(self, ctx: SkillContext) -> None:
        self.probe.record(ctx.run_id, "pre_sense")

    async def post_sense(self, ctx: SkillContext) -> None:
        self.probe.record(ctx.run_id, "post_sense")

    async def on_preempt(self, ctx: SkillContext) -> None:
        self.probe.record(ctx.run_id, "on_preempt")
        device = ctx.params.get("gripper")
        self.probe.safe_states.append(f"{ctx.run_id}: {device or 'nothing'} opened and parked")


class Noop(ProbedSkill):
    description = SkillDescription(name="noop", doc="Does nothing; succeeds.")

    async def execute(self, ctx: SkillContext) -> None:
        self.probe.record(ctx.run_id, "execute")


class Wait(ProbedSkill):
    """Holds its gripper until the probe's ``release`` gate opens, then passes a checkpoint."""

    description = SkillDescription(
        name="wait", doc="Waits for the test to release it.", parameters=[GRIPPER]
    )

    async def execute(self, ctx: SkillContext) -> None:
        self.probe.record(ctx.run_id, "execute")
        await ctx.progress("waiting for release", fraction=0.0)
        await self.probe.gate("release").wait()
        self.probe.record(ctx.run_id, "released")
        await ctx.checkpoint()
        self.probe.record(ctx.run_id, "after_checkpoint")


class Slow(ProbedSkill):
    """Moves in ``steps`` steps of ``step_time`` seconds, reporting progress at each."""

    description = SkillDescription(
        name="slow",
        doc="A long motion in steps.",
        parameters=[
            GRIPPER,
            ParamSpec(name="steps", type="int", kind="offline", default=4),
            ParamSpec(name="step_time", type="float", kind="offline", default=0.002),
        ],
        duration=0.01,
    )

    async def execute(self, ctx: SkillContext) -> None:
        self.probe.record(ctx.run_id, "execute")
        steps, step_time = ctx.params["steps"], ctx.params["step_time"]
        assert isinstance(steps, int) and isinstance(step_time, float)
        for i in range(steps):
            await ctx.checkpoint()
            await ctx.progress(f"step {i + 1}/{steps}", fraction=(i + 1) / steps, step="move")
            await anyio.sleep(step_time)


class Fail(ProbedSkill):
    description = SkillDescription(name="fail", doc="Always fails.")

    async def execute(self, ctx: SkillContext) -> None:
        self.probe.record(ctx.run_id, "execute")
        raise SkillFailure("the part slipped out of the gripper")


class Buggy(ProbedSkill):
    description = SkillDescription(name="buggy", doc="Has a bug.", parameters=[GRIPPER])

    async def execute(self, ctx: SkillContext) -> None:
        self.probe.record(ctx.run_id, "execute")
        table: dict[str, float] = {}
        print(table["missing calibration"])
