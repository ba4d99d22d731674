"""Every name names one element: ids and labels never clash, labels are unique within their
kind, the store's ids avoid labels, suggestions never repeat, and one way to show a name."""

from __future__ import annotations

import pytest

from wm_store import DuplicateLabelError, NameConflictError, display_name
from wm_store.ontology import Ontology, did_you_mean
from wm_store.protocol import AddElement, Element, UpdateElement
from wm_store.scene import SceneState, apply_transaction


def apply(
    state: SceneState, ontology: Ontology, *ops: AddElement | UpdateElement
) -> dict[str, str]:
    state.revision += 1
    return apply_transaction(state, ontology, list(ops), revision=state.revision, now=1.0).ids


def test_a_label_that_is_another_elements_id_is_refused_naming_both(
    state: SceneState, ontology: Ontology
) -> None:
    apply(state, ontology, AddElement(type="Gear", label="Pulley-4"))  # Gear-1
    before = dict(state.elements)
    with pytest.raises(NameConflictError) as err:
        apply(state, ontology, AddElement(type="Gear", label="Gear-1"))
    message = str(err.value)
    assert "label 'Gear-1' of the Gear Gear-2" in message
    assert "is the id of Pulley-4 (Gear-1)" in message
    assert state.elements == before, "refused: nothing changed"


def test_two_cameras_one_labelled_with_the_others_id_are_refused(
    state: SceneState, ontology: Ontology
) -> None:
    apply(state, ontology, AddElement(type="Camera", label="r1-camera"))  # Camera-1
    with pytest.raises(NameConflictError, match=r"'Camera-1'.*r1-camera \(Camera-1\)"):
        apply(state, ontology, AddElement(type="Camera", label="Camera-1"))


def test_relabelling_onto_another_id_or_label_is_refused(
    state: SceneState, ontology: Ontology
) -> None:
    ids = apply(
        state,
        ontology,
        AddElement(type="Gear", label="small", ref="a"),
        AddElement(type="Gear", label="big", ref="b"),
    )
    a, b = ids["a"], ids["b"]
    with pytest.raises(NameConflictError, match=rf"label '{a}' of the Gear {b} is the id of small"):
        apply(state, ontology, UpdateElement(id=b, label=a))
    with pytest.raises(DuplicateLabelError, match=rf"'small' of the Gear {b}.*small \({a}\)"):
        apply(state, ontology, UpdateElement(id=b, label="small"))
    apply(state, ontology, UpdateElement(id=b, label=b))  # its own id is fine
    assert state.elements[b].label == b


def test_an_explicit_id_that_is_another_elements_label_is_refused(
    state: SceneState, ontology: Ontology
) -> None:
    apply(state, ontology, AddElement(type="Gear", label="Gear-5 spare"))
    apply(state, ontology, AddElement(type="Bolt", label="Gear-7"))  # id Bolt-1
    with pytest.raises(NameConflictError, match=r"id 'Gear-7' is the label of Gear-7 \(Bolt-1\)"):
        apply(state, ontology, AddElement(type="Gear", id="Gear-7"))


def test_labels_are_unique_among_scene_elements_and_among_agents(
    state: SceneState, ontology: Ontology
) -> None:
    apply(state, ontology, AddElement(type="Gear", label="gear"))
    with pytest.raises(DuplicateLabelError, match=r"'gear'.*already the label of gear \(Gear-1\)"):
        apply(state, ontology, AddElement(type="Bolt", label="gear"))
    # an agent is often named like its robot; skills are named per agent
    apply(
        state,
        ontology,
        AddElement(type="MobileManipulator", label="r1"),
        AddElement(type="RobotAgent", label="r1"),
        AddElement(type="Skill", label="pick"),
        AddElement(type="Skill", label="pick"),
    )
    with pytest.raises(DuplicateLabelError, match="'r1'"):
        apply(state, ontology, AddElement(type="DeviceAgent", label="r1"))
    assert len(state.ids_with_label("pick")) == 2


def test_assigned_ids_skip_labels_and_take_the_own_label_when_fresh(
    state: SceneState, ontology: Ontology
) -> None:
    # one transaction: the robot's camera comes first, the camera labelled Camera-1 after it
    ids = apply(
        state,
        ontology,
        AddElement(type="Camera", label="r1-camera", ref="wrist"),
        AddElement(type="Camera", label="Camera-1", ref="overhead"),
        AddElement(type="Gear", label="Pulley-4", ref="pulley"),
        AddElement(type="Gear", label="Gear-1", ref="gear"),
    )
    assert ids["overhead"] == "Camera-1" and ids["wrist"] == "Camera-2"
    assert ids["gear"] == "Gear-1" and ids["pulley"] == "Gear-2"
    # a label already there is skipped too, and ids stay never reused
    apply(state, ontology, AddElement(type="Bolt", label="Gear-3"))
    assert apply(state, ontology, AddElement(type="Gear", ref="g"))["g"] == "Gear-4"
    with pytest.raises(NameConflictError, match="'Gear-2' of the Gear Gear-5 is the id of"):
        apply(state, ontology, AddElement(type="Gear", label="Gear-2"))


def test_suggestions_never_repeat_a_name() -> None:
    hint = did_you_mean("Pulley-5", ["Pulley-4", "Gear-1", "Pulley-4", "Pulley-4"])
    assert hint == "; did you mean 'Pulley-4'?"
    assert did_you_mean("gear", ["Gear", "Gear"]) == "; did you mean 'Gear'?"


def test_display_name_is_the_label_with_the_id_where_they_differ() -> None:
    assert display_name(Element(id="Gear-1", type="Gear", label="Pulley-4")) == "Pulley-4 (Gear-1)"
    assert display_name(Element(id="Gear-1", type="Gear", label="Gear-1")) == "Gear-1"
    assert display_name(Element(id="Gear-1", type="Gear")) == "Gear-1"
    assert display_name(None, "Gear-9") == "Gear-9"
