"""The compiler that reads an rdflib graph once into plain declarations, and the pieces
:mod:`wm_store.ontology` is built from.

Nothing walks the graph after loading: :func:`compile_graph` turns OWL/Turtle into
:class:`Declarations` (dicts of frozen structs), and :class:`wm_store.ontology.Ontology`
precomputes its closures from those. Classes, cardinality restrictions and templates (default
individuals) are read here; the rest lives in these modules::

    _terms        namespace, value kinds, name rules, message helpers, info structs
    _literals     protocol values as RDF literals, checks inside typed values
    _reader       declared names and annotations of a graph (GraphReader)
    _properties   object and data property declarations, ranges, resolution
"""

from __future__ import annotations

from typing import Final

from rdflib import OWL, RDF, RDFS, BNode, Graph, URIRef

from wm_store._errors import OntologyError, PropertyValueError
from wm_store.ontology._literals import (
    SKM,
    value_from_literal,
)
from wm_store.ontology._properties import read_data_property, read_relations
from wm_store.ontology._reader import GraphReader, read_number
from wm_store.ontology._terms import (
    TEMPLATE_NAME_RE,
    CardinalityRestriction,
    ClassInfo,
    Declarations,
)
from wm_store.protocol import TemplateDef, Value

__all__ = ["compile_graph"]

# --------------------------------------------------------------------------- graph compiler

_CARDINALITY: Final = {
    OWL.maxCardinality: (False, True),
    OWL.minCardinality: (True, False),
    OWL.cardinality: (True, True),
    OWL.maxQualifiedCardinality: (False, True),
    OWL.minQualifiedCardinality: (True, False),
    OWL.qualifiedCardinality: (True, True),
}


def _read_restrictions(r: GraphReader) -> list[CardinalityRestriction]:
    out = []
    for iri, cls in r.classes.items():
        for node in r.g.objects(iri, RDFS.subClassOf):
            if not isinstance(node, BNode) or (node, RDF.type, OWL.Restriction) not in r.g:
                continue
            where = f"restriction on class '{cls}'"
            prop = r.g.value(node, OWL.onProperty)
            if prop in r.data_props:
                continue  # data properties hold one value per element anyway
            if not isinstance(prop, URIRef) or prop not in r.relations:
                raise OntologyError(f"{where}: owl:onProperty {prop} is not a declared relation")
            on_node = r.g.value(node, OWL.onClass)
            on_class = r.class_ref(on_node, where) if on_node is not None else None
            lo: int | None = None
            hi: int | None = None
            some = r.g.value(node, OWL.someValuesFrom)
            if some is not None:  # "hasA some Arm" is "hasA min 1 Arm"
                on_class, lo, hi = r.class_ref(some, where), 1, None
            else:
                for p, (is_min, is_max) in _CARDINALITY.items():
                    o = r.g.value(node, p)
                    if o is not None:
                        n = int(read_number(o, where))
                        lo, hi = (n if is_min else lo), (n if is_max else hi)
                if lo is None and hi is None:
                    continue  # allValuesFrom, hasValue...: not enforced
            rel = r.relations[prop]
            out.append(
                CardinalityRestriction(
                    declared_on=cls, relation=rel, minimum=lo, maximum=hi, on_class=on_class
                )
            )
    return out


def _read_templates(r: GraphReader) -> dict[str, TemplateDef]:
    skip = {RDF.type, RDFS.label, RDFS.comment, SKM.template, *r.annotations}
    out: dict[str, TemplateDef] = {}
    for s in r.g.subjects(SKM.template, None):
        if not isinstance(s, URIRef) or not r.flag(s, SKM.template):
            continue
        name = r.register(s, "template", TEMPLATE_NAME_RE)
        where = f"template '{name}'"
        types = sorted(
            r.classes[t]
            for t in r.g.objects(s, RDF.type)
            if isinstance(t, URIRef) and t in r.classes
        )
        if len(types) != 1:
            raise OntologyError(f"{where} must have exactly one class as rdf:type, has {types}")
        props: dict[str, Value] = {}
        for p, o in r.g.predicate_objects(s):
            if not isinstance(p, URIRef) or p in skip:
                continue
            if p in r.relations:
                raise OntologyError(f"{where}: templates carry data properties, not relations")
            if p not in r.data_props:
                if str(p).startswith((str(SKM), str(s)[: len(s) - len(name)])):
                    raise OntologyError(
                        f"{where}: {p} is not a declared data property (a typo?); "
                        f"data properties: {sorted(r.data_props.values())}"
                    )
                continue  # foreign annotations (dc:creator, ...) are not ours to read
            key = r.data_props[p]
            if key in props:
                raise OntologyError(f"{where}: '{key}' has two values; give one")
            try:
                props[key] = value_from_literal(o)
            except PropertyValueError as exc:
                raise OntologyError(f"{where}, property '{key}': {exc}") from None
        out[name] = TemplateDef(
            name=name, type=types[0], label=r.text(s, RDFS.label), properties=props
        )
    return out


def compile_graph(graph: Graph) -> Declarations:
    """Read classes, relations, data properties, cardinalities and templates from ``graph``.

    Raises OntologyError naming the entity at fault (undeclared parent, bad name, unsupported
    range, duplicate name, ...)."""
    r = GraphReader(graph)
    classes: dict[str, ClassInfo] = {}
    for iri, name in r.classes.items():
        parents = (
            r.class_ref(o, f"class '{name}'")
            for o in graph.objects(iri, RDFS.subClassOf)
            if isinstance(o, URIRef)
        )
        classes[name] = ClassInfo(
            name=name,
            parents=tuple(sorted(p for p in parents if p is not None)),
            label=r.text(iri, RDFS.label),
            comment=r.text(iri, RDFS.comment),
        )
    return Declarations(
        classes=classes,
        relations=read_relations(r),
        data_properties={n: read_data_property(r, i, n) for i, n in r.data_props.items()},
        restrictions=tuple(_read_restrictions(r)),
        templates=_read_templates(r),
        datatypes=frozenset(r.datatypes.values()),
        iris={name: str(iri) for name, (_, iri) in r.names.items()},
    )
