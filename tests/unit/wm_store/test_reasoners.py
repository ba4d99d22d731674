"""Reasoners: spatial maths against hand-computed cases, similarity rankings, the plug-in set."""

from __future__ import annotations

import itertools
import math
from importlib.metadata import EntryPoint
from pathlib import Path

import pytest

from wm_store import ElementNotFoundError, UnknownClassError, ValidationError
from wm_store.ontology import Ontology
from wm_store.protocol import (
    Color,
    Element,
    Orientation,
    Pose,
    Position,
    SizeCuboid,
    SizeCylinder,
    SizeSphere,
    TemplateDef,
    TemplateDefined,
    Value,
)
from wm_store.rdf import import_turtle
from wm_store.reasoners import (
    FrameCycleError,
    MissingDataError,
    Reasoner,
    ReasonerError,
    ReasonerSet,
    SimilarityReasoner,
    SpatialReasoner,
    Transform,
    classify,
    identify,
    property_similarity,
    quat_multiply,
    quat_rotate,
)
from wm_store.scene import SceneState, apply_transaction

ROOT = Path(__file__).resolve().parents[3]
S = math.sqrt(0.5)
YAW_90 = Orientation(0.0, 0.0, S, S)
ROLL_90 = Orientation(S, 0.0, 0.0, S)
PITCH_90 = Orientation(0.0, S, 0.0, S)


IDENTITY = Orientation()


def pose(x: float, y: float, z: float, o: Orientation = IDENTITY, frame: str = "") -> Pose:
    return Pose(Position(x, y, z), o, frame)


def scene(*elements: Element) -> SceneState:
    state = SceneState()
    for e in elements:
        state.put_element(e)
    return state


def el(element_id: str, element_type: str = "Box", **properties: Value) -> Element:
    return Element(id=element_id, type=element_type, properties=dict(properties))


def close(actual: tuple[float, ...], expected: tuple[float, ...]) -> bool:
    return all(math.isclose(a, b, abs_tol=1e-9) for a, b in zip(actual, expected, strict=True))


def xyz(p: Pose) -> tuple[float, float, float]:
    return (p.position.x, p.position.y, p.position.z)


def quat(p: Pose) -> tuple[float, float, float, float]:
    o = p.orientation
    return (o.x, o.y, o.z, o.w)


# --------------------------------------------------------------------------- quaternion maths


def test_quaternion_rotation_and_product_by_hand() -> None:
    z90 = (0.0, 0.0, S, S)
    assert close(quat_rotate(z90, (1.0, 0.0, 0.0)), (0.0, 1.0, 0.0))
    assert close(quat_rotate((S, 0.0, 0.0, S), (0.0, 1.0, 0.0)), (0.0, 0.0, 1.0))
    # two quarter turns about z make a half turn: (0, 0, 1, 0)
    assert close(quat_multiply(z90, z90), (0.0, 0.0, 1.0, 0.0))
    t = Transform((1.0, 2.0, 3.0), z90)
    assert close(t.compose(t.inverse()).translation, (0.0, 0.0, 0.0))
    assert close(t.inverse().apply(t.apply((0.3, -0.2, 0.9))), (0.3, -0.2, 0.9))


# --------------------------------------------------------------------------- frames


@pytest.fixture
def chain() -> SpatialReasoner:
    """A at (1,0,0) turned 90° about z; B at (1,0,0) in A; C at (0,2,0.5) in B."""
    return SpatialReasoner(
        scene(
            el("A", pose=pose(1, 0, 0, YAW_90)),
            el("B", pose=pose(1, 0, 0, frame="A")),
            el("C", "Gear", pose=pose(0, 2, 0.5, frame="B")),
            el("D", pose=pose(0, 0, 0, ROLL_90)),
            el("E", "Gear", position=Position(0, 1, 0, "D")),
        )
    )


