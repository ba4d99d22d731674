"""Transactions: validation against the ontology, tree shape, CAS, ids, all-or-nothing."""

from __future__ import annotations

import msgspec
import pytest

from wm_store import (
    CardinalityError,
    ConflictError,
    DuplicateIdError,
    ElementNotFoundError,
    PropertyValueError,
    RelationDomainError,
    TreeShapeError,
    UnknownClassError,
    UnknownPropertyError,
    UnknownRelationError,
)
from wm_store.ontology import Ontology
from wm_store.protocol import (
    AddElement,
    ClassDef,
    DefineClass,
    ElementPut,
    ElementRemoved,
    Observe,
    Op,
    Position,
    Relation,
    RelationAdded,
    RelationRemoved,
    RemoveElement,
    SetRelation,
    UnsetRelation,
    UpdateElement,
)
from wm_store.scene import SceneState, apply_transaction

Kitting = tuple[SceneState, dict[str, str]]


def commit(state: SceneState, ontology: Ontology, ops: list[Op]) -> dict[str, str]:
    revision = state.revision + 1
    result = apply_transaction(state, ontology, ops, revision=revision, now=200.0 + revision)
    state.revision = revision
    return result.ids


def fingerprint(state: SceneState) -> bytes:
    snap = state.to_snapshot()
    snap.elements.sort(key=lambda e: e.id)
    snap.relations.sort(key=lambda r: (r.subject, r.predicate, r.object))
    return msgspec.msgpack.encode(snap)


def test_ids_are_per_type_and_refs_resolve(kitting: Kitting) -> None:
    state, ids = kitting
    assert ids["$gear1"] == "Gear-1"
    assert ids["$gear2"] == "Gear-2"
    assert ids["$kit"] == "KitBox-1"
    assert state.parent("Gear-1") == Relation("Box-1", "contain", "Gear-1")
    assert state.elements["Gear-1"].rev == 1


def test_ids_are_never_reused(kitting: Kitting, ontology: Ontology) -> None:
    state, _ = kitting
    commit(state, ontology, [RemoveElement(id="Gear-2")])
    ids = commit(state, ontology, [AddElement(type="Gear", ref="$g")])
    assert ids["$g"] == "Gear-3"
    with pytest.raises(DuplicateIdError, match="next free one is Gear-4"):
        commit(state, ontology, [AddElement(type="Gear", id="Gear-2")])


def test_explicit_fresh_id_is_kept(state: SceneState, ontology: Ontology) -> None:
    ids = commit(state, ontology, [AddElement(type="Gear", id="Gear-7", ref="$g")])
    assert ids["$g"] == "Gear-7"
    assert commit(state, ontology, [AddElement(type="Gear", ref="$h")])["$h"] == "Gear-8"
    with pytest.raises(DuplicateIdError):
        commit(state, ontology, [AddElement(type="Gear", id="Shaft-9")])


def test_unknown_names_fail_with_suggestion(state: SceneState, ontology: Ontology) -> None:
    with pytest.raises(UnknownClassError, match="Gear"):
        commit(state, ontology, [AddElement(type="Gaer")])
    with pytest.raises(UnknownPropertyError):
        commit(state, ontology, [AddElement(type="Gear", properties={"mas": 1.0})])
    commit(state, ontology, [AddElement(type="Box", ref="$b"), AddElement(type="Gear", ref="$g")])
    with pytest.raises(UnknownRelationError, match="contain"):
        commit(
            state, ontology, [SetRelation(subject="Box-1", predicate="contian", object="Gear-1")]
        )


def test_property_kind_and_range_checked(state: SceneState, ontology: Ontology) -> None:
    with pytest.raises(PropertyValueError):
        commit(state, ontology, [AddElement(type="Gear", properties={"mass": "heavy"})])
    with pytest.raises(PropertyValueError):
        commit(state, ontology, [AddElement(type="Gear", properties={"mass": -1.0})])
    with pytest.raises(PropertyValueError):
        commit(state, ontology, [AddElement(type="Gear", properties={"pose": Position(0, 0, 0)})])


