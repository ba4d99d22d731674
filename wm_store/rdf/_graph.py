"""The scene as an rdflib graph (the mapping in :mod:`wm_store.rdf`) and its Turtle export."""

from __future__ import annotations

import io
from collections.abc import Iterable
from datetime import UTC, datetime

from rdflib import BNode, Graph, Literal, Namespace, URIRef
from rdflib.namespace import DC, DCTERMS, OWL, RDF, RDFS, SKOS, XSD
from rdflib.plugins.serializers.turtle import TurtleSerializer
from rdflib.term import Node

from wm_store.ontology import Ontology, literal_from_value
from wm_store.protocol import (
    Element,
    Observation,
    Relation,
)
from wm_store.scene import SceneState

__all__ = [
    "METADATA_PREDICATES",
    "SCENE",
    "SCENE_IRI",
    "add_scene",
    "export_turtle",
    "local_name",
    "new_graph",
    "scene_graph",
    "vocabulary",
]

SCENE_IRI = "https://skimesh.dev/scene"
SCENE = Namespace(SCENE_IRI + "#")
"""Namespace of scene elements: ``skms:Box-1``."""

METADATA_PREDICATES = frozenset({"rev", "updatedAt", "observation"})
"""``skm:`` predicates that carry store metadata, not element properties."""

IGNORED_NAMESPACES = (str(RDF), str(RDFS), str(OWL), str(XSD), str(DC), str(DCTERMS), str(SKOS))
"""Predicates from these namespaces are annotations (comments, see-also…), not element data."""


def local_name(iri: str) -> str:
    """The part of an IRI after its last ``#`` (or, without one, its last ``/``)."""
    return iri.rpartition("#")[2] if "#" in iri else iri.rpartition("/")[2]


def new_graph(ontology: Ontology) -> Graph:
    """An empty graph with the prefixes ``skm``, ``skms``, ``rdf``, ``rdfs``, ``owl``, ``xsd``."""
    graph = Graph(bind_namespaces="core")
    graph.bind("skm", ontology.namespace)
    graph.bind("skms", SCENE)
    return graph


def scene_graph(
    state: SceneState, ontology: Ontology, *, metadata: bool = True, graph: Graph | None = None
) -> Graph:
    """The scene of ``state`` as RDF (mapping in the module docstring), added to ``graph``
    (a new one by default). Linear in elements + properties + relations; pure."""
    g = new_graph(ontology) if graph is None else graph
    add_scene(g, ontology, state.elements.values(), state.match_relations(), metadata=metadata)
    return g


def add_scene(
    graph: Graph,
    ontology: Ontology,
    elements: Iterable[Element],
    relations: Iterable[Relation],
    *,
    metadata: bool = True,
) -> None:
    """Add the triples of these elements and relations to ``graph`` (see :func:`scene_graph`).
    Linear in the triples (rdflib; 8-10 per element with properties); see docs/benchmarks.md,
    section "World model"."""
    skm = ontology.namespace
    iris = vocabulary(ontology)

    def iri(name: str) -> URIRef:
        return iris.get(name) or skm[name]

    add = graph.add
    rev_p, updated_p = skm["rev"], skm["updatedAt"]
    for element in elements:
        node = SCENE[element.id]
        add((node, RDF.type, iri(element.type)))
        add((node, RDF.type, OWL.NamedIndividual))
        if element.label:
            add((node, RDFS.label, Literal(element.label)))
        for name, value in element.properties.items():
            if value is not None:
                add((node, iri(name), literal_from_value(value)))
        if metadata:
            add((node, rev_p, Literal(element.rev)))
            add((node, updated_p, Literal(datetime.fromtimestamp(element.updated_at, UTC))))
            for name, observations in element.observations.items():
                for observation in observations:
                    _add_observation(graph, ontology, node, iri(name), observation)
    for rel in relations:
        add((SCENE[rel.subject], iri(rel.predicate), SCENE[rel.object]))


def vocabulary(ontology: Ontology) -> dict[str, URIRef]:
    """Name -> IRI of every class, relation and data property the ontology declares (an
    extension file may use its own namespace). Reads the declarations, not the whole graph."""
    graph = ontology.graph
    found: dict[str, URIRef] = {}
    for kind in (OWL.Class, RDFS.Class, OWL.ObjectProperty, OWL.DatatypeProperty):
        for subject in graph.subjects(RDF.type, kind):
            if isinstance(subject, URIRef) and not str(subject).startswith(IGNORED_NAMESPACES):
                found[local_name(subject)] = subject
    return found


def _add_observation(
    g: Graph, ontology: Ontology, node: URIRef, iri: URIRef, observation: Observation
) -> None:
    skm = ontology.namespace
    obs = BNode()
    g.add((node, skm["observation"], obs))
    g.add((obs, RDF.type, skm["Observation"]))
    g.add((obs, skm["ofProperty"], iri))
    if observation.value is not None:
        g.add((obs, skm["value"], literal_from_value(observation.value)))
    g.add((obs, skm["source"], Literal(observation.source)))
    g.add((obs, skm["stamp"], Literal(observation.stamp, datatype=XSD.double)))
    g.add((obs, skm["confidence"], Literal(observation.confidence, datatype=XSD.double)))


def ontology_iri(ontology: Ontology) -> URIRef:
    """The IRI the ontology declares for itself (``owl:Ontology``), for ``owl:imports``."""
    declared = sorted(
        s for s in ontology.graph.subjects(RDF.type, OWL.Ontology) if isinstance(s, URIRef)
    )
    if declared:
        return declared[0]
    return URIRef(str(ontology.namespace).rstrip("#/"))


def export_turtle(
    state: SceneState, ontology: Ontology, *, metadata: bool = False, terms: bool = True
) -> str:
    """The scene as Turtle: prefixes, an ``owl:Ontology`` header importing the skimesh
    ontology, the terms taught to the ontology beyond its core (``terms``: classes, relations,
    properties, templates; :func:`~wm_store.rdf.import_turtle` teaches them back first), then
    one block per element in subject order. Deterministic: the same state gives the same text.
    Blocks for rdflib's serializer, linear in the scene (see docs/benchmarks.md, section
    "World model")."""
    g = new_graph(ontology)
    if terms:
        g += ontology.extension_graph()
    header = URIRef(SCENE_IRI)
    g.add((header, RDF.type, OWL.Ontology))
    g.add((header, OWL.imports, ontology_iri(ontology)))
    scene_graph(state, ontology, metadata=metadata, graph=g)
    buffer = io.BytesIO()
    _ExactTurtleSerializer(g).serialize(buffer, encoding="utf-8")
    return buffer.getvalue().decode("utf-8")


class _ExactTurtleSerializer(TurtleSerializer):
    """rdflib's Turtle writer, except that ``xsd:double`` literals keep their lexical form:
    rdflib abbreviates them with ``%e`` (7 significant digits), so ``0.123456789`` would be
    read back as ``0.1234568``. Used directly, not registered as an rdflib plug-in."""

    def label(self, node: Node, position: int) -> str:
        if isinstance(node, Literal) and node.datatype == XSD.double:
            return node.n3(self.store.namespace_manager)
        return super().label(node, position)
