"""The loaded ontology: taxonomy closures, relations, value checks, cardinalities, templates,
the literal codec, run-time extension, and a Protégé-written extension file."""

from __future__ import annotations

import math
import time
from pathlib import Path

import pytest
from hypothesis import given
from hypothesis import strategies as st
from rdflib import XSD, Graph, Literal, URIRef

from wm_store import (
    CardinalityError,
    OntologyError,
    PropertyValueError,
    RelationDomainError,
    UnknownClassError,
    UnknownPropertyError,
    UnknownRelationError,
    UnknownTemplateError,
)
from wm_store.ontology import (
    NAMESPACE,
    ONTOLOGY_IRI,
    ClassInfo,
    DataPropertyInfo,
    Ontology,
    RelationInfo,
    core_ontology_path,
    literal_from_value,
    value_from_literal,
)
from wm_store.protocol import (
    ClassDef,
    Color,
    Frame,
    Orientation,
    Pose,
    Position,
    SizeCuboid,
    SizeCylinder,
    SizeSphere,
    TemplateDef,
    Value,
)

ASSETS = Path(__file__).resolve().parents[2] / "assets"
SKM = NAMESPACE
PREFIXES = """
@prefix skm: <https://skimesh.dev/ontology#> .
@prefix ex: <https://example.org/test#> .
@prefix owl: <http://www.w3.org/2002/07/owl#> .
@prefix rdf: <http://www.w3.org/1999/02/22-rdf-syntax-ns#> .
@prefix rdfs: <http://www.w3.org/2000/01/rdf-schema#> .
@prefix xsd: <http://www.w3.org/2001/XMLSchema#> .
"""


@pytest.fixture(scope="module")
def onto() -> Ontology:
    return Ontology.default()


def with_core(turtle: str) -> Ontology:
    return Ontology.load(core_ontology_path(), PREFIXES + turtle)


# --------------------------------------------------------------------------- loading


def test_default_loads_the_core_file_once(onto: Ontology) -> None:
    assert core_ontology_path().name == "skimesh.ttl"
    assert Ontology.default() is onto
    assert (URIRef(ONTOLOGY_IRI), None, None) in onto.graph
    assert {"PhysicalObject", "Location", "Agent", "Skill", "KitBox", "Microwave"} <= onto.classes


def test_every_core_term_has_a_label_and_a_comment(onto: Ontology) -> None:
    terms: list[ClassInfo | RelationInfo | DataPropertyInfo] = [
        *(onto.class_info(c) for c in onto.classes),
        *onto.relations.values(),
        *onto.data_properties.values(),
    ]
    missing = [t.name for t in terms if not (t.label and t.comment)]
    assert missing == []


def test_load_accepts_turtle_text() -> None:
    text = PREFIXES + 'ex:Widget a owl:Class ; rdfs:label "widget" .'
    onto = Ontology.load(text)
    assert onto.classes == {"Widget"}
    assert onto.class_info("Widget").label == "widget"


@pytest.mark.parametrize(
    ("source", "needle"),
    [
        ("no/such/file.ttl", "does not exist"),
        (PREFIXES + "ex:A a owl:Class ; rdfs:subClassOf", "cannot parse"),
        (PREFIXES + "ex:A a owl:Class ; rdfs:subClassOf ex:Missing .", "ex:Missing"),
        (PREFIXES + "ex:Kit-Box a owl:Class .", "must start with a capital"),
        (
            PREFIXES + "ex:A a owl:Class ; rdfs:subClassOf ex:B . ex:B a owl:Class ; "
            "rdfs:subClassOf ex:A .",
            "cycle",
        ),
        (PREFIXES + "ex:Gear a owl:Class . skm:Gear a owl:Class .", "used twice"),
    ],
)
def test_load_errors_say_what_is_wrong(source: str, needle: str) -> None:
    with pytest.raises(OntologyError, match=needle.replace("ex:", "https://example.org/test#")):
        Ontology.load(source)


def test_load_needs_a_source() -> None:
    with pytest.raises(OntologyError, match="at least one"):
        Ontology.load()


@pytest.mark.parametrize(
    ("turtle", "needle"),
    [
        ('ex:p a owl:DatatypeProperty ; skm:valueKind "Quaternion" .', "unknown skm:valueKind"),
        (
            "ex:p a owl:DatatypeProperty ; rdfs:range [ a rdfs:Datatype ; owl:onDatatype "
            'xsd:double ; owl:withRestrictions ( [ xsd:minExclusive "0"^^xsd:double ] ) ] .',
            "minExclusive is not supported",
        ),
        ('ex:p a owl:DatatypeProperty ; rdfs:range xsd:string ; skm:resolution "fused" .', "fused"),
        ('ex:p a owl:DatatypeProperty ; skm:resolution "newest" .', "newest"),
        ('ex:p a owl:DatatypeProperty ; rdfs:range xsd:string ; skm:valueKind "float" .', "agree"),
        (
            "ex:Bad a owl:NamedIndividual , skm:Gear ; skm:template true ; "
            'skm:mas "1"^^xsd:double .',
            "not a declared data property",
        ),
        (
            "ex:Bad a owl:NamedIndividual , skm:Gear ; skm:template true ; "
            'skm:mass "-1"^^xsd:double .',
            "Bad",
        ),
        (
            "ex:q a owl:ObjectProperty ; rdfs:subPropertyOf skm:contain ; skm:spatial false .",
            "spatial",
        ),
    ],
)
def test_ontology_file_mistakes_are_reported(turtle: str, needle: str) -> None:
    with pytest.raises(OntologyError, match=needle):
        with_core(turtle)


