"""The scene as RDF: an rdflib graph for SPARQL, Turtle export, and Turtle import as ops.

Mapping (scene namespace ``skms:`` = ``https://skimesh.dev/scene#``, ontology ``skm:``)::

    skms:<id> rdf:type skm:<Type>, owl:NamedIndividual ;
              rdfs:label "<label>" ;                      # when not empty
              skm:<property> <literal_from_value(value)> ; # "0.3 0.2 0.1"^^skm:SizeCuboid …
              skm:<relation> skms:<object id> .

With ``metadata=True`` (the default for :func:`scene_graph`, which SPARQL queries) each element
also carries ``skm:rev`` (xsd:integer, the revision that last changed it) and ``skm:updatedAt``
(xsd:dateTime), and each observation becomes a node::

    skms:<id> skm:observation [ a skm:Observation ; skm:ofProperty skm:<property> ;
        skm:value <literal> ; skm:source "<source>" ; skm:stamp <xsd:double> ;
        skm:confidence <xsd:double> ] .

Turtle files (:func:`export_turtle`) leave that metadata out by default: revisions and
observations belong to one store's history, not to a scene description; :func:`import_turtle`
ignores them if present. An exported file opens in Protégé (its header imports the skimesh
ontology IRI).

:func:`import_turtle` turns a Turtle scene — exported here, or written in Protégé with
individuals of any IRI — into transaction ops (:data:`~wm_store.protocol.Op`); apply them with
:func:`wm_store.transactions.apply_transaction` or send them in a ``Transact`` request.
Everything here is pure and synchronous; cost is linear in the scene and dominated by rdflib
(see :mod:`wm_store.sparql` for measured times).
"""

from __future__ import annotations

import io
import warnings
from collections.abc import Iterable, Iterator, Mapping
from datetime import UTC, datetime

import msgspec
from rdflib import BNode, Graph, Literal, Namespace, URIRef
from rdflib.namespace import DC, DCTERMS, OWL, RDF, RDFS, SKOS, XSD
from rdflib.plugins.serializers.turtle import TurtleSerializer
from rdflib.term import Node

from .errors import (
    OntologyError,
    PropertyValueError,
    UnknownClassError,
    UnknownPropertyError,
    UnknownRelationError,
    ValidationError,
    WmError,
)
from .ontology import Ontology, literal_from_value, value_from_literal
from .protocol import (
    AddElement,
    Element,
    Frame,
    Observation,
    Op,
    Orientation,
    Pose,
    Position,
    Relation,
    Value,
)
from .query import id_sort_key
from .state import SceneState, parse_id