def test_world_pose_chains_frames(chain: SpatialReasoner) -> None:
    assert close(xyz(chain.world_pose("B")), (1, 1, 0))
    c = chain.world_pose("C")
    assert close(xyz(c), (-1, 1, 0.5))  # (1,1,0) + Rz90·(0,2,0.5) = (1,1,0) + (-2,0,0.5)
    assert close(quat(c), (0, 0, S, S))
    assert c.frame == ""
    # a bare position is a pose without rotation, in its frame: Rx90·(0,1,0) = (0,0,1)
    assert close(xyz(chain.world_pose("E")), (0, 0, 1))
    assert chain.world_position("E") == Position(*chain.world_transform("E").translation)


def test_relative_pose_and_distance(chain: SpatialReasoner) -> None:
    c_in_a = chain.relative_pose("C", "A")
    assert c_in_a.frame == "A" and c_in_a.position.frame == "A"
    assert close(xyz(c_in_a), (1, 2, 0.5))
    assert close(quat(c_in_a), (0, 0, 0, 1))
    assert close(xyz(chain.relative_pose("A", "C")), (-1, -2, -0.5))
    assert math.isclose(chain.distance("A", "C"), math.sqrt(5.25))
    assert chain.distance("C", "C") == 0.0


def test_frame_errors_are_typed() -> None:
    spatial = SpatialReasoner(
        scene(
            el("A", pose=pose(0, 0, 0, frame="B")),
            el("B", pose=pose(0, 0, 0, frame="A")),
            el("Lost", pose=pose(0, 0, 0, frame="Nowhere")),
            el("Bare"),
            el("Zero", pose=pose(0, 0, 0, Orientation(0, 0, 0, 0))),
        )
    )
    with pytest.raises(FrameCycleError, match="A -> B -> A"):
        spatial.world_pose("A")
    with pytest.raises(ElementNotFoundError, match="Nowhere"):
        spatial.world_pose("Lost")
    with pytest.raises(MissingDataError, match="no 'pose'"):
        spatial.world_pose("Bare")
    with pytest.raises(MissingDataError, match="not a rotation"):
        spatial.world_pose("Zero")
    with pytest.raises(ElementNotFoundError):
        spatial.distance("Ghost", "Bare")
    assert FrameCycleError.code == MissingDataError.code == "property_value"


# --------------------------------------------------------------------------- volumes


def test_is_inside_respects_rotation_shape_and_tolerance() -> None:
    spatial = SpatialReasoner(
        scene(
            el(
                "K",
                pose=pose(0, 0, 0, Orientation(0, 0, math.sin(math.pi / 8), math.cos(math.pi / 8))),
                size=SizeCuboid(2.0, 0.2, 1.0),
            ),
            el("Diag", "Gear", pose=pose(0.6, 0.6, 0)),
            el("Axis", "Gear", pose=pose(0.6, 0, 0)),
            el("Cyl", pose=pose(5, 0, 0), size=SizeCylinder(0.5, 1.0)),
            el("Rim", "Gear", pose=pose(0.4, 0.31, 0, frame="Cyl")),
            el("Ball", pose=pose(0, 5, 0), size=SizeSphere(1.0)),
            el("Near", "Gear", pose=pose(0.5, 0.5, 0.5, frame="Ball")),
            el("Far", "Gear", pose=pose(0.6, 0.6, 0.6, frame="Ball")),
            el("Bin", pose=pose(0, 0, 10), size=SizeCuboid(2, 2, 2)),
            el("Cube", "Gear", pose=pose(0.95, 0, 0, frame="Bin"), size=SizeCuboid(0.2, 0.2, 0.2)),
        )
    )
    # K is turned 45°: its long axis runs along the diagonal
    assert spatial.is_inside("Diag", "K")
    assert not spatial.is_inside("Axis", "K")
    assert not spatial.is_inside("Rim", "Cyl")  # radius 0.5008 > 0.5
    assert spatial.is_inside("Rim", "Cyl", tolerance=0.01)
    assert spatial.is_inside("Near", "Ball") and not spatial.is_inside("Far", "Ball")
    assert spatial.is_inside("Cube", "Bin")
    assert not spatial.is_inside("Cube", "Bin", whole=True)  # its corners stick out by 5 cm
    with pytest.raises(MissingDataError, match="size"):
        spatial.is_inside("Diag", "Axis")