def test_relation_domain_and_range(kitting: Kitting, ontology: Ontology) -> None:
    state, _ = kitting
    with pytest.raises(RelationDomainError):
        commit(
            state, ontology, [SetRelation(subject="Gear-1", predicate="hasSkill", object="Box-1")]
        )


def test_spatial_tree_one_parent_and_no_cycle(kitting: Kitting, ontology: Ontology) -> None:
    state, _ = kitting
    with pytest.raises(TreeShapeError, match=r"already has the spatial parent box-gears \(Box-1\)"):
        commit(
            state, ontology, [SetRelation(subject="KitBox-1", predicate="contain", object="Gear-1")]
        )
    with pytest.raises(TreeShapeError, match="cycle"):
        commit(
            state, ontology, [SetRelation(subject="Box-1", predicate="contain", object="Station-1")]
        )
    # moving = unset + set in one transaction
    commit(
        state,
        ontology,
        [
            UnsetRelation(subject="Box-1", predicate="contain", object="Gear-1"),
            SetRelation(subject="KitBox-1", predicate="contain", object="Gear-1"),
        ],
    )
    assert state.parent("Gear-1") == Relation("KitBox-1", "contain", "Gear-1")


def test_max_cardinality(kitting: Kitting, ontology: Ontology) -> None:
    state, _ = kitting
    commit(
        state,
        ontology,
        [
            UnsetRelation(subject="Box-1", predicate="contain", object="Gear-1"),
            SetRelation(subject="Gripper-1", predicate="contain", object="Gear-1"),
        ],
    )
    with pytest.raises(CardinalityError, match="at most 1"):
        commit(
            state,
            ontology,
            [
                UnsetRelation(subject="Box-1", predicate="contain", object="Gear-2"),
                SetRelation(subject="Gripper-1", predicate="contain", object="Gear-2"),
            ],
        )


def test_failed_transaction_changes_nothing(kitting: Kitting, ontology: Ontology) -> None:
    state, _ = kitting
    before = fingerprint(state)
    counters = dict(state.counters)
    with pytest.raises(TreeShapeError):
        commit(
            state,
            ontology,
            [
                AddElement(type="Gear", ref="$g", relations=[Relation("Box-1", "contain", "$")]),
                UpdateElement(id="Gear-1", properties={"mass": 0.9}),
                RemoveElement(id="Gear-2"),
                SetRelation(subject="Box-1", predicate="contain", object="Shelf-1"),
            ],
        )
    assert fingerprint(state) == before
    assert state.counters == counters
    assert commit(state, ontology, [AddElement(type="Gear", ref="$g")])["$g"] == "Gear-3"


def test_compare_and_set(kitting: Kitting, ontology: Ontology) -> None:
    state, _ = kitting
    commit(state, ontology, [UpdateElement(id="Gear-1", properties={"mass": 0.3}, expect_rev=1)])
    assert state.elements["Gear-1"].rev == 2
    with pytest.raises(ConflictError, match="rev 2"):
        commit(
            state, ontology, [UpdateElement(id="Gear-1", properties={"mass": 0.4}, expect_rev=1)]
        )
    assert state.elements["Gear-1"].properties["mass"] == 0.3


def test_update_merge_replace_and_delete(kitting: Kitting, ontology: Ontology) -> None:
    state, _ = kitting
    commit(state, ontology, [UpdateElement(id="Gear-1", properties={"mass": None}, label="g1")])
    assert "mass" not in state.elements["Gear-1"].properties
    assert "pose" in state.elements["Gear-1"].properties
    assert state.ids_with_label("g1") == {"Gear-1"}
    commit(state, ontology, [UpdateElement(id="Gear-1", properties={"mass": 0.5}, mode="replace")])
    assert state.elements["Gear-1"].properties == {"mass": 0.5}


