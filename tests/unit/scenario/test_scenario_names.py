"""Scenario labels never name two elements: a label of the form of an id is its own element's
id (refused on an element of another class), and a scene whose label is already another
element's id in the world model is refused with the way out."""

from __future__ import annotations

import anyio
import pytest

from scenario import ScenarioError, parse_scenario
from scenario.wm import scenario_ops, scene_ops
from skimesh.paths import read_scenario
from wm_store import DeviceSpec, InMemoryTransport, RobotRegistration, WmClient
from wm_store.ontology import Ontology
from wm_store.scene import SceneState, apply_transaction
from wm_store.server import WmService, WmStore

pytestmark = pytest.mark.anyio

SCENE = """
name = "names"

[[robots]]
name = "r1"

[[furniture]]
type = "Table"
label = "Table-1"
pose = {{ x = 1.0 }}
size = [0.6, 1.0, 0.7]

[[parts]]
type = "Gear"
label = "{first}"
parent = "Table-1"
shape = "cylinder"
size = [0.02, 0.02]

[[parts]]
type = "Gear"
label = "Gear-1"
parent = "Table-1"
pose = {{ y = 0.1 }}
shape = "cylinder"
size = [0.02, 0.02]
"""


def test_a_label_shaped_like_an_id_of_another_class_is_refused() -> None:
    with pytest.raises(ScenarioError) as err:
        parse_scenario(SCENE.format(first="Table-2"), source="names.toml")
    message = str(err.value)
    assert message.startswith("names.toml: $.parts[0].label: label 'Table-2' has the form")
    assert "of an id of a Table, but it labels a Gear" in message


def test_other_labels_never_take_the_id_another_label_names() -> None:
    scenario = parse_scenario(SCENE.format(first="Pulley-4"))  # Pulley: no class of the scene
    ontology = Ontology.default()
    state = SceneState()
    state.set_spatial_predicates(n for n, r in ontology.relations.items() if r.spatial)
    ids = apply_transaction(state, ontology, scenario_ops(scenario), revision=1).ids
    assert ids["$Gear-1"] == "Gear-1", "listed second, the part labelled Gear-1 is Gear-1"
    assert ids["$Pulley-4"] == "Gear-2"


async def test_a_scene_label_that_is_a_registered_elements_id_is_refused() -> None:
    scenario = read_scenario("kitting")
    store = await WmStore.open(Ontology.default())
    async with anyio.create_task_group() as tg:
        await tg.start(store.run)
        async with WmClient.connect(InMemoryTransport(WmService(store)), store.ontology) as wm:
            # an agent started before the scene: its robot's camera gets the id Camera-1
            registration = RobotRegistration(
                agent="r1",
                robot_type="MobileManipulator",
                robot_label="r1",
                devices=[DeviceSpec(type="Camera", label="r1-camera")],
            )
            await wm.register_robot(registration)
            assert wm.resolve_element(label="r1-camera")[0].id == "Camera-1"
            with pytest.raises(ScenarioError) as err:
                scene_ops(scenario, wm.replica.state, wm.ontology)
        tg.cancel_scope.cancel()
    message = str(err.value)
    assert "label 'Camera-1' is already the id of r1-camera (Camera-1)" in message
    assert "load the scene before starting the agents" in message
