"""Fixtures for the world-model unit tests: the core ontology and small scenes."""

from __future__ import annotations

import pytest

from wm_store.ontology import Ontology
from wm_store.protocol import AddElement, Pose, Position, Relation, SizeCuboid
from wm_store.scene import SceneState, apply_transaction


@pytest.fixture(scope="session")
def ontology() -> Ontology:
    return Ontology.default()


def spatial_state(ontology: Ontology) -> SceneState:
    state = SceneState()
    state.set_spatial_predicates(n for n, r in ontology.relations.items() if r.spatial)
    return state


@pytest.fixture
def state(ontology: Ontology) -> SceneState:
    return spatial_state(ontology)


KITTING_OPS = [
    AddElement(type="Station", label="station-a", ref="$station"),
    AddElement(
        type="Shelf",
        label="shelf-a",
        ref="$shelf",
        relations=[Relation("$station", "contain", "$")],
    ),
    AddElement(
        type="Box",
        label="box-gears",
        ref="$box",
        properties={"size": SizeCuboid(0.3, 0.2, 0.1)},
        relations=[Relation("$shelf", "contain", "$")],
    ),
    AddElement(
        type="Gear",
        label="gear",
        ref="$gear1",
        properties={"pose": Pose(Position(0.1, 0.0, 0.05)), "mass": 0.2},
        relations=[Relation("$box", "contain", "$")],
    ),
    AddElement(
        type="Gear",
        label="spare gear",
        ref="$gear2",
        properties={"pose": Pose(Position(-0.1, 0.0, 0.05)), "mass": 0.25},
        relations=[Relation("$box", "contain", "$")],
    ),
    AddElement(type="MobileManipulator", label="r1", ref="$robot"),
    AddElement(
        type="Gripper",
        label="r1-gripper",
        ref="$gripper",
        relations=[Relation("$robot", "hasA", "$")],
    ),
    AddElement(
        type="KitBox", label="kit-1", ref="$kit", relations=[Relation("$robot", "contain", "$")]
    ),
]


@pytest.fixture
def kitting(state: SceneState, ontology: Ontology) -> tuple[SceneState, dict[str, str]]:
    """A station with a shelf, a box of two gears, and a robot with a gripper and a kit box."""
    result = apply_transaction(state, ontology, KITTING_OPS, revision=1, now=100.0)
    state.revision = 1
    return state, result.ids
