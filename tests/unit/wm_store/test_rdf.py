"""Scene <-> RDF: the graph mapping, Turtle export, Protégé-style import, round trips, errors."""

from __future__ import annotations

import warnings
from pathlib import Path
from typing import cast

import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st
from rdflib import Graph, Literal, URIRef
from rdflib.compare import isomorphic
from rdflib.namespace import OWL, RDF, RDFS, XSD

from wm_store import (
    OntologyError,
    PropertyValueError,
    UnknownClassError,
    UnknownPropertyError,
    UnknownRelationError,
    ValidationError,
    WmError,
)
from wm_store.ontology import Ontology
from wm_store.protocol import (
    AddElement,
    Color,
    Observe,
    Op,
    Orientation,
    Pose,
    Position,
    Relation,
    SizeCuboid,
    SizeCylinder,
    SizeSphere,
    Value,
)
from wm_store.rdf import SCENE, export_turtle, import_turtle, scene_graph
from wm_store.scene import SceneState, apply_transaction

ROOT = Path(__file__).resolve().parents[3]
SKM = "https://skimesh.dev/ontology#"
Kitting = tuple[SceneState, dict[str, str]]

PREFIXES = """\
@prefix : <http://example.org/s#> .
@prefix skm: <https://skimesh.dev/ontology#> .
@prefix skms: <https://skimesh.dev/scene#> .
@prefix owl: <http://www.w3.org/2002/07/owl#> .
@prefix rdfs: <http://www.w3.org/2000/01/rdf-schema#> .
@prefix xsd: <http://www.w3.org/2001/XMLSchema#> .
"""


def fresh(ontology: Ontology) -> SceneState:
    state = SceneState()
    state.set_spatial_predicates(n for n, r in ontology.relations.items() if r.spatial)
    return state


def load(ontology: Ontology, text: str, state: SceneState | None = None) -> SceneState:
    state = state if state is not None else fresh(ontology)
    ops = import_turtle(text, ontology, state=state)
    apply_transaction(state, ontology, ops, revision=state.revision + 1, now=50.0)
    state.revision += 1
    return state


def turtle_graph(text: str) -> Graph:
    return Graph().parse(data=text, format="turtle")


# --------------------------------------------------------------------------- graph mapping


def test_scene_graph_maps_elements_properties_and_relations(
    kitting: Kitting, ontology: Ontology
) -> None:
    state, _ = kitting
    g = scene_graph(state, ontology)
    gear, box = SCENE["Gear-1"], SCENE["Box-1"]
    assert (gear, RDF.type, URIRef(SKM + "Gear")) in g
    assert (gear, RDF.type, OWL.NamedIndividual) in g
    assert (gear, RDFS.label, Literal("gear")) in g
    assert (box, URIRef(SKM + "contain"), gear) in g
    pose = g.value(gear, URIRef(SKM + "pose"))
    assert isinstance(pose, Literal) and pose.datatype == URIRef(SKM + "Pose")
    assert str(pose) == "0.1 0.0 0.05 0.0 0.0 0.0 1.0"
    assert g.value(gear, URIRef(SKM + "mass")) == Literal("0.2", datatype=XSD.double)
    assert g.value(gear, URIRef(SKM + "rev")) == Literal(1)
    stamp = g.value(gear, URIRef(SKM + "updatedAt"))
    assert isinstance(stamp, Literal) and stamp.datatype == XSD.dateTime
    bare = scene_graph(state, ontology, metadata=False)
    assert bare.value(gear, URIRef(SKM + "rev")) is None
    assert len(bare) == len(g) - 2 * len(state.elements)


def test_observations_become_nodes_with_metadata(kitting: Kitting, ontology: Ontology) -> None:
    state, _ = kitting
    seen: list[Op] = [
        Observe(id="Gear-1", property="mass", value=0.21, source="scale", confidence=0.8)
    ]
    apply_transaction(state, ontology, seen, revision=2, now=200.0)
    g = scene_graph(state, ontology)
    obs = g.value(SCENE["Gear-1"], URIRef(SKM + "observation"))
    assert obs is not None
    assert g.value(obs, URIRef(SKM + "ofProperty")) == URIRef(SKM + "mass")
    assert g.value(obs, URIRef(SKM + "source")) == Literal("scale")
    assert g.value(obs, URIRef(SKM + "value")) == Literal("0.21", datatype=XSD.double)
    assert g.value(obs, URIRef(SKM + "confidence")) == Literal(0.8)
    assert URIRef(SKM + "observation") not in set(
        scene_graph(state, ontology, metadata=False).predicates()
    )