# --------------------------------------------------------------------------- classes


def test_kitbox_is_a_container_and_a_box(onto: Ontology) -> None:
    assert onto.is_a("KitBox", "Box")
    assert onto.is_a("KitBox", "Container")
    assert onto.is_a("KitBox", "PhysicalObject")
    assert onto.is_a("KitBox", "KitBox")
    assert not onto.is_a("KitBox", "Location")
    assert not onto.is_a("Box", "KitBox")


def test_subclasses_are_transitive_and_precomputed(onto: Ontology) -> None:
    assert onto.subclasses("Part") == {"Part", "Gear", "Shaft", "Bracket", "Bolt"}
    assert {"KitBox", "PartBox", "MealBox", "Tray", "Box"} <= onto.subclasses("Container")
    assert {"Gear", "Gripper", "Microwave", "MobileManipulator"} <= onto.subclasses(
        "PhysicalObject"
    )
    assert onto.subclasses("Part") is onto.subclasses("Part")


def test_superclasses_nearest_first(onto: Ontology) -> None:
    assert onto.superclasses("KitBox") == ("KitBox", "Box", "Container", "PhysicalObject")
    assert onto.superclasses("Gripper")[:3] == ("Gripper", "Device", "Machine")


def test_multiple_inheritance(onto: Ontology) -> None:
    assert onto.is_a("Shelf", "Surface")
    assert onto.is_a("Shelf", "Furniture")
    assert onto.is_a("SmartPlatform", "Sensor")
    assert onto.is_a("SmartPlatform", "Location")
    assert "SmartPlatform" in onto.subclasses("Surface") & onto.subclasses("Device")
    assert onto.is_a("Tray", "Container")
    assert not onto.is_a("Tray", "Location")


@pytest.mark.parametrize(
    ("typo", "suggestion"),
    [("Gera", "Gear"), ("kitbox", "KitBox"), ("Micowave", "Microwave"), ("Contaner", "Container")],
)
def test_unknown_class_suggests_the_closest(onto: Ontology, typo: str, suggestion: str) -> None:
    with pytest.raises(UnknownClassError, match=f"did you mean '{suggestion}'"):
        onto.check_class(typo)
    with pytest.raises(UnknownClassError, match=typo):
        onto.is_a(typo, "Part")
    with pytest.raises(UnknownClassError, match=typo):
        onto.is_a("Part", typo)
    with pytest.raises(UnknownClassError):
        onto.subclasses(typo)


def test_unknown_names_of_every_kind_suggest(onto: Ontology) -> None:
    with pytest.raises(UnknownRelationError, match="did you mean 'contain'"):
        onto.relation("contians")
    with pytest.raises(UnknownPropertyError, match="did you mean 'graspWidth'"):
        onto.data_property("graspwidth")
    with pytest.raises(UnknownTemplateError, match="did you mean 'DefaultKitBox'"):
        onto.template("DefaultKitbox")
    with pytest.raises(UnknownClassError, match=r"unknown class 'Xyzzy'\. "):
        onto.check_class("Xyzzy")


# --------------------------------------------------------------------------- relations


@pytest.mark.parametrize(
    ("subject", "predicate", "obj"),
    [
        ("Gripper", "contain", "Gear"),
        ("KitBox", "contain", "Bolt"),
        ("Shelf", "contain", "PartBox"),
        ("Station", "contain", "Shelf"),
        ("MobileManipulator", "contain", "KitBox"),
        ("Tray", "contain", "MealBox"),
        ("Microwave", "contain", "MealBox"),
        ("MobileManipulator", "hasA", "Arm"),
        ("Microwave", "hasA", "MicrowaveDoor"),
        ("MobileManipulator", "at", "Station"),
        ("KitBox", "on", "Table"),
        ("MealBox", "on", "Tray"),
        ("Camera", "attachedTo", "Arm"),
        ("Gear", "near", "Station"),
        ("RobotAgent", "controls", "MobileManipulator"),
        ("DeviceAgent", "controls", "Microwave"),
        ("RobotAgent", "hasSkill", "Skill"),
    ],
)
def test_relations_within_domain_and_range(
    onto: Ontology, subject: str, predicate: str, obj: str
) -> None:
    assert onto.check_relation(subject, predicate, obj).name == predicate


