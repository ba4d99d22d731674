"""Probe skills that fail the way the task layer must replan around, run for real (not in
simulated-outcome mode): a post-condition that does not hold after execution, and a
hold-condition the world breaks while the skill runs. The planner can use both (each has a
relation among its post-conditions)."""

from __future__ import annotations

from typing import cast

from skill_agent import SkillContext
from skill_agent.protocol import HasPropertyCond, ParamSpec, RelationCond, SkillDescription
from wm_store import WmClient
from wm_store.protocol import UpdateElement

from .basic import ProbedSkill

__all__ = ["PART_NUMBER", "Convey", "Stow"]

PART_NUMBER = "G-100"
OBJ = ParamSpec(name="obj", type="Part", doc="the part handled")
CONTAINER = ParamSpec(name="container", type="Container", doc="where the part goes")
SOURCE = ParamSpec(name="source", type="Container", doc="where the part is taken from")


class Stow(ProbedSkill):
    """Puts a part into a container and reads its label. The label reads only from the second
    run on (the first ``post_sense`` writes nothing), so the first run fails its checked-only
    post-condition ``has partNumber``: reason ``postcondition``, nothing committed."""

    description = SkillDescription(
        name="stow",
        doc="Put a part into a container and read its part number.",
        parameters=[OBJ, CONTAINER],
        post=[
            RelationCond(subject="container", predicate="contain", object="obj"),
            HasPropertyCond(param="obj", property="partNumber"),
        ],
    )

    async def execute(self, ctx: SkillContext) -> None:
        self.probe.record(ctx.run_id, "execute")

    async def post_sense(self, ctx: SkillContext) -> None:
        await super().post_sense(ctx)
        if self.probe.count("post_sense") >= 2:  # the first read fails
            wm = cast(WmClient, ctx.wm)
            obj = ctx.params["obj"]
            assert isinstance(obj, str)
            await wm.transact([UpdateElement(id=obj, properties={"partNumber": PART_NUMBER})])


class Convey(ProbedSkill):
    """Moves a part from ``source`` into ``container``; the part must stay in ``source`` while
    the robot reaches for it (a hold-condition). It reports progress ("reaching"), then waits
    for the probe's ``reach`` gate."""

    description = SkillDescription(
        name="convey",
        doc="Take a part out of one container and put it into another.",
        parameters=[OBJ, SOURCE, CONTAINER],
        pre=[RelationCond(subject="source", predicate="contain", object="obj")],
        hold=[RelationCond(subject="source", predicate="contain", object="obj")],
        post=[RelationCond(subject="container", predicate="contain", object="obj")],
    )

    async def execute(self, ctx: SkillContext) -> None:
        self.probe.record(ctx.run_id, "execute")
        await ctx.progress("reaching for the part", fraction=0.5, step="reach")
        await self.probe.gate("reach").wait()
        self.probe.record(ctx.run_id, "reached")
