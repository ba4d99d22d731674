"""A skill plug-in with its own ontology terms: ``inspect`` looks at a part and records that it
was inspected (``inspected`` = true, with an ``inspectionScore``).

Neither property is in the core ontology: the skill ships them in ``inspection.ttl``
(:attr:`Skill.ontology`). An agent that loads the skill teaches them to the world model
first, so the task agent can plan for a goal such as ``inspected(Gear-3) = true`` and every
client can read them, with no ``--ontology`` anywhere. See docs/guides/write-a-skill.md.
"""

from __future__ import annotations

from skill_agent import Skill, SkillContext
from skill_agent.protocol import ParamSpec, PropertyCond, SkillDescription
from wm_store.protocol import UpdateElement

__all__ = ["Inspect"]


class Inspect(Skill):
    """Inspect ``part`` (a stand-in for a camera check) and record the verdict."""

    ontology = ("inspection.ttl",)
    description = SkillDescription(
        name="inspect",
        skill_type="sense",
        doc="Look at a part and record that it was inspected.",
        parameters=[ParamSpec(name="part", type="Part", doc="the part to inspect")],
        post=[PropertyCond(param="part", property="inspected", value=True)],
        duration=1.0,
    )

    async def execute(self, ctx: SkillContext) -> None:
        part = ctx.params["part"]
        assert isinstance(part, str)
        await ctx.progress(f"looking at {part}", fraction=0.5)
        await ctx.transact([UpdateElement(id=part, properties={"inspectionScore": 0.93})])