@pytest.mark.parametrize(
    ("subject", "predicate", "obj", "needle"),
    [
        ("Gear", "contain", "Bolt", "subject of 'contain' must be one of Container, Location"),
        ("RobotAgent", "at", "Station", "subject of 'at' must be PhysicalObject"),
        ("MobileManipulator", "at", "Gear", "object of 'at' must be Location"),
        ("RobotAgent", "controls", "Gear", "object of 'controls' must be Machine"),
        ("Gear", "hasSkill", "Skill", "subject of 'hasSkill' must be Agent"),
        ("KitBox", "contain", "RobotAgent", "object of 'contain'"),
    ],
)
def test_relations_outside_domain_or_range(
    onto: Ontology, subject: str, predicate: str, obj: str, needle: str
) -> None:
    with pytest.raises(RelationDomainError, match=needle):
        onto.check_relation(subject, predicate, obj)


def test_check_relation_rejects_unknown_names_and_abstract_relations(onto: Ontology) -> None:
    with pytest.raises(UnknownRelationError):
        onto.check_relation("Gripper", "holds", "Gear")
    with pytest.raises(UnknownClassError, match="Gear"):
        onto.check_relation("Gripper", "contain", "Gearr")
    with pytest.raises(RelationDomainError, match=r"abstract.*\['contain', 'hasA'\]"):
        onto.check_relation("Gripper", "spatialRelation", "Gear")


def test_sub_property_inherits_the_super_property_domain() -> None:
    onto = with_core("ex:commands a owl:ObjectProperty ; rdfs:subPropertyOf skm:controls .")
    onto.check_relation("RobotAgent", "commands", "Robot")
    with pytest.raises(RelationDomainError, match="from its super-property 'controls'"):
        onto.check_relation("Gear", "commands", "Robot")


def test_spatial_flag_follows_spatial_relation(onto: Ontology) -> None:
    spatial = {name for name, info in onto.relations.items() if info.spatial}
    assert spatial == {"spatialRelation", "contain", "hasA"}
    assert onto.subproperties("spatialRelation") == {"spatialRelation", "contain", "hasA"}
    assert onto.superproperties("contain") == {"contain", "spatialRelation"}
    assert onto.relation("contain").parents == ("spatialRelation",)
    deeper = with_core("ex:grips a owl:ObjectProperty ; rdfs:subPropertyOf skm:contain .")
    assert deeper.relation("grips").spatial
    assert deeper.subproperties("spatialRelation") == {
        "spatialRelation",
        "contain",
        "hasA",
        "grips",
    }


def test_relation_info_domains(onto: Ontology) -> None:
    contain = onto.relation("contain")
    assert contain.domain is None
    assert contain.domains == {"Location", "Container", "Machine"}
    at = onto.relation("at")
    assert (at.domain, at.range, at.spatial) == ("PhysicalObject", "Location", False)


# --------------------------------------------------------------------------- data properties


def test_data_property_infos(onto: Ontology) -> None:
    grasp = onto.data_property("graspWidth")
    assert (grasp.kinds, grasp.minimum, grasp.maximum) == (frozenset({"float"}), 0.0, 0.2)
    assert grasp.tolerance == pytest.approx(0.005)
    assert onto.data_property("size").kinds == {"SizeCuboid", "SizeCylinder", "SizeSphere"}
    assert onto.data_property("jointPositions").kinds == {"list", "float"}
    assert onto.data_property("capacity").minimum == 0
    assert onto.data_property("pose").resolution == "most_confident"
    assert onto.data_property("temperature").resolution == "fused"
    assert onto.data_property("doorOpen").resolution == "latest"


GOOD_VALUES: list[tuple[str, Value]] = [
    ("pose", Pose(Position(0.1, 0.2, 0.3), Orientation(0.0, 0.0, 0.0, 1.0), "Station-1")),
    ("position", Position(1.0, -2.0, 0.5)),
    ("orientation", Orientation()),
    ("frame", Frame(tuple(float(i == j) for i in range(4) for j in range(4)))),
    ("size", SizeCuboid(0.3, 0.2, 0.1)),
    ("size", SizeCylinder(0.05, 0.1)),
    ("size", SizeSphere(0.04)),
    ("color", Color(1.0, 0.0, 0.0)),
    ("mass", 0.25),
    ("mass", 2),
    ("capacity", 6),
    ("doorOpen", True),
    ("address", "skimesh/default/agents/r1"),
    ("jointPositions", [0.0, -0.5, 1]),
    ("jointPositions", []),
    ("mass", None),
]


@pytest.mark.parametrize(("name", "value"), GOOD_VALUES)
def test_good_values_pass(onto: Ontology, name: str, value: Value) -> None:
    onto.check_value(name, value)


