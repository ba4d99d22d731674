"""Press a smart appliance's button (the issue's ``operate(appliance: e.g. start heating)``):
``operate`` presses *start*, ``operate_stop`` presses *stop*; both drive
:meth:`~device_drivers.Appliance.press` of the agent's appliance.

Why two skills: a description is static data (the planner reads it before any run, and the
runtime commits its post-conditions as the prediction), and a condition cannot depend on the
value of a ``str`` parameter. The two buttons need different descriptions: *start* needs the
door closed and the heater off and predicts ``heating(appliance) = true``; *stop* needs nothing
and predicts ``heating = false``. So each button is a thin skill of the family ``operate``
sharing one implementation, and the offline parameter ``button`` documents the button pressed:
each skill accepts the one button its description predicts (``operate``: ``"start"``, the
default; ``operate_stop``: ``"stop"``). Any other value fails the run before anything is pressed
(in ``pre_sense``, the first step of a run), with a message naming the skill to use; a value
that is no string is refused at start by the parameter check. In simulated-outcome mode no
skill code runs, so there the value is not checked.

``operate`` returns as soon as the appliance reports heating: the heater runs for the
appliance's own default time and stops by itself (``heat`` heats for a chosen time and waits
for the end; it also predicts ``heated(object)``, which ``operate`` does not, so a planner
warming a meal picks ``heat``). Because the heater stops on its own, the world model's
``heating = true`` goes stale; both skills first read the appliance (``pre_sense``) and write
its real ``heating`` and ``doorOpen`` to the world model, so the pre-conditions judge the
machine as it is (``operate_stop`` on an idle heater is harmless and sets ``heating = false``).
After pressing, ``post_sense`` reads the appliance again and fails the run honestly when the
heater is not in the state the button should produce. A stop of the run halts the appliance
(door motor and heater), as for ``heat``.
"""

from __future__ import annotations

from typing import ClassVar, Literal

from device_drivers import Appliance, DeviceError
from skill_agent._errors import SkillFailure
from skill_agent._skill import Skill, SkillContext
from skill_agent.primitives._supervise import halt, supervise
from skill_agent.protocol._skills import ParamSpec, PropertyCond, SkillDescription
from skill_agent.skills._appliance import APPLIANCE, NOT_HEATING
from skill_agent.skills._params import door_is
from skill_agent.skills._support import device, element_id, failure, tracked, wm_of
from wm_store.ontology import Prop
from wm_store.protocol import UpdateElement, Value

__all__ = ["BUTTONS", "Operate", "OperateStop"]

Button = Literal["start", "stop"]
BUTTONS: dict[str, str] = {"start": "operate", "stop": "operate_stop"}
"""The buttons these skills press, and the skill that presses each."""

HEATING = PropertyCond(param="appliance", property=Prop.heating, op="eq", value=True)


def _button_param(button: Button, effect: str) -> ParamSpec:
    return ParamSpec(
        name="button",
        type="str",
        kind="offline",
        default=button,
        doc=f"the button pressed; only {button!r} ({effect}); "
        + ", ".join(f"{b!r} is skill {skill}" for b, skill in BUTTONS.items()),
    )


def _appliance(ctx: SkillContext) -> Appliance:
    return device(ctx, "appliance", Appliance)  # type: ignore[type-abstract]  # runtime Protocol


class _Press(Skill):
    """Press :attr:`button` on the appliance, then check that the heater follows."""

    button: ClassVar[Button] = "start"

    def _check_button(self, ctx: SkillContext) -> None:
        name, value = ctx.description.name, ctx.params.get("button")
        if value == self.button:
            return
        if isinstance(value, str) and value in BUTTONS:
            raise SkillFailure(
                f"{name}: parameter 'button' is {value!r}, but {name} presses only "
                f"{self.button!r} (what its description predicts); press {value!r} with the "
                f"skill {BUTTONS[value]!r}"
            )
        known = ", ".join(f"{b!r} ({skill})" for b, skill in BUTTONS.items())
        raise SkillFailure(f"{name}: parameter 'button' is {value!r}; the buttons are {known}")

    async def pre_sense(self, ctx: SkillContext) -> None:
        self._check_button(ctx)
        state = await _appliance(ctx).state()
        wm, appliance = wm_of(ctx), element_id(ctx, "appliance")
        known = wm.get_element(appliance).properties
        seen: dict[str, Value] = {Prop.heating: state.heating, Prop.doorOpen: state.door_open}
        changed = {p: v for p, v in seen.items() if known.get(p) != v}
        if changed:
            await wm.transact([UpdateElement(id=appliance, properties=changed)])
            said = ", ".join(f"{p} = {str(v).lower()}" for p, v in changed.items())
            await ctx.progress(f"the appliance reports {said}", step="sensed")

    async def execute(self, ctx: SkillContext) -> None:
        self._check_button(ctx)
        appliance, button = _appliance(ctx), self.button
        try:
            await tracked(
                ctx,
                f"pressing {button} on {appliance.name}",
                lambda _progress: supervise(
                    appliance, f"{appliance.name}: {button} button", lambda: appliance.press(button)
                ),
                step="press",
            )
        except DeviceError as exc:
            raise failure(ctx.description.name, exc) from exc

    async def post_sense(self, ctx: SkillContext) -> None:
        want = self.button == "start"
        state = await _appliance(ctx).state()
        if state.heating != want:
            doing = "not heating" if want else f"still heating ({state.remaining:.1f} s left)"
            door = "open" if state.door_open else "closed"
            raise SkillFailure(
                f"{ctx.description.name}: pressed {self.button}, but the appliance is {doing} "
                f"(door {door})"
            )

    async def on_preempt(self, ctx: SkillContext) -> None:
        await halt(_appliance(ctx))


class Operate(_Press):
    """Press *start*: the appliance heats for its own default time; returns once it heats."""

    description = SkillDescription(
        name="operate",
        skill_type="operate",
        doc="Press the appliance's start button: it heats for its own default time (door "
        "closed); done once it reports heating. To heat an object for a set time, use `heat`.",
        parameters=[APPLIANCE, _button_param("start", "starts heating")],
        pre=[door_is("appliance", False), NOT_HEATING],
        post=[HEATING],
        duration=0.5,
    )
    button = "start"


class OperateStop(_Press):
    """Press *stop*: the heater stops (harmless when it is off)."""

    description = SkillDescription(
        name="operate_stop",
        skill_type="operate",
        doc="Press the appliance's stop button: the heater stops (nothing happens if it is off).",
        parameters=[APPLIANCE, _button_param("stop", "stops heating")],
        post=[NOT_HEATING],
        duration=0.5,
    )
    button = "stop"
