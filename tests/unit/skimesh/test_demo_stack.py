"""Setting up ``skimesh demo``: the goal adds closed appliance doors, the agents come from the
scenario file, and a data directory that already holds a world model is refused before anything
starts (the demo loads its scene into an empty store)."""

from __future__ import annotations

from pathlib import Path

import anyio
import pytest

from scenario import load_scenario
from skimesh.commands.demo import mission_goal
from skimesh.demo import StackOptions, agent_configs, demo_stack
from skimesh.errors import DemoError
from wm_store.ontology import Ontology
from wm_store.protocol import AddElement, Transact
from wm_store.server import StoreConfig, WmStore

SCENARIOS = Path(__file__).resolve().parents[3] / "configs" / "scenarios"


def test_the_mission_leaves_appliances_closed() -> None:
    meal = load_scenario(SCENARIOS / "meal" / "scenario.toml")
    assert mission_goal(meal) == (
        "heated(MealBox-1) and contain(Tray-1, MealBox-1) and doorOpen(Microwave-1) = false"
    )
    kitting = load_scenario(SCENARIOS / "kitting" / "scenario.toml")
    assert mission_goal(kitting) == " and ".join(kitting.goals)


def test_the_agents_are_the_scenarios() -> None:
    meal = agent_configs(load_scenario(SCENARIOS / "meal" / "scenario.toml"))
    assert {name: c.robot_label for name, c in meal.items()} == {
        "friend": "friend",
        "microwave": "Microwave-1",
    }
    assert meal["friend"].hardware == {"sensor": "Camera-1", "platform": "Worktop-1"}


@pytest.mark.anyio
async def test_a_used_data_directory_is_refused(tmp_path: Path) -> None:
    store = await WmStore.open(Ontology.default(), StoreConfig(data_dir=str(tmp_path)))
    async with anyio.create_task_group() as tg:
        await tg.start(store.run)  # its log writer: a commit waits for it
        await store.transact(Transact(ops=[AddElement(type="Gear", label="old")]))
        tg.cancel_scope.cancel()
    await store.aclose()
    scenario = load_scenario(SCENARIOS / "kitting" / "scenario.toml")
    options = StackOptions(scenario=scenario, agents=agent_configs(scenario), data_dir=tmp_path)
    said: list[str] = []
    with pytest.raises(DemoError, match=r"already holds a world model \(1 elements\)"):
        async with demo_stack(options, None, say=said.append):
            pass
    assert said == [], "refused before the router started"
