"""Turtle import: a Turtle scene, exported by :func:`~wm_store.rdf.export_turtle` or written in
Protégé with individuals of any IRI, turned into transaction ops (:data:`~wm_store.protocol.Op`).

Individuals become elements; ids of the form ``<Type>-<n>`` are kept (``keep_ids``), and
individuals used as pose frames get explicit ids numbered after the store's counters. Store
metadata (``skm:rev``, ``skm:updatedAt``, observations) is ignored. Pure and synchronous.
"""

from __future__ import annotations

import warnings
from collections.abc import Iterator, Mapping

import msgspec
from rdflib import BNode, Graph, Literal, URIRef
from rdflib.namespace import OWL, RDF, RDFS
from rdflib.term import Node

from wm_store._errors import (
    OntologyError,
    PropertyValueError,
    UnknownClassError,
    UnknownPropertyError,
    UnknownRelationError,
    ValidationError,
    WmError,
)
from wm_store.ontology import Ontology, value_from_literal
from wm_store.protocol import (
    AddElement,
    DefineTerms,
    Frame,
    Op,
    Orientation,
    Pose,
    Position,
    Relation,
    TermsDef,
    Value,
)
from wm_store.rdf._graph import IGNORED_NAMESPACES, METADATA_PREDICATES, local_name, vocabulary
from wm_store.scene import SceneState, id_sort_key, parse_id

__all__ = ["import_turtle"]

_TEMPLATE = URIRef("https://skimesh.dev/ontology#template")
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
    """Transaction ops that add the individuals of a Turtle scene, after a
    :class:`~wm_store.protocol.DefineTerms` of the ontology terms the file declares (classes,
    properties, restrictions, templates, as :func:`~wm_store.rdf.export_turtle` writes them or
    Protégé saves them): an exported site imports whole.

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
    ``OntologyError`` naming an individual without exactly one most specific skimesh class, or
    terms that do not fit the ontology;
    ``PropertyValueError`` for a malformed value. Pure; blocks for a time linear in the
    individuals, mostly rdflib's Turtle parser (see docs/benchmarks.md, section "World model").
    """
    graph = _parse(text)
    ops: list[Op] = []
    terms = _split_terms(graph)
    if len(terms):
        ontology = ontology.teach(terms, source="the imported file")
        turtle = terms.serialize(format="turtle")
        ops.append(DefineTerms(terms=TermsDef(turtle=turtle, source="import")))
    counters = state.counters if state is not None else {}
    return ops + _Importer(graph, ontology).ops(keep_ids, counters)


def _split_terms(graph: Graph) -> Graph:
    """Move the ontology terms out of ``graph`` (declared classes and properties, templates,
    with the blank nodes they use) into a graph of their own."""
    terms = Graph()
    for prefix, ns in graph.namespaces():
        terms.bind(prefix, ns)
    todo: list[Node] = [
        s
        for s in set(graph.subjects())
        if isinstance(s, URIRef)
        and (
            set(graph.objects(s, RDF.type)) & _NOT_INDIVIDUALS
            or any(value_from_literal(o) is True for o in graph.objects(s, _TEMPLATE))
        )
    ]
    seen: set[Node] = set()
    while todo:
        subject = todo.pop()
        if subject in seen:
            continue
        seen.add(subject)
        for triple in list(graph.triples((subject, None, None))):
            terms.add(triple)
            graph.remove(triple)
            if isinstance(triple[2], BNode):
                todo.append(triple[2])
    return terms


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
            if isinstance(predicate, URIRef) and not str(predicate).startswith(IGNORED_NAMESPACES):
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