# --------------------------------------------------------------------------- export


def test_export_is_deterministic_protege_ready_and_exact(
    kitting: Kitting, ontology: Ontology
) -> None:
    state, _ = kitting
    apply_transaction(
        state,
        ontology,
        [AddElement(type="Bolt", label='odd "label"\n', properties={"mass": 0.123456789012})],
        revision=2,
        now=3.0,
    )
    text = export_turtle(state, ontology)
    assert text == export_turtle(state, ontology)
    assert text.startswith("@prefix")
    assert "owl:imports <https://skimesh.dev/ontology>" in text
    assert '"0.123456789012"^^xsd:double' in text  # rdflib alone writes 1.234568e-01
    assert "skm:rev" not in text and "skm:updatedAt" not in text
    g = turtle_graph(text)
    assert (SCENE["Bolt-1"], RDFS.label, Literal('odd "label"\n')) in g
    assert "skm:rev" in export_turtle(state, ontology, metadata=True)


def test_export_then_import_restores_the_same_scene(kitting: Kitting, ontology: Ontology) -> None:
    state, _ = kitting
    text = export_turtle(state, ontology)
    again = load(ontology, text)
    assert sorted(again.elements) == sorted(state.elements)
    for element_id, element in state.elements.items():
        copy = again.elements[element_id]
        assert (copy.type, copy.label, copy.properties) == (
            element.type,
            element.label,
            element.properties,
        )
    assert set(again.all_relations()) == set(state.all_relations())
    assert isomorphic(turtle_graph(export_turtle(again, ontology)), turtle_graph(text))


# --------------------------------------------------------------------------- round trip property

TYPES = ["Station", "Table", "Box", "KitBox", "Gear", "Shaft", "Camera", "MobileManipulator", "Arm"]
finite = st.floats(min_value=-1e6, max_value=1e6, allow_nan=False, allow_infinity=False)
length = st.floats(min_value=0.0, max_value=100.0, allow_nan=False)
unit = st.floats(min_value=0.0, max_value=1.0, allow_nan=False)
texts = st.text(max_size=12)
sizes = st.one_of(
    st.builds(SizeCuboid, length, length, length),
    st.builds(SizeCylinder, length, length),
    st.builds(SizeSphere, length),
)


@st.composite
def scenes(draw: st.DrawFn, ontology: Ontology) -> list[Op]:
    """A few elements of random types, typed properties, poses in earlier elements' frames,
    a random spatial tree and some `near` relations, as one transaction."""
    ops: list[Op] = []
    ids: list[str] = []
    types: list[str] = []
    counters: dict[str, int] = {}
    for index in range(draw(st.integers(1, 6))):
        element_type = draw(st.sampled_from(TYPES))
        counters[element_type] = counters.get(element_type, 0) + 1
        frame = draw(st.sampled_from(["", *ids]))
        candidates: dict[str, Value] = {
            "pose": Pose(
                Position(draw(finite), draw(finite), draw(finite)),
                Orientation(draw(unit), draw(unit), draw(unit), 1.0),
                frame,
            ),
            "size": draw(sizes),
            "color": Color(draw(unit), draw(unit), draw(unit), draw(unit)),
            "mass": draw(length),
            "capacity": draw(st.integers(0, 10**9)),
            "description": draw(texts),
            "available": draw(st.booleans()),
            "jointPositions": cast(Value, draw(st.lists(finite, max_size=4))),
        }
        chosen = draw(st.sets(st.sampled_from(sorted(candidates))))
        properties: dict[str, Value] = {}
        for name in sorted(chosen):
            try:
                ontology.check_property(element_type, name, candidates[name])
            except WmError:
                continue
            properties[name] = candidates[name]
        relations: list[Relation] = []
        if draw(st.booleans()) and ids:
            parent = draw(st.integers(0, len(ids) - 1))
            predicate = draw(st.sampled_from(["contain", "hasA"]))
            try:
                ontology.check_relation(types[parent], predicate, element_type)
                relations.append(Relation(ids[parent], predicate, "$"))
            except WmError:
                pass
        if draw(st.booleans()) and ids:
            other = draw(st.integers(0, len(ids) - 1))
            relations.append(Relation("$", "near", ids[other]))
        label = draw(texts)  # labels are unique: numbered apart when given
        ops.append(
            AddElement(
                type=element_type,
                label=f"e{index} {label}" if label else "",
                properties=properties,
                relations=relations,
                ref=f"e{index}",
            )
        )
        ids.append(f"{element_type}-{counters[element_type]}")
        types.append(element_type)
    return ops