def test_remove_branch_removes_subtree_and_relations(kitting: Kitting, ontology: Ontology) -> None:
    state, _ = kitting
    result = apply_transaction(
        state, ontology, [RemoveElement(id="Shelf-1", branch=True)], revision=2
    )
    assert not {"Shelf-1", "Box-1", "Gear-1", "Gear-2"} & state.elements.keys()
    assert "Station-1" in state.elements
    assert state.objects("Station-1", "contain") == set()
    removed = [d.id for d in result.deltas if isinstance(d, ElementRemoved)]
    assert removed[-1] == "Shelf-1"  # children first
    assert any(isinstance(d, RelationRemoved) for d in result.deltas)


def test_remove_missing_element_fails(state: SceneState, ontology: Ontology) -> None:
    with pytest.raises(ElementNotFoundError):
        commit(state, ontology, [RemoveElement(id="Gear-99")])


def test_deltas_replay_to_same_state(kitting: Kitting, ontology: Ontology) -> None:
    state, _ = kitting
    replica = SceneState()
    replica.set_spatial_predicates(state.spatial_predicates)
    for d in state.to_snapshot().elements:
        replica.put_element(d)
    for r in state.all_relations():
        replica.add_relation(r)
    result = apply_transaction(
        state,
        ontology,
        [
            UpdateElement(id="Gear-1", properties={"mass": 0.7}),
            UnsetRelation(subject="Box-1", predicate="contain", object="Gear-2"),
            SetRelation(subject="KitBox-1", predicate="contain", object="Gear-2"),
            AddElement(type="Shaft", ref="$s", relations=[Relation("Box-1", "contain", "$")]),
        ],
        revision=2,
    )
    assert [type(d) for d in result.deltas] == [
        ElementPut,
        RelationRemoved,
        RelationAdded,
        ElementPut,
        RelationAdded,
    ]
    for delta in result.deltas:
        replica.apply(delta)
    replica.revision = state.revision
    assert fingerprint(replica) == fingerprint(state)


def test_undo_restores_previous_state(kitting: Kitting, ontology: Ontology) -> None:
    state, _ = kitting
    before = fingerprint(state)
    result = apply_transaction(
        state, ontology, [RemoveElement(id="Box-1", branch=True)], revision=2
    )
    for record in reversed(result.undo):
        state.undo(record)
    assert fingerprint(state) == before


def test_observations_resolved_by_policy(kitting: Kitting, ontology: Ontology) -> None:
    state, _ = kitting
    policy = ontology.data_property("position").resolution
    commit(
        state,
        ontology,
        [
            Observe(
                id="Gear-1",
                property="position",
                value=Position(1.0, 0, 0),
                source="camera",
                confidence=0.5,
                stamp=1.0,
            ),
            Observe(
                id="Gear-1",
                property="position",
                value=Position(2.0, 0, 0),
                source="platform",
                confidence=1.0,
                stamp=2.0,
            ),
        ],
    )
    element = state.elements["Gear-1"]
    assert [o.source for o in element.observations["position"]] == ["camera", "platform"]
    value = element.properties["position"]
    assert isinstance(value, Position)
    expected = {"latest": 2.0, "most_confident": 2.0, "fused": (0.5 * 1.0 + 1.0 * 2.0) / 1.5}[
        policy
    ]
    assert value.x == pytest.approx(expected)


def test_define_class_at_run_time(state: SceneState, ontology: Ontology) -> None:
    result = apply_transaction(
        state,
        ontology,
        [
            DefineClass(cls=ClassDef(name="Sprocket", parent="Gear")),
            AddElement(type="Sprocket", ref="$s"),
        ],
        revision=1,
    )
    assert result.ids["$s"] == "Sprocket-1"
    assert result.ontology.is_a("Sprocket", "Part")
    assert "Sprocket" not in ontology.classes
    assert [c.name for c in state.classes] == ["Sprocket"]
