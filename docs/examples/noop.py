"""The smallest skill: no parameters, no conditions, nothing to do. Used to measure the cost of
a run itself (``benchmarks/skills/``) and to check that an agent answers."""

from __future__ import annotations

from skill_agent import Skill, SkillContext
from skill_agent.protocol import SkillDescription


class NoOp(Skill):
    description = SkillDescription(name="noop", doc="Does nothing, successfully.", duration=0.0)

    async def execute(self, ctx: SkillContext) -> None:
        """Nothing to do."""