@given(data=st.data())
@settings(max_examples=60, deadline=None, suppress_health_check=[HealthCheck.too_slow])
def test_round_trip_of_random_scenes(data: st.DataObject, ontology: Ontology) -> None:
    state = fresh(ontology)
    apply_transaction(state, ontology, data.draw(scenes(ontology)), revision=1, now=10.0)
    text = export_turtle(state, ontology)
    again = load(ontology, text)
    assert sorted(again.elements) == sorted(state.elements)
    for element_id, element in state.elements.items():
        assert again.elements[element_id].properties == element.properties
        assert again.elements[element_id].label == element.label
    assert isomorphic(turtle_graph(export_turtle(again, ontology)), turtle_graph(text))


# --------------------------------------------------------------------------- Protégé import


def test_protege_scene_imports_cleanly(ontology: Ontology) -> None:
    text = (ROOT / "tests/assets/scene_protege.ttl").read_text()
    ops = import_turtle(text, ontology)
    refs = [op.ref for op in ops if isinstance(op, AddElement)]
    assert len(refs) == len(ops) == 10
    assert (
        refs.index("kitchen") < refs.index("worktop") < refs.index("meal_box") < refs.index("meal")
    )
    assert ops == import_turtle(text, ontology)  # deterministic
    state = load(ontology, text)
    by_label = {e.label: e for e in state.elements.values()}
    box = by_label["meal box"]
    assert box.type == "MealBox" and box.properties["capacity"] == 1
    assert box.properties["color"] == Color(0.95, 0.95, 0.9)
    assert by_label["smart microwave"].properties["doorOpen"] is False
    assert by_label["FRIEND"].properties["available"] is True
    assert "friend_gripper" in by_label  # no rdfs:label: the local name
    # frames named by local name now name the element ids
    worktop = by_label["kitchen worktop"]
    pose = box.properties["pose"]
    assert isinstance(pose, Pose) and pose.frame == worktop.id
    assert state.parent(box.id) == Relation(worktop.id, "contain", box.id)
    assert state.parent(by_label["pasta"].id) == Relation(box.id, "contain", by_label["pasta"].id)
    arm = by_label["light-weight arm"]
    assert state.objects(arm.id, "hasA") == {by_label["friend_gripper"].id}
    assert state.objects(by_label["FRIEND"].id, "at") == {by_label["kitchen"].id}


def test_import_numbers_frames_after_the_target_store(ontology: Ontology) -> None:
    state = load(ontology, (ROOT / "tests/assets/scene_protege.ttl").read_text())
    text = (ROOT / "tests/assets/scene_protege.ttl").read_text()
    copy = text.replace('rdfs:label "', 'rdfs:label "2nd ').replace("_gripper", "_gripper_2")
    again = load(ontology, copy, state)  # labels are unique: the second copy's differ
    assert len(again.elements) == 20
    assert {"Worktop-1", "Worktop-2", "MealBox-2"} <= set(again.elements)


def test_keep_ids_false_lets_the_store_number(kitting: Kitting, ontology: Ontology) -> None:
    state, _ = kitting
    text = export_turtle(state, ontology).replace('rdfs:label "', 'rdfs:label "2nd ')
    ops = import_turtle(text, ontology, keep_ids=False)  # a second copy, labelled apart
    assert all(op.id == "" for op in ops if isinstance(op, AddElement))  # no poses with frames
    apply_transaction(state, ontology, ops, revision=2, now=1.0)
    assert {"Gear-3", "Gear-4", "KitBox-2"} <= set(state.elements)


def test_relations_may_point_at_existing_elements(kitting: Kitting, ontology: Ontology) -> None:
    state, _ = kitting
    text = PREFIXES + ':bolt a skm:Bolt ; skm:pose "0 0 0.1 0 0 0 1 @Box-1"^^skm:Pose .\n'
    text += "skms:Box-1 skm:contain :bolt .\n"
    with pytest.raises(OntologyError, match="skms:Box-1"):
        import_turtle(text, ontology)  # Box-1 is described (by a triple) but has no class
    text = (
        PREFIXES
        + ':bolt a skm:Bolt ; skm:near skms:Gear-1 ; skm:pose "0 0 0 0 0 0 1 @Box-1"^^skm:Pose .\n'
    )
    load(ontology, text, state)
    assert state.has_relation(Relation("Bolt-1", "near", "Gear-1"))
    bolt = state.elements["Bolt-1"].properties["pose"]
    assert isinstance(bolt, Pose) and bolt.frame == "Box-1"