@pytest.mark.parametrize(
    ("name", "value", "needle"),
    [
        ("mass", True, "takes float, got bool"),
        ("mass", "heavy", "takes float, got string"),
        ("capacity", 2.0, "takes int, got float"),
        ("capacity", False, "takes int, got bool"),
        ("doorOpen", 1, "takes bool, got int"),
        ("pose", SizeCuboid(1, 1, 1), "takes Pose, got SizeCuboid"),
        ("size", Position(1, 1, 1), "one of SizeCuboid, SizeCylinder, SizeSphere"),
        ("mass", [1.0], "not a list"),
        ("jointPositions", 0.5, "takes a list"),
        ("jointPositions", [0.5, "x"], "item 1 of property 'jointPositions'"),
        ("mass", math.nan, "not finite"),
        ("mass", -0.001, r"must be within \[0.0, inf\]"),
        ("capacity", -1, "must be within"),
        ("color", Color(1.5, 0.0, 0.0), r"\[0, 1\]"),
        ("size", SizeCuboid(-0.1, 0.2, 0.1), ">= 0"),
        ("frame", Frame((1.0, 0.0, 0.0)), "16 numbers"),
        ("position", Position(math.inf, 0.0, 0.0), "finite"),
        ("pose", Pose(Position(0, 0, 0), Orientation(math.nan, 0, 0, 1)), "finite"),
        ("mass", object(), "object"),
    ],
)
def test_bad_values_are_rejected(onto: Ontology, name: str, value: Value, needle: str) -> None:
    with pytest.raises(PropertyValueError, match=needle):
        onto.check_value(name, value)


@pytest.mark.parametrize(
    ("value", "ok"),
    [
        (0.0, True),
        (0.2, True),
        (0.204, True),
        (0.205, True),
        (0.206, False),
        (0.3, False),
        (-0.004, True),
        (-0.006, False),
    ],
)
def test_range_tolerance(onto: Ontology, value: float, ok: bool) -> None:
    if ok:
        onto.check_value("graspWidth", value)
    else:
        with pytest.raises(PropertyValueError) as err:
            onto.check_value("graspWidth", value)
        message = str(err.value)
        assert "graspWidth" in message
        assert repr(value) in message
        assert "[0.0, 0.2]" in message
        assert "tolerance 0.005" in message


def test_check_property_checks_the_domain(onto: Ontology) -> None:
    onto.check_property("Microwave", "heatingPower", 900.0)
    onto.check_property("MealBox", "capacity", 1)
    with pytest.raises(PropertyValueError, match="does not apply to a Gear: it is for Appliance"):
        onto.check_property("Gear", "heatingPower", 900.0)
    with pytest.raises(UnknownPropertyError):
        onto.check_value("weight", 1.0)


# --------------------------------------------------------------------------- cardinality


def test_max_cardinality_is_inherited(onto: Ontology) -> None:
    assert onto.max_cardinality("Gripper", "contain") == 1
    assert onto.max_cardinality("PhysicalObject", "at") == 1
    assert onto.max_cardinality("MobileManipulator", "at") == 1  # from PhysicalObject
    assert onto.max_cardinality("Gripper", "at") == 1
    assert onto.max_cardinality("Microwave", "contain") == 1
    assert onto.max_cardinality("KitBox", "contain") is None
    assert onto.max_cardinality("Gripper", "spatialRelation") is None  # contain is narrower


def test_qualified_max_cardinality(onto: Ontology) -> None:
    assert onto.max_cardinality("Microwave", "hasA") is None
    assert onto.max_cardinality("Microwave", "hasA", "MicrowaveDoor") == 1
    assert onto.max_cardinality("Microwave", "hasA", "Camera") is None
    assert onto.max_cardinality("Arm", "hasA", "Gripper") == 1
    assert onto.max_cardinality("MobileManipulator", "hasA", "MobileBase") == 1


def test_restriction_on_a_super_property_bounds_its_sub_properties() -> None:
    onto = with_core(
        "ex:Peg a owl:Class ; rdfs:subClassOf skm:Part , [ a owl:Restriction ; "
        'owl:onProperty skm:spatialRelation ; owl:maxCardinality "2"^^xsd:nonNegativeInteger ] .'
    )
    assert onto.max_cardinality("Peg", "hasA") == 2
    assert onto.max_cardinality("Peg", "contain") == 2


def test_min_cardinality(onto: Ontology) -> None:
    assert onto.min_cardinality("MobileManipulator", "hasA") == 1
    assert onto.min_cardinality("MobileManipulator", "hasA", "Arm") == 1
    assert onto.min_cardinality("MobileManipulator", "hasA", "Device") == 1
    assert onto.min_cardinality("MobileManipulator", "hasA", "Gripper") is None
    assert onto.min_cardinality("MobileManipulator", "spatialRelation") == 1
    assert onto.min_cardinality("Microwave", "hasA", "MicrowaveDoor") == 1
    assert onto.min_cardinality("RobotAgent", "controls", "Robot") == 1
    assert onto.min_cardinality("Gripper", "contain") is None