def test_is_on_uses_top_face_footprint_and_lowest_point() -> None:
    spatial = SpatialReasoner(
        scene(
            el("T", "Table", pose=pose(0, 0, 0.7), size=SizeCuboid(1.0, 0.6, 0.04)),
            el("On", pose=pose(0.1, 0, 0.77), size=SizeCuboid(0.2, 0.2, 0.1)),
            el("Above", pose=pose(0.1, 0, 0.80), size=SizeCuboid(0.2, 0.2, 0.1)),
            el("Off", pose=pose(0.6, 0, 0.77), size=SizeCuboid(0.2, 0.2, 0.1)),
            # a shaft lying down: its lowest point is its radius below its centre
            el("Lying", "Shaft", pose=pose(0, 0.1, 0.77, PITCH_90), size=SizeCylinder(0.05, 0.3)),
            el("Dot", "Gear", pose=pose(0, 0, 0.725)),
        )
    )
    assert spatial.is_on("On", "T")
    assert not spatial.is_on("Above", "T")
    assert spatial.is_on("Above", "T", tolerance=0.05)
    assert not spatial.is_on("Off", "T")
    assert spatial.is_on("Lying", "T")
    assert spatial.is_on("Dot", "T")  # no size: its centre is within 1 cm of the top
    assert spatial.compute_relations("On", "T") == {"on"}
    assert spatial.compute_relations("T", "On") == frozenset()
    assert spatial.compute_relations("Dot", "On") == frozenset()  # Dot has no size: no error


def test_get_data_codes(chain: SpatialReasoner) -> None:
    assert chain.get_data("B", "world_pose") == chain.world_pose("B")
    assert chain.get_data("B", "world_position") == chain.world_position("B")
    with pytest.raises(ValidationError, match="world_pose"):
        chain.get_data("B", "colour")


def test_sample_scene_is_geometrically_consistent(ontology: Ontology) -> None:
    state = SceneState()
    state.set_spatial_predicates(n for n, r in ontology.relations.items() if r.spatial)
    ops = import_turtle((ROOT / "configs/scenes/sample.ttl").read_text(), ontology)
    apply_transaction(state, ontology, ops, revision=1, now=0.0)
    spatial = SpatialReasoner(state, ontology)
    for part in ("Gear-1", "Gear-2", "Shaft-1", "Shaft-2"):
        assert spatial.is_inside(part, "PartBox-1", whole=True), part
        assert spatial.is_inside(part, "Station-1")
    assert spatial.is_on("PartBox-1", "Shelf-1")
    assert spatial.is_on("KitBox-1", "MobileBase-1")
    assert spatial.compute_relations("PartBox-1", "Gear-1") == {"contain"}
    assert close(xyz(spatial.world_pose("Shelf-1")), (3.1, 0.9, 0.6))
    assert not spatial.is_inside("MobileManipulator-1", "Station-1")  # it waits beside it


# --------------------------------------------------------------------------- similarity


def test_property_similarity_formulas() -> None:
    assert property_similarity(0.12, 0.12) == 1.0
    assert math.isclose(property_similarity(0.3, 0.4) or 0, 0.75)
    assert property_similarity(0, 0) == 1.0
    assert property_similarity("G-100", "G-100") == 1.0
    assert property_similarity("G-100", "S-200") == 0.0
    assert property_similarity(True, 1) == 0.0
    # a box seen lying on another face is the same box
    assert property_similarity(SizeCuboid(0.1, 0.2, 0.3), SizeCuboid(0.3, 0.1, 0.2)) == 1.0
    # a cylinder and a cuboid with the same bounding box: half
    assert property_similarity(SizeCylinder(0.1, 0.3), SizeCuboid(0.2, 0.2, 0.3)) == 0.5
    assert math.isclose(
        property_similarity(Color(1, 0, 0), Color(0, 1, 0)) or 0, 1 - math.sqrt(2 / 3)
    )
    assert property_similarity(Color(1, 0, 0), 3.0) == 0.0
    assert property_similarity(Position(0, 0, 0), Position(0, 0, 0)) is None
    assert property_similarity([1.0], [1.0]) is None