__all__ = [
    "METADATA_PREDICATES",
    "SCENE",
    "SCENE_IRI",
    "add_scene",
    "export_turtle",
    "import_turtle",
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

_IGNORED_NAMESPACES = (str(RDF), str(RDFS), str(OWL), str(XSD), str(DC), str(DCTERMS), str(SKOS))
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
    About 10-25 µs per triple (rdflib), 8-10 triples per element with properties."""
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
            if isinstance(subject, URIRef) and not str(subject).startswith(_IGNORED_NAMESPACES):
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


def export_turtle(state: SceneState, ontology: Ontology, *, metadata: bool = False) -> str:
    """The scene as Turtle: prefixes, an ``owl:Ontology`` header importing the skimesh
    ontology, then one block per element in subject order. Deterministic: the same state gives
    the same text. Blocks for rdflib's serializer: ~0.4 s per 1k elements."""
    g = new_graph(ontology)
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


# --------------------------------------------------------------------------- import

_NOT_INDIVIDUALS = frozenset(
    {OWL.Class, RDFS.Class, OWL.ObjectProperty, OWL.DatatypeProperty, OWL.AnnotationProperty}
    | {RDFS.Datatype, OWL.Restriction, OWL.AllDifferent, OWL.Axiom}
)


class _Individual:
    __slots__ = ("id", "iri", "label", "properties", "ref", "type")

    def __init__(self, iri: URIRef, ref: str) -> None:
        self.iri, self.ref = iri, ref
        self.type = self.label = self.id = ""
        self.properties: dict[str, Value] = {}


def import_turtle(
    text: str, ontology: Ontology, *, keep_ids: bool = True, state: SceneState | None = None
) -> list[Op]:
    """Transaction ops that add the individuals of a Turtle scene.

    Every IRI subject (but the ``owl:Ontology`` header) is an individual and becomes an
    :class:`~wm_store.protocol.AddElement`: ``ref`` is the IRI's local name (``:meal_box`` ->
    ``"meal_box"``); the type is its skimesh class (the most specific, if it names several along
    one branch); ``label`` is its ``rdfs:label``, else the local name unless that has the id
    form ``<Type>-<n>``; properties come from its data properties. With ``keep_ids``, a local
    name ``<Type>-<n>`` of its own type becomes the explicit ``id`` (an exported scene comes
    back with the same ids; the ids must be fresh in the target store).

    Poses name their frame by local name (``"... @worktop"``). An individual used as a frame
    gets an explicit id too — numbered after ``state.counters`` (the store the ops are for;
    default: an empty store) — and the frames are rewritten to it. Frames naming no individual
    of the file are kept: they must be ids of existing elements.

    A relation goes into the op of whichever end is added later, so the ops apply in order; an
    object the file does not describe is an existing element, its local name taken as its id.
    Ops come parents first along the spatial tree, siblings in natural name order: the same
    text always gives the same ops. Ignored: annotations (``rdfs:comment``, ``owl:``, Dublin
    Core, SKOS), blank-node subjects, and ``skm:rev`` / ``skm:updatedAt`` / ``skm:observation``.

    Raises ``ValidationError`` for text that is not Turtle (rdflib's message and line), a
    property given twice or a literal/individual in the wrong place; ``UnknownClassError`` /
    ``UnknownRelationError`` / ``UnknownPropertyError`` (with suggestions) for unknown names;
    ``OntologyError`` naming an individual without exactly one most specific skimesh class, or a
    subject that declares a class or property (extend the ontology with ``Ontology.load``);
    ``PropertyValueError`` for a malformed value. Pure; blocks ~0.5 s per 1k individuals
    (mostly rdflib's Turtle parser).
    """
    counters = state.counters if state is not None else {}
    return _Importer(_parse(text), ontology).ops(keep_ids, counters)


def _parse(text: str) -> Graph:
    graph = Graph(bind_namespaces="core")
    # rdflib reports a weird boolean lexical form with warnings.warn; make it an error here
    # instead of a process-wide warning (record=True keeps it local to this block).
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        try:
            graph.parse(data=text, format="turtle")
        except Exception as exc:  # rdflib raises BadSyntax and a few plain exceptions
            raise ValidationError(f"not valid Turtle: {_syntax_message(exc)}") from None
    if caught:
        raise PropertyValueError(f"malformed literal in the Turtle: {caught[0].message}")
    return graph


def _syntax_message(exc: Exception) -> str:
    lines, message = getattr(exc, "lines", None), getattr(exc, "message", None)
    if isinstance(lines, int) and message:
        return f"line {lines + 1}: {message}"
    return str(exc)


class _Importer:
    def __init__(self, graph: Graph, ontology: Ontology) -> None:
        self.graph, self.ontology = graph, ontology
        self.skm = str(ontology.namespace)
        self.names = {iri: name for name, iri in vocabulary(ontology).items()}
        self.individuals: dict[URIRef, _Individual] = {}
        self.relations: list[Relation] = []

    def ops(self, keep_ids: bool, counters: Mapping[str, int]) -> list[Op]:
        by_ref: dict[str, URIRef] = {}
        for subject in sorted({s for s in self.graph.subjects() if isinstance(s, URIRef)}):
            types = set(self.graph.objects(subject, RDF.type))
            if OWL.Ontology in types:
                continue
            if types & _NOT_INDIVIDUALS:
                raise OntologyError(
                    f"{self.show(subject)} declares a class or property; a scene file holds "
                    "individuals only (load ontology extensions with Ontology.load)"
                )
            ref = local_name(subject)
            if ref in by_ref:
                raise ValidationError(
                    f"two individuals have the local name {ref!r}: <{by_ref[ref]}> and <{subject}>"
                )
            by_ref[ref] = subject
            self.individuals[subject] = _Individual(subject, ref)
        for ind in self.individuals.values():
            where = f"individual {self.show(ind.iri)}"
            try:
                self.read(ind, keep_ids)
            except WmError as exc:
                raise type(exc)(f"{where}: {exc}") from None
        return _ops(self.ontology, list(self.individuals.values()), self.relations, counters)

    def show(self, node: URIRef) -> str:
        return node.n3(self.graph.namespace_manager)

    def name(self, iri: URIRef, kind: str) -> str:
        """The ontology name of ``iri``; unknown ones raise the ontology's error."""
        found = self.names.get(iri)
        if found is not None:
            return found
        local = local_name(iri)
        check = {
            "class": self.ontology.check_class,
            "relation": self.ontology.relation,
            "property": self.ontology.data_property,
        }[kind]
        check(local)  # an unknown name raises with the closest known names
        raise {"class": UnknownClassError, "relation": UnknownRelationError}.get(
            kind, UnknownPropertyError
        )(f"<{iri}> is not a skimesh {kind}; did you mean <{self.skm}{local}>?")

    def read(self, ind: _Individual, keep_ids: bool) -> None:
        classes = [
            self.name(t, "class")
            for t in sorted(self.graph.objects(ind.iri, RDF.type), key=str)
            if isinstance(t, URIRef) and t not in (OWL.NamedIndividual, OWL.Thing)
        ]
        is_a = self.ontology.is_a
        specific = {c for c in classes if not any(o != c and is_a(o, c) for o in classes)}
        if len(specific) != 1:
            found = ", ".join(sorted(specific)) or "none"
            raise OntologyError(
                f"needs exactly one most specific skimesh class as rdf:type; found: {found}"
            )
        ind.type = specific.pop()
        labels = sorted(
            (o for o in self.graph.objects(ind.iri, RDFS.label) if isinstance(o, Literal)),
            key=lambda o: (o.language or "", str(o)),
        )
        parsed = parse_id(ind.ref)
        ind.label = str(labels[0]) if labels else ("" if parsed else ind.ref)
        if keep_ids and parsed is not None and parsed[0] == ind.type:
            ind.id = ind.ref
        for predicate, obj in sorted(self.graph.predicate_objects(ind.iri)):
            if isinstance(predicate, URIRef) and not str(predicate).startswith(_IGNORED_NAMESPACES):
                self.statement(ind, predicate, obj)

    def statement(self, ind: _Individual, predicate: URIRef, obj: Node) -> None:
        if predicate.startswith(self.skm) and local_name(predicate) in METADATA_PREDICATES:
            return
        if isinstance(obj, Literal):
            if predicate in self.names and self.names[predicate] in self.ontology.relations:
                raise ValidationError(f"relation {self.show(predicate)} takes an individual")
            name = self.name(predicate, "property")
            if name in ind.properties:
                raise ValidationError(f"property {name!r} has two values; keep one")
            ind.properties[name] = value_from_literal(obj)
        elif isinstance(obj, URIRef):
            if self.names.get(predicate) in self.ontology.data_properties:
                raise ValidationError(f"{self.show(predicate)} is a data property: give a literal")
            name = self.name(predicate, "relation")
            target = self.individuals.get(obj)
            self.relations.append(
                Relation(ind.ref, name, target.ref if target else local_name(obj))
            )
        else:
            raise ValidationError(f"{self.show(predicate)} has a blank node; name the individual")


def _spatial_order(
    ontology: Ontology, by_ref: Mapping[str, _Individual], relations: list[Relation]
) -> list[str]:
    """Refs parents first along the spatial tree (depth first), siblings in natural order."""
    children: dict[str, list[str]] = {}
    for rel in relations:
        if rel.object in by_ref and ontology.relation(rel.predicate).spatial:
            children.setdefault(rel.subject, []).append(rel.object)
    has_parent = {child for kids in children.values() for child in kids}
    order: list[str] = []
    placed: set[str] = set()
    roots = sorted((r for r in by_ref if r not in has_parent), key=id_sort_key, reverse=True)
    rest = sorted(by_ref, key=id_sort_key, reverse=True)
    for stack in (roots, rest):  # `rest` only matters for spatial cycles (refused on apply)
        while stack:
            ref = stack.pop()
            if ref not in placed:
                placed.add(ref)
                order.append(ref)
                stack.extend(sorted(children.get(ref, ()), key=id_sort_key, reverse=True))
    return order


def _frames(value: Value) -> Iterator[str]:
    match value:
        case Pose(position=p, orientation=o, frame=f):
            yield from (f, p.frame, o.frame)
        case Position(frame=f) | Orientation(frame=f) | Frame(frame=f):
            yield f
        case list():
            for item in value:
                yield from _frames(item)


def _reframe(value: Value, ids: Mapping[str, str]) -> Value:
    """``value`` with frame references to file individuals replaced by their ids."""
    match value:
        case Pose(position=p, orientation=o, frame=f):
            return Pose(_reframe(p, ids), _reframe(o, ids), ids.get(f, f))  # type: ignore[arg-type]
        case Position(frame=f) | Orientation(frame=f) | Frame(frame=f):
            return msgspec.structs.replace(value, frame=ids.get(f, f))
        case list():
            return [_reframe(item, ids) for item in value]  # type: ignore[misc]
    return value


def _ops(
    ontology: Ontology,
    individuals: list[_Individual],
    relations: list[Relation],
    counters: Mapping[str, int],
) -> list[Op]:
    """AddElement ops; each relation in the op of its later end. Individuals that poses use as
    frames get explicit ids (numbered after ``counters``) so the frames can name them.

    Order: elements with explicit ids first — per type in increasing number, as the store
    requires (an explicit id must be above every id of its type used so far) — then the others,
    whose ids the store assigns after them; both parts parents first where that allows."""
    by_ref = {ind.ref: ind for ind in individuals}
    spatial = _spatial_order(ontology, by_ref, relations)
    used = dict(counters)
    for ind in individuals:
        parsed = parse_id(ind.id)
        if parsed is not None:
            used[parsed[0]] = max(used.get(parsed[0], 0), parsed[1])
    framed = {f for ind in individuals for v in ind.properties.values() for f in _frames(v)}
    for ref in spatial:
        ind = by_ref[ref]
        if ref in framed and not ind.id:
            used[ind.type] = used.get(ind.type, 0) + 1
            ind.id = f"{ind.type}-{used[ind.type]}"
    ids = {ref: ind.id for ref, ind in by_ref.items() if ind.id}
    with_id = [ref for ref in spatial if by_ref[ref].id]
    slots: dict[str, list[int]] = {}
    for slot, ref in enumerate(with_id):
        slots.setdefault(by_ref[ref].type, []).append(slot)
    for slot_list in slots.values():  # same slots, ids ascending within each type
        ascending = sorted((with_id[i] for i in slot_list), key=lambda r: id_sort_key(ids[r]))
        for slot, ref in zip(slot_list, ascending, strict=True):
            with_id[slot] = ref
    order = with_id + [ref for ref in spatial if not by_ref[ref].id]
    position = {ref: i for i, ref in enumerate(order)}
    attached: dict[str, list[Relation]] = {ref: [] for ref in order}
    for rel in sorted(set(relations), key=lambda r: (r.subject, r.predicate, r.object)):
        later = rel.subject
        if position.get(rel.object, -1) > position[rel.subject]:
            later = rel.object
        attached[later].append(rel)
    return [
        AddElement(
            type=by_ref[ref].type,
            label=by_ref[ref].label,
            properties={k: _reframe(v, ids) for k, v in sorted(by_ref[ref].properties.items())},
            relations=attached[ref],
            ref=ref,
            id=by_ref[ref].id,
        )
        for ref in order
    ]
