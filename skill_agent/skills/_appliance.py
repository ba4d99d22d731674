"""Skills of a smart appliance's own agent (FRIEND II's smart microwave): ``open_door``,
``close_door`` and ``heat``, driving the :class:`~device_drivers.Appliance` device.

The appliance is the agent's machine and its hardware parameter (so a heat and a door motion
never overlap: they lock the same device). Every skill checks the appliance's own report after
acting (``post_sense``): a door that did not reach its position, a heater that did not finish
fail the run honestly. ``heat`` first checks (``pre_sense``) that the object really is in the
cavity, by the appliance's ``contents``. A stop halts the door motor or the heater.

``doorOpen`` and ``heating`` are properties of the appliance in the ontology, so the door's
state is ``doorOpen(appliance)``; the door element (``hasA``) names which door.
"""

from __future__ import annotations

from device_drivers import Appliance, DeviceError
from skill_agent._errors import SkillFailure
from skill_agent._skill import Skill, SkillContext
from skill_agent.primitives._supervise import halt, supervise
from skill_agent.protocol._skills import ParamSpec, PropertyCond, RelationCond, SkillDescription
from skill_agent.skills._params import contains, door_is, offline
from skill_agent.skills._support import device, element_id, failure, float_param, tracked, wm_of
from wm_store.ontology import Cls, Prop, Rel

__all__ = ["HEATED", "ApplianceCloseDoor", "ApplianceOpenDoor", "Heat"]

HEATED: str | None = getattr(Prop, "heated", None)
"""The boolean ``heated`` property, once the ontology has it (the meal goal
``heated(MealBox-1)`` needs it); until then ``heat`` predicts nothing about the object."""

APPLIANCE = ParamSpec(
    name="appliance", type=Cls.Appliance, kind="hardware", doc="the appliance (this agent's)"
)
DOOR = ParamSpec(name="door", type=Cls.Door, doc="its door")
NOT_HEATING = PropertyCond(param="appliance", property=Prop.heating, op="eq", value=False)
HAS_DOOR = RelationCond(subject="appliance", predicate=Rel.hasA, object="door")


def _appliance(ctx: SkillContext) -> Appliance:
    return device(ctx, "appliance", Appliance)  # type: ignore[type-abstract]  # runtime Protocol


class _Door(Skill):
    """Drive the door motor to open (``want_open``) or closed, then check the door's angle."""

    want_open: bool = True

    async def execute(self, ctx: SkillContext) -> None:
        appliance = _appliance(ctx)
        verb = "opening" if self.want_open else "closing"
        try:
            await tracked(
                ctx,
                f"{verb} the door of {appliance.name}",
                lambda cb: supervise(
                    appliance,
                    f"{appliance.name}: door",
                    lambda: appliance.set_door(self.want_open, progress=cb),
                ),
                step="door",
            )
        except DeviceError as exc:
            raise failure(ctx.description.name, exc) from exc

    async def post_sense(self, ctx: SkillContext) -> None:
        state = await _appliance(ctx).state()
        if state.door_open != self.want_open:
            want = "open" if self.want_open else "closed"
            raise SkillFailure(
                f"{ctx.description.name}: the door is not {want} (angle {state.door_angle:.2f} rad)"
            )

    async def on_preempt(self, ctx: SkillContext) -> None:
        await halt(_appliance(ctx))


class ApplianceOpenDoor(_Door):
    description = SkillDescription(
        name="open_door",
        skill_type="open_door",
        doc="Open the appliance's door with its own motor (stops nothing: not while heating).",
        parameters=[APPLIANCE, DOOR],
        pre=[HAS_DOOR, door_is("appliance", False), NOT_HEATING],
        post=[door_is("appliance", True)],
        duration=2.0,
    )
    want_open = True


class ApplianceCloseDoor(_Door):
    description = SkillDescription(
        name="close_door",
        skill_type="close_door",
        doc="Close the appliance's door with its own motor.",
        parameters=[APPLIANCE, DOOR],
        pre=[HAS_DOOR, door_is("appliance", True)],
        post=[door_is("appliance", False)],
        duration=2.0,
    )
    want_open = False


class Heat(Skill):
    """Heat what is inside for ``duration`` seconds (simulated time) with the door closed."""

    description = SkillDescription(
        name="heat",
        skill_type="heat",
        doc="Heat the object inside the appliance for `duration` s at `power` (door closed).",
        parameters=[
            APPLIANCE,
            ParamSpec(name="object", type=Cls.PhysicalObject, doc="what is heated"),
            offline("duration", "float", 30.0, "heating time, s"),
            offline("power", "float", 1.0, "fraction of the heating power, 0..1"),
        ],
        pre=[contains("appliance", "object"), door_is("appliance", False), NOT_HEATING],
        post=[
            NOT_HEATING,
            *([PropertyCond(param="object", property=HEATED, value=True)] if HEATED else []),
        ],
        duration=30.0,
    )

    async def pre_sense(self, ctx: SkillContext) -> None:
        label = wm_of(ctx).get_element(element_id(ctx, "object")).label
        contents = (await _appliance(ctx).state()).contents
        if label not in contents:
            inside = ", ".join(contents) or "nothing"
            raise SkillFailure(f"heat: {label} is not in the appliance (it holds {inside})")

    async def execute(self, ctx: SkillContext) -> None:
        appliance = _appliance(ctx)
        duration, power = float_param(ctx, "duration"), float_param(ctx, "power")
        try:
            await tracked(
                ctx,
                f"heating for {duration:g} s at {power:.0%}",
                lambda cb: supervise(
                    appliance,
                    f"{appliance.name}: heat",
                    lambda: appliance.heat(duration, power=power, progress=cb),
                ),
                step="heat",
            )
        except DeviceError as exc:
            raise failure("heat", exc) from exc

    async def post_sense(self, ctx: SkillContext) -> None:
        state = await _appliance(ctx).state()
        if state.heating or state.remaining > 1e-3:
            raise SkillFailure(f"heat: the heater stopped with {state.remaining:.1f} s left")

    async def on_preempt(self, ctx: SkillContext) -> None:
        await halt(_appliance(ctx))