def test_check_max_cardinality(onto: Ontology) -> None:
    onto.check_max_cardinality("Gripper", "contain", "Gear", [])
    onto.check_max_cardinality("Gripper", "hasA", "Camera", [("contain", "Gear")])
    with pytest.raises(CardinalityError, match=r"at most 1 'contain'.*already has 1"):
        onto.check_max_cardinality("Gripper", "contain", "Bolt", [("contain", "Gear")])
    with pytest.raises(CardinalityError, match="exactly 1 'hasA' to a MicrowaveDoor"):
        onto.check_max_cardinality(
            "Microwave", "hasA", "MicrowaveDoor", [("hasA", "MicrowaveDoor")]
        )
    onto.check_max_cardinality("Microwave", "hasA", "Camera", [("hasA", "MicrowaveDoor")])
    with pytest.raises(CardinalityError, match="declared on PhysicalObject"):
        onto.check_max_cardinality("MobileManipulator", "at", "Station", [("at", "Station")])


def test_check_min_cardinality_reports_without_raising(onto: Ontology) -> None:
    bare = onto.check_min_cardinality("MobileManipulator", [])
    assert {s.restriction.on_class for s in bare} == {"Arm", "MobileBase"}
    assert all(s.actual == 0 for s in bare)
    messages = sorted(s.message for s in bare)
    assert messages[0] == (
        "a MobileManipulator should have at least 1 'hasA' to an Arm (declared on "
        "MobileManipulator); it has 0"
    )
    built = [("hasA", "Arm"), ("hasA", "MobileBase"), ("hasA", "Gripper")]
    assert onto.check_min_cardinality("MobileManipulator", built) == ()
    door = onto.check_min_cardinality("Microwave", [("contain", "MealBox")])
    assert len(door) == 1
    assert "MicrowaveDoor" in door[0].message


# --------------------------------------------------------------------------- templates


def test_templates_by_name_and_by_class(onto: Ontology) -> None:
    kit = onto.template("KitBox")
    assert kit.name == "DefaultKitBox"
    assert kit.type == "KitBox"
    assert kit.properties["size"] == SizeCuboid(0.4, 0.3, 0.12)
    assert kit.properties["capacity"] == 6
    gear = onto.template("DefaultGear")
    assert gear.properties["mass"] == pytest.approx(0.12)
    assert isinstance(gear.properties["size"], SizeCylinder)
    assert onto.template("Microwave").properties["heatingPower"] == 800.0
    assert onto.template("Arm").properties["jointPositions"] == [0.0, -0.5, 0.0, 1.2, 0.0, 0.8, 0.0]
    assert {"DefaultMealBox", "DefaultTray", "DefaultMeal"} <= set(onto.templates)


def test_every_template_is_valid(onto: Ontology) -> None:
    for t in onto.templates.values():
        for key, value in t.properties.items():
            onto.check_property(t.type, key, value)


def test_template_returns_a_copy(onto: Ontology) -> None:
    arm = onto.template("DefaultArm")
    arm.properties["mass"] = 3.0
    joints = arm.properties["jointPositions"]
    assert isinstance(joints, list)
    joints.append(9.0)
    fresh = onto.template("DefaultArm")
    assert "mass" not in fresh.properties
    assert fresh.properties["jointPositions"] == [0.0, -0.5, 0.0, 1.2, 0.0, 0.8, 0.0]
    with pytest.raises(TypeError):
        onto.templates["X"] = arm  # type: ignore[index]


def test_template_lookup_errors(onto: Ontology) -> None:
    with pytest.raises(UnknownTemplateError, match="no default template for class 'Station'"):
        onto.template("Station")
    two = with_core(
        "ex:BigBolt a owl:NamedIndividual , skm:Bolt ; skm:template true .\n"
        "ex:SmallBolt a owl:NamedIndividual , skm:Bolt ; skm:template true ."
    )
    assert two.template("Bolt").name == "DefaultBolt"  # the Default<Class> one wins
    three = with_core(
        "ex:BigGear a owl:NamedIndividual , skm:Shaft ; skm:template true .\n"
        "ex:Other a owl:Class ; rdfs:subClassOf skm:Part .\n"
        "ex:A1 a owl:NamedIndividual , ex:Other ; skm:template true .\n"
        "ex:A2 a owl:NamedIndividual , ex:Other ; skm:template true ."
    )
    with pytest.raises(UnknownTemplateError, match=r"several, ask by name: \['A1', 'A2'\]"):
        three.template("Other")


# --------------------------------------------------------------------------- literals

