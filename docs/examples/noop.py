"""The smallest skill: no parameters, no conditions, nothing to do. Used to measure the cost of
a run itself (``benchmarks/skills.py``) and to check that an agent answers."""

from __future__ import annotations

from skill_agent.protocol import SkillDescription
from skill_agent.skill import Skill, SkillContext


class NoOp(Skill):
    description = SkillDescription(name="noop", doc="Does nothing, successfully.", duration=0.0)

    async def execute(self, ctx: SkillContext) -> None:
        """Nothing to do."""