def observed_gear(**extra: Value) -> Element:
    return Element(
        id="", type="Part", properties={"size": SizeCylinder(0.031, 0.02), "mass": 0.118, **extra}
    )


def test_classify_ranks_templates_and_classes(ontology: Ontology) -> None:
    state = SceneState()
    ranked = classify(state, ontology, observed_gear(), "Part", 0.0)
    assert ranked[0][0] == "DefaultGear"
    # size: 1 - 0.004/0.144 (sorted extents 0.02 0.06 0.06 vs 0.02 0.062 0.062); mass: 1 -
    # 0.002/0.12; the mean of both
    expected = ((1 - 0.004 / 0.144) + (1 - 0.002 / 0.12)) / 2
    assert math.isclose(ranked[0][1], expected)
    shaft = dict(ranked)["DefaultShaft"]  # extents 0.02 0.02 0.15: far less alike
    assert math.isclose(shaft, ((1 - 0.13 / 0.232) + (1 - 0.082 / 0.2)) / 2)
    assert all(a[1] >= b[1] for a, b in itertools.pairwise(ranked))
    assert classify(state, ontology, observed_gear(), "Part", 0.9) == [
        ("DefaultGear", ranked[0][1])
    ]
    by_class = classify(state, ontology, observed_gear(), "Part", 0.9, by="class")
    assert by_class == [("Gear", ranked[0][1])]
    # candidates are limited to the type asked for
    assert {n for n, _ in classify(state, ontology, observed_gear(), "Box", 0.0)} == {
        "DefaultKitBox",
        "DefaultPartBox",
        "DefaultMealBox",
    }


def test_classify_uses_runtime_templates_and_checks_arguments(ontology: Ontology) -> None:
    state = SceneState()
    big = TemplateDef(
        name="BigGear", type="Gear", properties={"size": SizeCylinder(0.031, 0.02), "mass": 0.118}
    )
    state.apply(TemplateDefined(big))  # as a DefineTemplate writes it
    assert classify(state, ontology, observed_gear(), "Gear", 0.99) == [("BigGear", 1.0)]
    with pytest.raises(UnknownClassError, match="Gear"):
        classify(state, ontology, observed_gear(), "Gera", 0.5)
    with pytest.raises(ValidationError, match="threshold"):
        classify(state, ontology, observed_gear(), "Part", 1.5)


@pytest.fixture
def parts() -> SceneState:
    gear: dict[str, Value] = {"size": SizeCylinder(0.03, 0.02), "mass": 0.12}
    return scene(
        el("Gear-1", "Gear", pose=pose(0, 0, 0), **gear),
        el("Gear-2", "Gear", pose=pose(1, 0, 0), **gear),
        el("Gear-10", "Gear", pose=pose(1, 0, 0), **gear),
        el("Shaft-1", "Shaft", pose=pose(0.95, 0, 0), size=SizeCylinder(0.01, 0.15), mass=0.2),
        el("Box-1", "Box", pose=pose(0.95, 0, 0), size=SizeCuboid(0.3, 0.2, 0.1)),
    )


