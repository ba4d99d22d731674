"""resolve() and relation patterns over the native indexes."""

from __future__ import annotations

import pytest

from wm_store import UnknownClassError
from wm_store.ontology import Ontology
from wm_store.protocol import Element, Pose, Position, PropertyFilter, Query, Relation
from wm_store.scene import SceneState, id_sort_key, match_relations, resolve

Kitting = tuple[SceneState, dict[str, str]]


def ids(elements: list[Element]) -> list[str]:
    return [e.id for e in elements]


def test_type_includes_subclasses(kitting: Kitting, ontology: Ontology) -> None:
    state, _ = kitting
    assert ids(resolve(state, ontology, Query(type="Part"))) == ["Gear-1", "Gear-2"]
    assert ids(resolve(state, ontology, Query(type="Container"))) == ["Box-1", "KitBox-1"]
    assert ids(resolve(state, ontology, Query(type="Box", exact_type=True))) == ["Box-1"]


def test_label_filters_and_limit(kitting: Kitting, ontology: Ontology) -> None:
    state, _ = kitting
    heavy = Query(type="Gear", filters=[PropertyFilter(property="mass", op="gt", value=0.22)])
    assert ids(resolve(state, ontology, heavy)) == ["Gear-2"]
    assert ids(resolve(state, ontology, Query(label="kit-1"))) == ["KitBox-1"]
    assert len(resolve(state, ontology, Query(type="Part"), limit=1)) == 1
    near = Query(
        filters=[
            PropertyFilter(
                property="pose", op="near", value=Pose(Position(0.1, 0.01, 0.05)), tolerance=0.02
            )
        ]
    )
    assert ids(resolve(state, ontology, near)) == ["Gear-1"]
    exists = Query(filters=[PropertyFilter(property="size", op="exists")])
    assert ids(resolve(state, ontology, exists)) == ["Box-1"]


def test_related_patterns(kitting: Kitting, ontology: Ontology) -> None:
    state, _ = kitting
    in_box = Query(type="Part", related=[Relation("Box-1", "contain", "?")])
    assert ids(resolve(state, ontology, in_box)) == ["Gear-1", "Gear-2"]
    # spatialRelation is the super-property of contain and hasA
    holders = Query(related=[Relation("?", "spatialRelation", "Gear-1")])
    assert ids(resolve(state, ontology, holders)) == ["Box-1"]


def test_unknown_type_fails_instead_of_matching_nothing(
    kitting: Kitting, ontology: Ontology
) -> None:
    state, _ = kitting
    with pytest.raises(UnknownClassError):
        resolve(state, ontology, Query(type="Gaer"))


def test_match_relations_wildcards(kitting: Kitting, ontology: Ontology) -> None:
    state, _ = kitting
    assert match_relations(state, ontology, "Box-1", "contain") == [
        Relation("Box-1", "contain", "Gear-1"),
        Relation("Box-1", "contain", "Gear-2"),
    ]
    assert match_relations(state, ontology, "*", "hasA", "*") == [
        Relation("MobileManipulator-1", "hasA", "Gripper-1")
    ]
    assert len(match_relations(state, ontology)) == state.relation_count
    assert (
        match_relations(
            state, ontology, "", "spatialRelation", "Gripper-1", include_subproperties=False
        )
        == []
    )


def test_natural_id_order() -> None:
    assert sorted(["Part-10", "Part-2", "Box-1"], key=id_sort_key) == ["Box-1", "Part-2", "Part-10"]