ROUND_TRIP: list[Value] = [
    Position(0.1, 0.2, 0.3),
    Position(1.0, 2.0, 3.0, "Station-1"),
    Orientation(0.0, 0.7071067811865476, 0.0, 0.7071067811865476),
    Orientation(0.0, 0.0, 0.0, 1.0, "Arm-2"),
    Pose(Position(0.1, 0.2, 0.3), Orientation(0.0, 0.0, 1.0, 0.0), "Table-1"),
    Pose(Position(0.1, 0.2, 0.3, "a"), Orientation(0.0, 0.0, 1.0, 0.0, "b"), "c"),
    Frame(tuple(float(i) / 3 for i in range(16)), "World"),
    Frame((1.0, 2.0)),
    SizeCuboid(0.3, 0.2, 0.1),
    SizeCylinder(0.05, 0.1),
    SizeSphere(0.04),
    Color(0.1, 0.2, 0.3, 0.5),
    True,
    False,
    0,
    -(2**70),
    0.1,
    -0.0,
    1e-300,
    math.inf,
    -math.inf,
    "",
    "plain text",
    'ünïcode @ with "quotes" and\nnewline',
    [],
    [1, 2.5, "x", True, Position(1.0, 2.0, 3.0)],
    None,
]


@pytest.mark.parametrize("value", ROUND_TRIP, ids=repr)
def test_literal_round_trip(value: Value) -> None:
    lit = literal_from_value(value)
    back = value_from_literal(lit)
    assert back == value
    assert type(back) is type(value)
    graph = Graph()
    graph.add((URIRef("urn:x"), SKM.p, lit))  # and through Turtle text, as scene export does
    reparsed = Graph().parse(data=graph.serialize(format="turtle"), format="turtle")
    assert value_from_literal(next(iter(reparsed.objects()))) == value


def test_nan_round_trips() -> None:
    back = value_from_literal(literal_from_value(math.nan))
    assert isinstance(back, float)
    assert math.isnan(back)


@pytest.mark.parametrize(
    ("value", "lexical", "datatype"),
    [
        (Position(1.0, 2.0, 3.0), "1.0 2.0 3.0", SKM.Position),
        (Position(1.0, 2.0, 3.0, "Box-1"), "1.0 2.0 3.0 @Box-1", SKM.Position),
        (SizeCylinder(0.05, 0.1), "0.05 0.1", SKM.SizeCylinder),
        (Color(1.0, 0.0, 0.0), "1.0 0.0 0.0 1.0", SKM.Color),
        ([1.0, 2.0], "[1.0,2.0]", SKM.json),
        (Pose(Position(0, 0, 0, "a")), None, SKM.json),
        (2.5, "2.5", XSD.double),
        (3, "3", XSD.integer),
        (True, "true", XSD.boolean),
    ],
)
def test_literal_forms(value: Value, lexical: str | None, datatype: URIRef) -> None:
    lit = literal_from_value(value)
    assert lit.datatype == datatype
    if lexical is not None:
        assert str(lit) == lexical


@pytest.mark.parametrize(
    ("lit", "value"),
    [
        (Literal("1 0 0", datatype=SKM.Color), Color(1.0, 0.0, 0.0, 1.0)),
        (Literal("1 2 3 0 0 0 1", datatype=SKM.Pose), Pose(Position(1, 2, 3), Orientation())),
        (Literal("0.5", datatype=XSD.decimal), 0.5),
        (Literal("7", datatype=XSD.int), 7),
        (Literal("1", datatype=XSD.boolean), True),
        (Literal("hello", lang="en"), "hello"),
        (Literal("hello", datatype=XSD.string), "hello"),
    ],
)
def test_hand_written_literals(lit: Literal, value: Value) -> None:
    assert value_from_literal(lit) == value


@pytest.mark.parametrize(
    ("lit", "needle"),
    [
        (Literal("1 2", datatype=SKM.Position), "needs 3 numbers"),
        (Literal("a b c", datatype=SKM.Position), "space-separated numbers"),
        (Literal("1 1 1 @Box-1", datatype=SKM.SizeCuboid), "has no frame"),
        (Literal("[1,", datatype=SKM.json), "not a JSON"),
        (Literal("2024-01-01T00:00:00", datatype=XSD.dateTime), "unsupported datatype"),
        (Literal("maybe", datatype=XSD.boolean), "not a valid boolean"),
        (URIRef("urn:x"), "resource"),
    ],
)
def test_bad_literals(lit: Literal | URIRef, needle: str) -> None:
    with pytest.raises(PropertyValueError, match=needle):
        value_from_literal(lit)


finite = st.floats(allow_nan=False, allow_infinity=False)
non_negative = st.floats(min_value=0.0, allow_infinity=False)
unit = st.floats(min_value=0.0, max_value=1.0)
frames = st.text(max_size=12)
scalars = st.one_of(
    st.booleans(),
    st.integers(),
    finite,
    st.text(),
    st.builds(Position, finite, finite, finite, frames),
    st.builds(Orientation, finite, finite, finite, finite, frames),
    st.builds(SizeCuboid, non_negative, non_negative, non_negative),
    st.builds(SizeSphere, non_negative),
    st.builds(Color, unit, unit, unit, unit),
)


@given(st.floats(allow_nan=False))
def test_any_float_round_trips(x: float) -> None:
    back = value_from_literal(literal_from_value(x))
    assert isinstance(back, float)
    assert back == x
    assert math.copysign(1.0, back) == math.copysign(1.0, x)


