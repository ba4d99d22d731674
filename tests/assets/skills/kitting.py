"""Pick-like symbolic example skills with conditions, a hold-condition and a composite."""

from __future__ import annotations

import msgspec

from skill_agent import CompositeSkill, Selector, Sequence, SkillContext, Step
from skill_agent.protocol import (
    EmptyCond,
    HasPropertyCond,
    ParamSpec,
    RelationCond,
    SkillDescription,
)

from .basic import GRIPPER, ProbedSkill

__all__ = ["Carry", "FailThenNoop", "Pick", "PickAndPlace", "Place", "TrustingPick", "Weigh"]

OBJ = ParamSpec(name="obj", type="Part", doc="the part handled")
CONTAINER = ParamSpec(name="container", type="Container", doc="where the part goes")
HOLDING = RelationCond(subject="gripper", predicate="contain", object="obj")


class Pick(ProbedSkill):
    """Grasp a part with an empty gripper (symbolic: the effect is the prediction)."""

    description = SkillDescription(
        name="pick",
        skill_type="pick",
        doc="Pick a part.",
        parameters=[GRIPPER, OBJ],
        pre=[EmptyCond(param="gripper")],
        post=[HOLDING],
    )
    senses = ("obj",)

    async def execute(self, ctx: SkillContext) -> None:
        self.probe.record(ctx.run_id, "execute")


class TrustingPick(Pick):
    """``pick`` that trusts world-model data younger than a minute (skips sensing)."""

    description = msgspec.structs.replace(
        Pick.description, name="trusting_pick", sensing_max_age=60.0
    )


class Place(ProbedSkill):
    description = SkillDescription(
        name="place",
        doc="Put the held part into a container.",
        parameters=[GRIPPER, OBJ, CONTAINER],
        pre=[HOLDING],
        post=[RelationCond(subject="container", predicate="contain", object="obj")],
    )

    async def execute(self, ctx: SkillContext) -> None:
        self.probe.record(ctx.run_id, "execute")


class Carry(ProbedSkill):
    """Holds the part until released; the part must stay in the gripper meanwhile."""

    description = SkillDescription(
        name="carry",
        doc="Carry a held part.",
        parameters=[GRIPPER, OBJ],
        pre=[HOLDING],
        hold=[HOLDING],
    )

    async def execute(self, ctx: SkillContext) -> None:
        self.probe.record(ctx.run_id, "execute")
        await self.probe.gate("release").wait()


class Weigh(ProbedSkill):
    """Its post-condition is checked only (no effect) and never true in the test scene."""

    description = SkillDescription(
        name="weigh",
        doc="Measure a part (expects a temperature reading too).",
        parameters=[OBJ],
        post=[HasPropertyCond(param="obj", property="temperature")],
    )

    async def execute(self, ctx: SkillContext) -> None:
        self.probe.record(ctx.run_id, "execute")


class PickAndPlace(CompositeSkill):
    description = SkillDescription(
        name="pick_and_place",
        doc="Pick a part and place it into a container.",
        parameters=[GRIPPER, OBJ, CONTAINER],
        pre=[EmptyCond(param="gripper")],
        post=[RelationCond(subject="container", predicate="contain", object="obj")],
    )
    tree = Sequence(
        [
            Step("pick", {"gripper": "gripper", "obj": "obj"}),
            Step("place", {"gripper": "gripper", "obj": "obj", "container": "container"}),
        ]
    )


class FailThenNoop(CompositeSkill):
    """A fallback: ``fail`` first, then ``noop``."""

    description = SkillDescription(name="fail_then_noop", doc="Fallback demo.")
    tree = Selector([Step("fail"), Step("noop")])
