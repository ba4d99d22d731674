"""A goal fact is checked in the world model and, where the simulation can tell, in the
physics: a box that the world model believes on the tray but that lies elsewhere fails."""

from __future__ import annotations

from pathlib import Path

import anyio
import pytest

from mujoco_sim import WorldOptions, running_world
from scenario import load_scenario
from scenario.wm import scenario_ops
from skimesh.demo import goal_holds, verify_goal
from task_agent import parse_goal
from wm_store import InMemoryTransport, WmClient
from wm_store.ontology import Ontology
from wm_store.protocol import SetRelation, UnsetRelation, UpdateElement
from wm_store.server import WmService, WmStore

pytestmark = [pytest.mark.sim, pytest.mark.anyio]

MEAL = Path(__file__).resolve().parents[3] / "configs" / "scenarios" / "meal" / "scenario.toml"


async def test_facts_are_checked_in_the_world_model_and_in_the_physics() -> None:
    scenario = load_scenario(MEAL)
    ontology = Ontology.default()
    store = await WmStore.open(ontology)
    async with anyio.create_task_group() as tg:
        await tg.start(store.run)
        async with (
            WmClient.connect(InMemoryTransport(WmService(store)), ontology) as wm,
            running_world(scenario, WorldOptions(fast=True)) as world,
        ):
            reply = await wm.transact(scenario_ops(scenario))
            ids = {ref[1:]: eid for ref, eid in reply.ids.items() if ref.startswith("$")}

            def label_of(element_id: str) -> str:
                return wm.get_element(element_id).label or element_id

            text = (
                "contain(Tray-1, MealBox-1) and doorOpen(Microwave-1) = false and "
                "heated(MealBox-1) and not contain(Worktop-1, Tray-1)"
            )
            before = await verify_goal(parse_goal(text, wm), wm, world, label_of)
            box, tray, worktop = ids["MealBox-1"], ids["Tray-1"], ids["Worktop-1"]
            await wm.transact(  # the world model is told a story the physics does not back
                [
                    UnsetRelation(subject=worktop, predicate="contain", object=box),
                    SetRelation(subject=tray, predicate="contain", object=box),
                    UpdateElement(id=box, properties={"heated": True}),
                ]
            )
            after = await verify_goal(parse_goal(text, wm), wm, world, label_of)
        tg.cancel_scope.cancel()
    facts = [c.fact for c in before]
    assert facts == [
        "contain(Tray-1, MealBox-1)",
        "doorOpen(Microwave-1) = false",
        "heated(MealBox-1) = true",
        "not contain(Worktop-1, Tray-1)",
    ]
    assert [(c.in_wm, c.physics) for c in before] == [
        (False, False),
        (True, True),
        (False, None),  # an unset boolean is false; the simulation has no temperatures
        (False, None),  # the tray stands on the worktop (furniture: no physics object)
    ]
    assert "MealBox-1 does not lie in Tray-1" in before[0].detail
    assert before[1].detail == "door closed (0.00 rad)"
    assert [(c.in_wm, c.physics) for c in after][:3] == [(True, False), (True, True), (True, None)]
    assert not goal_holds(after), "the world model alone is not enough"