@given(st.builds(Pose, st.builds(Position, finite, finite, finite), st.builds(Orientation), frames))
def test_any_pose_round_trips(pose: Pose) -> None:
    assert value_from_literal(literal_from_value(pose)) == pose


@given(st.lists(scalars, max_size=6))
def test_any_list_round_trips(items: list[Value]) -> None:
    value: Value = items  # type: ignore[assignment]
    assert value_from_literal(literal_from_value(value)) == value


@given(scalars)
def test_any_scalar_round_trips(value: Value) -> None:
    assert value_from_literal(literal_from_value(value)) == value


# --------------------------------------------------------------------------- extend


def test_extend_adds_a_subclass_and_leaves_the_original(onto: Ontology) -> None:
    before = onto.subclasses("Part")
    bigger = onto.extend(classes=[ClassDef(name="Pulley", parent="Part", comment="A belt wheel.")])
    assert bigger.is_a("Pulley", "Part")
    assert bigger.is_a("Pulley", "PhysicalObject")
    assert "Pulley" in bigger.subclasses("Part")
    assert "Pulley" in bigger.subclasses("PhysicalObject")
    assert bigger.superclasses("Pulley") == ("Pulley", "Part", "PhysicalObject")
    assert bigger.max_cardinality("Pulley", "at") == 1  # inherited restriction
    assert bigger.class_info("Pulley").label == "pulley"
    assert bigger.extended_classes == (
        ClassDef(name="Pulley", parent="Part", comment="A belt wheel."),
    )
    assert onto.subclasses("Part") == before
    assert "Pulley" not in onto.classes
    with pytest.raises(UnknownClassError):
        onto.check_class("Pulley")
    assert onto.extend() is onto


def test_extend_chain_and_template(onto: Ontology) -> None:
    bigger = onto.extend(
        classes=[
            ClassDef(name="Pulley", parent="Part"),
            ClassDef(name="TimingPulley", parent="Pulley", label="timing pulley"),
        ],
        templates=[
            TemplateDef(
                name="DefaultTimingPulley",
                type="TimingPulley",
                label="GT2 pulley",
                properties={"mass": 0.03, "size": SizeCylinder(0.01, 0.015), "graspWidth": 0.02},
            )
        ],
    )
    assert bigger.is_a("TimingPulley", "Part")
    assert bigger.subclasses("Pulley") == {"Pulley", "TimingPulley"}
    tpl = bigger.template("TimingPulley")
    assert tpl.name == "DefaultTimingPulley"
    assert tpl.properties["mass"] == 0.03
    assert "DefaultTimingPulley" not in onto.templates


@pytest.mark.parametrize(
    ("cls", "error", "needle"),
    [
        (ClassDef(name="Pulley", parent="Prat"), UnknownClassError, "did you mean 'Part'"),
        (ClassDef(name="Gear", parent="Part"), OntologyError, "already defined"),
        (ClassDef(name="pulley", parent="Part"), OntologyError, "capital letter"),
        (ClassDef(name="Timing-Pulley", parent="Part"), OntologyError, "capital letter"),
        (ClassDef(name="Pose", parent="Part"), OntologyError, "taken"),
        (ClassDef(name="DefaultGear", parent="Part"), OntologyError, "taken"),
    ],
)
def test_extend_rejects_bad_classes(
    onto: Ontology, cls: ClassDef, error: type[Exception], needle: str
) -> None:
    with pytest.raises(error, match=needle):
        onto.extend(classes=[cls])


@pytest.mark.parametrize(
    ("template", "error", "needle"),
    [
        (TemplateDef(name="T", type="Gera"), UnknownClassError, "Gear"),
        (TemplateDef(name="T", type="Gear", properties={"mass": -1.0}), PropertyValueError, "'T'"),
        (TemplateDef(name="T", type="Gear", properties={"mas": 1.0}), UnknownPropertyError, "mass"),
        (
            TemplateDef(name="T", type="Gear", properties={"heatingPower": 1.0}),
            PropertyValueError,
            "does not apply",
        ),
        (TemplateDef(name="DefaultGear", type="Gear"), OntologyError, "cannot be replaced"),
        (TemplateDef(name="Gear", type="Gear"), OntologyError, "taken"),
        (TemplateDef(name="bad name", type="Gear"), OntologyError, "letters"),
    ],
)
def test_extend_rejects_bad_templates(
    onto: Ontology, template: TemplateDef, error: type[Exception], needle: str
) -> None:
    with pytest.raises(error, match=needle):
        onto.extend(templates=[template])


def test_run_time_templates_can_be_replaced(onto: Ontology) -> None:
    first = onto.extend(
        templates=[TemplateDef(name="HeavyGear", type="Gear", properties={"mass": 2.0})]
    )
    second = first.extend(
        templates=[TemplateDef(name="HeavyGear", type="Gear", properties={"mass": 3.0})]
    )
    assert second.template("HeavyGear").properties == {"mass": 3.0}
    assert first.template("HeavyGear").properties == {"mass": 2.0}
    assert len(second.extended_templates) == 1
    hyphen = onto.extend(templates=[TemplateDef(name="small-gear", type="Gear")])
    assert hyphen.template("small-gear").type == "Gear"


