"""The microwave agent's ``operate`` / ``operate_stop`` skills (press start / stop) with a fake
appliance whose buttons behave like the simulated controller's: their pre-conditions against
the world model and the appliance's own report, the prediction committed, honest failures, a
bad ``button`` value, a stop of the run, and the planner's use of them on the meal scene."""

from __future__ import annotations

from collections.abc import AsyncIterator
from pathlib import Path
from typing import Literal

import anyio
import pytest

from device_drivers import CommandError, DeviceBusyError
from scenario import load_scenario
from skill_agent import ParameterTypeError, PreconditionError
from skill_agent.protocol import Progress, RunEvent, StartRun
from skill_agent.runtime import SimulatedOutcomes, SkillRegistry, load_config
from skill_agent.skills import HEATED, Heat, Operate, OperateStop
from tests.unit.skill_agent.scenario_planning import plan_scenario
from tests.unit.skill_agent.test_skills_fakes import FakeAppliance, Rig, ToyWorld, rig, run
from wm_store import InMemoryTransport, WmClient
from wm_store.ontology import Ontology, Prop, Rel
from wm_store.protocol import SetRelation, UnsetRelation
from wm_store.server import WmService, WmStore

pytestmark = pytest.mark.anyio

ROOT = Path(__file__).resolve().parents[3]


class ButtonAppliance(FakeAppliance):
    """Buttons as ``mujoco_sim.control`` handles them: ``start`` heats (refused
    with the door open or while heating), ``stop`` stops the heater, ``open`` opens the door.
    ``dud``: start is accepted but the heater does not come on. With ``hold`` set, a press
    takes effect and then waits for it (a slow answer, to stop the run meanwhile)."""

    def __init__(self, name: str, world: ToyWorld) -> None:
        super().__init__(name, world)
        self.dud = False

    async def press(self, button: Literal["start", "stop", "open"]) -> None:
        await super().press(button)
        if button == "start":
            if self.door_open:
                raise CommandError(f"{self.name}: the door is open; close it before heating")
            if self.heating:
                raise DeviceBusyError(f"{self.name} is already heating; stop it first")
            self.heating = not self.dud
        elif button == "stop":
            self.heating = False
        else:
            self.door_open = True
        if self.hold is not None:
            self.started.set()
            await self.hold.wait()

    async def stop(self) -> None:
        await super().stop()
        self.heating = False


@pytest.fixture
async def meal() -> AsyncIterator[Rig]:
    async with rig("meal") as r:
        yield r


def microwave(meal: Rig) -> ButtonAppliance:
    device = ButtonAppliance("Microwave-1", meal.world)
    meal.devices = {"Microwave-1": device}
    return device


def wm_property(meal: Rig, prop: str) -> object:
    return meal.wm.get_element(meal["Microwave-1"]).properties.get(prop)


async def test_operate_starts_heating_and_the_world_model_follows(meal: Rig) -> None:
    oven = microwave(meal)
    events: list[RunEvent] = []
    async with meal.agent("Microwave-1", Operate) as core:
        core.subscribe(events.append)
        result = await run(core, "operate")
    assert result.success, result.message
    assert result.params == {"appliance": meal["Microwave-1"], "button": "start"}
    assert oven.calls == ["press start"] and oven.heating
    assert wm_property(meal, Prop.heating) is True
    pressed = [e for e in events if isinstance(e, Progress) and e.step == "press"]
    assert [e.fraction for e in pressed] == [0.0, 1.0]
    assert "pressing start on Microwave-1" in pressed[0].message


async def test_start_with_the_door_open_is_refused_before_anything_is_pressed(meal: Rig) -> None:
    oven = microwave(meal)
    oven.door_open = True
    await meal.wm.update_element(meal["Microwave-1"], {Prop.doorOpen: True})
    async with meal.agent("Microwave-1", Operate) as core:
        with pytest.raises(PreconditionError, match="doorOpen"):
            await core.start(StartRun(skill="operate"))
    assert oven.calls == [] and not oven.heating
    assert wm_property(meal, Prop.heating) is False


async def test_the_appliance_report_corrects_a_stale_world_model_before_the_check(
    meal: Rig,
) -> None:
    oven = microwave(meal)
    oven.door_open = True  # opened by hand: the world model still says closed
    async with meal.agent("Microwave-1", Operate) as core:
        with pytest.raises(PreconditionError, match="doorOpen"):
            await core.start(StartRun(skill="operate"))
        assert oven.calls == [] and wm_property(meal, Prop.doorOpen) is True
        oven.door_open = False
        started = await run(core, "operate")
        assert started.success, started.message
        oven.heating = False  # the default heating time ran out; the world model says heating
        assert wm_property(meal, Prop.heating) is True
        again = await run(core, "operate")
    assert again.success, again.message
    assert oven.calls == ["press start", "press start"] and oven.heating
    assert wm_property(meal, Prop.doorOpen) is False


async def test_a_bad_button_is_a_clear_error_and_nothing_is_pressed(meal: Rig) -> None:
    oven = microwave(meal)
    async with meal.agent("Microwave-1", Operate, OperateStop) as core:
        boil = await run(core, "operate", button="boil")
        wrong = await run(core, "operate", button="stop")
        with pytest.raises(ParameterTypeError, match="'button' takes a str value"):
            await core.start(StartRun(skill="operate", params={"button": 3}))
        reverse = await run(core, "operate_stop", button="start")
    assert not boil.success and boil.reason == "execution"
    assert "parameter 'button' is 'boil'" in boil.message
    assert "'start' (operate), 'stop' (operate_stop)" in boil.message
    assert not wrong.success and "with the skill 'operate_stop'" in wrong.message
    assert not reverse.success and "with the skill 'operate'" in reverse.message
    assert oven.calls == [] and not oven.heating
    assert wm_property(meal, Prop.heating) is False