def test_metadata_in_a_file_is_ignored(kitting: Kitting, ontology: Ontology) -> None:
    state, _ = kitting
    apply_transaction(
        state, ontology, [Observe(id="Gear-1", property="mass", value=0.3, source="s")], revision=2
    )
    again = load(ontology, export_turtle(state, ontology, metadata=True))
    assert again.elements["Gear-1"].properties["mass"] == 0.3
    assert again.elements["Gear-1"].observations == {}


# --------------------------------------------------------------------------- import errors


@pytest.mark.parametrize(
    ("body", "error", "match"),
    [
        (":g a skm:Gera .", UnknownClassError, r":g.*did you mean 'Gear'"),
        (":g a skm:Gear ; skm:mas 0.1 .", UnknownPropertyError, r"did you mean 'mass'"),
        (":b a skm:Box ; skm:contains :g . :g a skm:Gear .", UnknownRelationError, "'contain'"),
        (":g skm:mass 0.1 .", OntologyError, r":g: needs exactly one .*found: none"),
        (":g a skm:Gear, skm:Box .", OntologyError, "found: Box, Gear"),
        (":g a skm:Gear, skm:Part .", None, ""),
        (":g a <http://example.org/Gear> .", UnknownClassError, r"not a skimesh class.*#Gear"),
        (":g a skm:Gear ; <http://example.org/contain> :g .", UnknownRelationError, "skimesh"),
        (
            ":Widget a owl:Class ; rdfs:subClassOf :Nothing . :w a :Widget .",
            OntologyError,
            "imported file do not fit the ontology.*not a declared owl:Class",
        ),
        (":g a skm:Gear ; skm:mass 0.1, 0.2 .", ValidationError, "two values"),
        (':g a skm:Gear ; skm:contain "x" .', ValidationError, "takes an individual"),
        (":g a skm:Gear ; skm:mass :g .", ValidationError, "give a literal"),
        (':g a skm:Gear ; skm:pose "1 2"^^skm:Pose .', PropertyValueError, "7 numbers"),
        (':g a skm:Gear ; skm:mass "heavy"^^xsd:double .', PropertyValueError, "heavy"),
        (':g a skm:Gear ; skm:available "maybe"^^xsd:boolean .', PropertyValueError, "boolean"),
        (":g a skm:Gear ; skm:contain [ a skm:Bolt ] .", ValidationError, "blank node"),
        (":g a skm:Gear ; skm:pose .", ValidationError, r"not valid Turtle: line \d+"),
    ],
)
def test_import_errors_name_the_problem(
    ontology: Ontology, body: str, error: type[Exception] | None, match: str
) -> None:
    text = PREFIXES + body + "\n"
    with warnings.catch_warnings():
        warnings.simplefilter("error")  # nothing may leak out as a warning
        if error is None:
            (op,) = import_turtle(text, ontology)
            assert isinstance(op, AddElement) and op.type == "Gear"
            return
        with pytest.raises(error, match=match):
            import_turtle(text, ontology)


def test_sample_scene_loads_as_documented(ontology: Ontology) -> None:
    state = load(ontology, (ROOT / "configs/scenes/sample.ttl").read_text())
    assert state.objects("PartBox-1", "contain") == {"Gear-1", "Gear-2", "Shaft-1", "Shaft-2"}
    assert state.objects("MobileManipulator-1", "hasA") == {"Arm-1", "MobileBase-1", "Camera-1"}
    assert state.objects("Arm-1", "hasA") == {"Gripper-1"}
    assert state.parent("KitBox-1") == Relation("MobileManipulator-1", "contain", "KitBox-1")
    assert state.parent("PartBox-1") == Relation("Shelf-1", "contain", "PartBox-1")
    assert state.parent("Table-1") == Relation("Station-1", "contain", "Table-1")
    assert all("pose" in e.properties for e in state.elements.values())


def test_explicit_ids_are_applied_in_increasing_order(ontology: Ontology) -> None:
    # parents first would add Station-3 before Station-2, which the store refuses
    text = PREFIXES + (
        "skms:Station-1 a skm:Station ; skm:contain skms:Station-3 .\n"
        "skms:Station-2 a skm:Station .\nskms:Station-3 a skm:Station .\n"
        ":annex a skm:Station .\n"
    )
    state = load(ontology, text)
    assert sorted(state.elements) == ["Station-1", "Station-2", "Station-3", "Station-4"]
    assert state.elements["Station-4"].label == "annex"