def test_extension_turtle_reloads_with_the_core(onto: Ontology) -> None:
    assert onto.extension_turtle() == ""
    bigger = onto.extend(
        classes=[ClassDef(name="Pulley", parent="Part", label="pulley", comment="A wheel.")],
        templates=[
            TemplateDef(
                name="DefaultPulley",
                type="Pulley",
                label="pulley",
                properties={"mass": 0.1, "color": Color(0.2, 0.2, 0.2), "description": None},
            )
        ],
    )
    text = bigger.extension_turtle()
    reloaded = Ontology.load(core_ontology_path(), text)
    assert reloaded.is_a("Pulley", "Part")
    assert reloaded.class_info("Pulley") == bigger.class_info("Pulley")
    assert reloaded.template("Pulley") == bigger.template("Pulley")
    assert reloaded.classes == bigger.classes


def test_extended_graph_includes_the_additions(onto: Ontology) -> None:
    size = len(onto.graph)
    bigger = onto.extend(classes=[ClassDef(name="Pulley", parent="Part")])
    assert (SKM.Pulley, None, None) in bigger.graph
    assert len(onto.graph) == size
    assert (SKM.Pulley, None, None) not in onto.graph


def test_extend_is_fast(onto: Ontology) -> None:
    timings = []
    for i in range(5):
        start = time.perf_counter()
        onto.extend(
            classes=[ClassDef(name=f"Fast{i}", parent="Part")],
            templates=[
                TemplateDef(name=f"DefaultFast{i}", type=f"Fast{i}", properties={"mass": 1})
            ],
        )
        timings.append(time.perf_counter() - start)
    assert min(timings) < 0.05


# --------------------------------------------------------------------------- Protégé file


@pytest.fixture(scope="module")
def geared() -> Ontology:
    return Ontology.load(core_ontology_path(), ASSETS / "protege_extension.ttl")


def test_protege_extension_loads_with_the_core(geared: Ontology) -> None:
    assert geared.is_a("HelicalGear", "Gear")
    assert geared.is_a("HelicalGear", "Part")
    assert "HelicalGear" in geared.subclasses("Part")
    assert geared.is_a("Gearbox", "Container")
    assert geared.relation("meshesWith").parents == ("near",)
    assert "meshesWith" in geared.subproperties("near")
    geared.check_relation("HelicalGear", "meshesWith", "Gear")
    with pytest.raises(RelationDomainError):
        geared.check_relation("Shaft", "meshesWith", "Gear")


def test_protege_extension_spatial_by_annotation(geared: Ontology) -> None:
    assert geared.relation("carries").spatial
    assert not geared.relation("meshesWith").spatial


def test_protege_extension_properties_and_restrictions(geared: Ontology) -> None:
    module = geared.data_property("module")
    assert (module.kinds, module.minimum, module.maximum) == (frozenset({"float"}), 0.1, 10.0)
    geared.check_value("module", 10.04)  # tolerance 0.05
    with pytest.raises(PropertyValueError):
        geared.check_value("module", 10.1)
    teeth = geared.data_property("toothCount")
    assert (teeth.kinds, teeth.minimum) == (frozenset({"int"}), 0.0)
    assert geared.max_cardinality("HelicalGear", "meshesWith", "Gear") == 2
    assert geared.min_cardinality("Gearbox", "hasA", "Shaft") == 1  # from owl:someValuesFrom


def test_protege_extension_template(geared: Ontology) -> None:
    gear = geared.template("HelicalGear")
    assert gear.name == "DefaultHelicalGear"
    assert gear.properties == {
        "mass": 0.15,
        "size": SizeCylinder(0.035, 0.02),
        "module": 1.5,
        "toothCount": 24,
    }


def test_value_kinds_any_and_list() -> None:
    onto = with_core(
        "ex:anything a owl:DatatypeProperty .\n"
        'ex:tags a owl:DatatypeProperty ; rdfs:range skm:json ; skm:valueKind "list" .\n'
        'ex:waypoints a owl:DatatypeProperty ; skm:valueKind "list" , "Pose" .'
    )
    values: list[Value] = [1, "x", [1, "x"], Position(0, 0, 0)]
    for value in values:
        onto.check_value("anything", value)
    onto.check_value("tags", ["a", 1, Color(0, 0, 0)])
    with pytest.raises(PropertyValueError, match="takes a list"):
        onto.check_value("tags", "a")
    onto.check_value("waypoints", [Pose(Position(0, 0, 0))])
    with pytest.raises(PropertyValueError, match="item 0 of property 'waypoints' takes Pose"):
        onto.check_value("waypoints", [Position(0, 0, 0)])
