"""Reading declarations out of an rdflib graph: :class:`GraphReader` finds the declared
classes, object properties, data properties and datatypes, checks that every name is valid and
unique, and reads labels, boolean annotations, class references and super-properties.

It is the low-level half of :func:`wm_store.ontology._model.compile_graph`; every error it raises
is an OntologyError that names the entity at fault and says how to fix it.
"""

from __future__ import annotations

import re
from typing import Final

from rdflib import OWL, RDF, RDFS, XSD, BNode, Graph, URIRef
from rdflib import Literal as RdfLiteral
from rdflib.collection import Collection
from rdflib.term import Node

from wm_store._errors import OntologyError
from wm_store.ontology._literals import value_from_literal
from wm_store.ontology._terms import (
    CLASS_NAME_RE,
    NAME_RE,
    TEMPLATE_NAME_RE,
    did_you_mean,
    local_name,
)

__all__ = ["GraphReader", "read_number"]

_RESERVED: Final = (str(OWL), str(RDF), str(RDFS), str(XSD))


class GraphReader:
    """Reads one graph; every error names the entity and says how to fix it."""

    def __init__(self, graph: Graph) -> None:
        self.g = graph
        self.names: dict[str, tuple[str, URIRef]] = {}
        self.classes = self._declared("class", (OWL.Class, RDFS.Class), CLASS_NAME_RE)
        self.relations = self._declared("object property", (OWL.ObjectProperty,), NAME_RE)
        self.data_props = self._declared("data property", (OWL.DatatypeProperty,), NAME_RE)
        self.datatypes = self._declared("datatype", (RDFS.Datatype,), NAME_RE)
        self.annotations = set(self.g.subjects(RDF.type, OWL.AnnotationProperty))

    def _declared(
        self, kind: str, types: tuple[URIRef, ...], pattern: re.Pattern[str]
    ) -> dict[URIRef, str]:
        found: dict[URIRef, str] = {}
        for t in types:
            for s in self.g.subjects(RDF.type, t):
                if isinstance(s, URIRef) and not str(s).startswith(_RESERVED):
                    found[s] = self.register(s, kind, pattern)
        return found

    def register(self, iri: URIRef, kind: str, pattern: re.Pattern[str]) -> str:
        name = local_name(iri)
        if not pattern.fullmatch(name):
            rule = "a capital letter" if pattern is CLASS_NAME_RE else "a letter"
            more = ", '-'" if pattern is TEMPLATE_NAME_RE else ""
            raise OntologyError(
                f"{kind} <{iri}>: the name {name!r} must start with {rule} and contain only "
                f"letters, digits{more} and '_' (element ids are '<Type>-<n>'); rename it"
            )
        seen = self.names.get(name)
        if seen is not None and seen[1] != iri:
            raise OntologyError(
                f"the name {name!r} is used twice: {seen[0]} <{seen[1]}> and {kind} <{iri}>; "
                "names must be unique across namespaces and across classes, properties, "
                "datatypes and templates"
            )
        self.names[name] = (kind, iri)
        return name

    def text(self, s: Node, p: URIRef) -> str:
        values = [o for o in self.g.objects(s, p) if isinstance(o, RdfLiteral)]
        for want in ("en", None):
            for o in values:
                if o.language == want:
                    return str(o)
        return str(values[0]) if values else ""

    def flag(self, s: Node, p: URIRef) -> bool | None:
        """A boolean annotation: None when absent; ``true`` or the string "true" is True."""
        o = self.g.value(s, p)
        if o is None:
            return None
        value = value_from_literal(o)
        return value is True or (isinstance(value, str) and value.strip().lower() == "true")

    def class_ref(self, node: Node, where: str) -> str | None:
        if node == OWL.Thing:
            return None
        if isinstance(node, URIRef) and node in self.classes:
            return self.classes[node]
        hint = did_you_mean(local_name(str(node)), self.classes.values())
        raise OntologyError(
            f"{where}: {node} is not a declared owl:Class{hint} (or add its "
            "'rdf:type owl:Class' declaration)"
        )

    def class_set(self, s: URIRef, p: URIRef, where: str) -> frozenset[str]:
        nodes = list(self.g.objects(s, p))
        if len(nodes) > 1:
            raise OntologyError(
                f"{where} has {len(nodes)} {local_name(p)} statements (OWL reads that as an "
                "intersection); state one, using owl:unionOf for alternatives"
            )
        if not nodes:
            return frozenset()
        node = nodes[0]
        members = self.g.value(node, OWL.unionOf) if isinstance(node, BNode) else None
        if members is not None:
            refs = (self.class_ref(m, where) for m in Collection(self.g, members))
            return frozenset(r for r in refs if r is not None)
        ref = self.class_ref(node, where)
        return frozenset() if ref is None else frozenset({ref})

    def superproperties(self, s: URIRef, declared: dict[URIRef, str], where: str) -> list[str]:
        out = []
        for o in self.g.objects(s, RDFS.subPropertyOf):
            if o in (OWL.topObjectProperty, OWL.topDataProperty):
                continue
            if not isinstance(o, URIRef) or o not in declared:
                raise OntologyError(f"{where}: super-property {o} is not declared")
            out.append(declared[o])
        return sorted(out)


def read_number(node: Node | None, where: str) -> float:
    """The number in a literal (an int or float), else OntologyError at ``where``."""
    value = value_from_literal(node) if node is not None else None
    if isinstance(value, bool) or not isinstance(value, int | float):
        raise OntologyError(f"{where}: expected a number, got {node}")
    return float(value)