def test_identify_ranks_known_elements(parts: SceneState, ontology: Ontology) -> None:
    seen = Element(
        id="Gear-99",
        type="Gear",
        properties={"size": SizeCylinder(0.03, 0.02), "mass": 0.12, "pose": pose(0.95, 0, 0)},
    )
    ranked = identify(parts, ontology, seen, 0.0)
    # equal scores keep natural id order: Gear-2 before Gear-10; shafts and boxes are no gears
    assert [i for i, _ in ranked] == ["Gear-2", "Gear-10", "Gear-1"]
    assert math.isclose(ranked[0][1], (2 + 0.9) / 3)  # position 5 cm off with a 0.5 m scale
    assert math.isclose(ranked[2][1], 2 / 3)
    assert [i for i, _ in identify(parts, ontology, seen, 0.9)] == ["Gear-2", "Gear-10"]
    assert {i for i, s in identify(parts, ontology, seen, 0.0, position_scale=None)} == {
        "Gear-1",
        "Gear-2",
        "Gear-10",
    }
    # a less specific observation (a Part) may be a gear or a shaft, never a box
    part = Element(
        id="", type="Part", properties={"size": SizeCylinder(0.01, 0.15), "pose": pose(0.95, 0, 0)}
    )
    ranked_part = identify(parts, ontology, part, 0.0)
    assert ranked_part[0] == ("Shaft-1", 1.0)
    assert "Box-1" not in {i for i, _ in ranked_part}
    # an element already in the view is not its own candidate
    assert "Gear-2" not in {i for i, _ in identify(parts, ontology, parts.elements["Gear-2"], 0.0)}


def test_similarity_reasoner_wraps_functions(parts: SceneState, ontology: Ontology) -> None:
    reasoner = SimilarityReasoner(parts, ontology)
    assert isinstance(reasoner, Reasoner)
    assert reasoner.classify(observed_gear(), "Part", 0.9)[0][0] == "DefaultGear"
    assert reasoner.identify(parts.elements["Gear-1"])[0][0] in {"Gear-2", "Gear-10"}
    assert reasoner.compute_relations("Gear-1", "Gear-2") == frozenset()
    with pytest.raises(ValidationError):
        reasoner.get_data("Gear-1", "anything")


# --------------------------------------------------------------------------- plug-in set


class Named:
    """A minimal plug-in reasoner."""

    properties_handled = frozenset({"temperature"})
    data_codes: frozenset[str] = frozenset()
    relations_computed: frozenset[str] = frozenset()

    def __init__(self, view: SceneState, ontology: Ontology) -> None:
        self.name = "thermal"

    def get_data(self, element_id: str, code: str) -> Value:
        return None

    def compute_relations(self, subject: str, obj: str) -> frozenset[str]:
        return frozenset()


def points(*pairs: tuple[str, str]) -> list[EntryPoint]:
    return [EntryPoint(name, value, "skimesh.reasoners") for name, value in pairs]


def test_reasoner_set_loads_builtins_entry_points_and_extras(ontology: Ontology) -> None:
    here = f"{__name__}:Named"
    found = ReasonerSet.load(discover=lambda group: points(("thermal", here)))
    assert list(found) == ["similarity", "spatial", "thermal"]
    bound = found.bind(SceneState(), ontology)
    assert isinstance(bound["spatial"], SpatialReasoner)
    assert all(isinstance(r, Reasoner) for r in bound.values())
    only = ReasonerSet.load({"thermal": Named}, builtins=False, discover=lambda group: [])
    assert list(only) == ["thermal"]
    with pytest.raises(ReasonerError, match="no reasoner 'grasp'; known: thermal"):
        only["grasp"]


def test_reasoner_set_errors(ontology: Ontology) -> None:
    with pytest.raises(ReasonerError, match="failed to load"):
        ReasonerSet.load(discover=lambda group: points(("broken", "no_such_module_xyz:Thing")))
    with pytest.raises(ReasonerError, match=r"two 'skimesh\.reasoners' entry points"):
        ReasonerSet.load(discover=lambda group: points(("a", f"{__name__}:Named"), ("a", "x:Y")))
    with pytest.raises(ReasonerError, match="not callable"):
        ReasonerSet.load(discover=lambda group: points(("a", f"{__name__}:ROOT.name")))
    misnamed = ReasonerSet({"heat": Named})
    with pytest.raises(ReasonerError, match="calls itself 'thermal'"):
        misnamed.bind(SceneState(), ontology)
    not_a_reasoner = ReasonerSet({"x": lambda view, onto: object()})  # type: ignore[dict-item,return-value]
    with pytest.raises(ReasonerError, match="lacks part of the Reasoner protocol"):
        not_a_reasoner.bind(SceneState(), ontology)