async def test_stop_after_start_ends_heating(meal: Rig) -> None:
    oven = microwave(meal)
    box = meal["MealBox-1"]
    await meal.wm.transact(
        [
            UnsetRelation(subject=meal["Worktop-1"], predicate=Rel.contain, object=box),
            SetRelation(subject=meal["Microwave-1"], predicate=Rel.contain, object=box),
        ]
    )
    oven.contents = ["MealBox-1"]
    async with meal.agent("Microwave-1", Operate, OperateStop, Heat) as core:
        started = await run(core, "operate")
        assert started.success and wm_property(meal, Prop.heating) is True
        with pytest.raises(PreconditionError, match="heating"):  # heat needs the heater off
            await core.start(StartRun(skill="heat", params={"object": box}))
        stopped = await run(core, "operate_stop")
    assert stopped.success, stopped.message
    assert stopped.params["button"] == "stop"
    assert oven.calls == ["press start", "press stop"] and not oven.heating
    assert wm_property(meal, Prop.heating) is False


async def test_a_heater_that_does_not_come_on_fails_honestly(meal: Rig) -> None:
    oven = microwave(meal)
    oven.dud = True
    async with meal.agent("Microwave-1", Operate) as core:
        result = await run(core, "operate")
    assert not result.success and result.reason == "execution"
    assert "pressed start, but the appliance is not heating" in result.message
    assert wm_property(meal, Prop.heating) is False, "no prediction committed"


async def test_a_heater_already_on_is_seen_and_refuses_the_start(meal: Rig) -> None:
    oven = microwave(meal)
    oven.heating = True  # started on the appliance itself: the world model says off
    async with meal.agent("Microwave-1", Operate) as core:
        with pytest.raises(PreconditionError, match="heating"):
            await core.start(StartRun(skill="operate"))
    assert wm_property(meal, Prop.heating) is True and oven.calls == []


class DoorOpensFirst(ButtonAppliance):
    """Someone opens the door between the pre-condition check and the press."""

    async def press(self, button: Literal["start", "stop", "open"]) -> None:
        self.door_open = True
        await super().press(button)


async def test_a_press_the_appliance_refuses_fails_with_its_message(meal: Rig) -> None:
    oven = DoorOpensFirst("Microwave-1", meal.world)
    meal.devices = {"Microwave-1": oven}
    async with meal.agent("Microwave-1", Operate) as core:
        result = await run(core, "operate")
    assert not result.success and result.reason == "execution"
    assert "CommandError" in result.message and "the door is open" in result.message
    assert not oven.heating and wm_property(meal, Prop.heating) is False


async def test_stopping_operate_halts_the_appliance(meal: Rig) -> None:
    oven = microwave(meal)
    oven.hold = anyio.Event()
    async with meal.agent("Microwave-1", Operate) as core:
        started = await core.start(StartRun(skill="operate"))
        with anyio.fail_after(5):
            await oven.started.wait()
        assert (await oven.state()).heating
        result = await core.stop(started.run_id)
    assert result.reason == "preempted" and oven.stops >= 1
    assert not (await oven.state()).heating
    assert wm_property(meal, Prop.heating) is False, "no prediction committed"


async def test_simulated_outcomes_commit_the_prediction_without_pressing(meal: Rig) -> None:
    oven = microwave(meal)
    async with meal.agent(
        "Microwave-1", Operate, OperateStop, simulated=SimulatedOutcomes(seed=1)
    ) as core:
        started = await run(core, "operate")
        assert started.success and wm_property(meal, Prop.heating) is True
        stopped = await run(core, "operate_stop")
    assert stopped.success and wm_property(meal, Prop.heating) is False
    assert oven.calls == []


def test_the_microwave_agent_config_offers_both_buttons() -> None:
    config = load_config(ROOT / "configs" / "agents" / "meal" / "microwave.toml")
    entries = SkillRegistry.from_config(config, Ontology.default()).load()
    assert {"operate", "operate_stop", "heat"} <= set(entries)
    assert entries["operate"].description.family == entries["operate_stop"].description.family


# --------------------------------------------------------------------------- the planner


@pytest.fixture
async def wm() -> AsyncIterator[WmClient]:
    ontology = Ontology.default()
    store = await WmStore.open(ontology)
    async with anyio.create_task_group() as tg:
        await tg.start(store.run)
        async with WmClient.connect(InMemoryTransport(WmService(store)), ontology) as client:
            yield client
        tg.cancel_scope.cancel()


async def test_the_planner_starts_the_heater_with_operate(wm: WmClient) -> None:
    plan = await plan_scenario(
        wm, "meal", ["meal/friend", "meal/microwave"], "heating(Microwave-1)"
    )
    assert [s.skill for s in plan.steps] == ["operate"]


async def test_the_meal_is_warmed_with_heat_not_operate(wm: WmClient) -> None:
    scenario = load_scenario(ROOT / "configs" / "scenarios" / "meal" / "scenario.toml")
    goal = " and ".join(g for g in scenario.goals if HEATED or "heated" not in g)
    plan = await plan_scenario(wm, "meal", ["meal/friend", "meal/microwave"], goal)
    skills = [s.skill for s in plan.steps]
    assert "operate" not in skills and "operate_stop" not in skills
    if HEATED:
        assert "heat" in skills
