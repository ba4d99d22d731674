"""Teaching the ontology while the system runs: the Turtle side (rdflib). Replaying what was
taught is :mod:`wm_store.ontology._replay`.

- :func:`parse_terms` reads a Turtle text into a graph (pure; safe in a worker thread), with an
  error that names the source;
- :func:`relation_turtle` / :func:`property_turtle` write the Turtle of one relation or data
  property, for ``skimesh wm define-relation`` / ``define-property`` and the client API;
- :func:`core_text`: the core file's text.
"""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path
from typing import Final

from rdflib import BNode, Graph
from rdflib.compare import isomorphic

from wm_store._errors import OntologyError
from wm_store.ontology._terms import ALL_KINDS, CLASS_NAME_RE, NAME_RE

__all__ = [
    "MAX_TERMS_BYTES",
    "core_text",
    "parse_terms",
    "property_turtle",
    "relation_turtle",
    "without_known_blank_nodes",
]

MAX_TERMS_BYTES: Final = 1 << 20
"""The largest Turtle text one :class:`~wm_store.protocol.DefineTerms` may carry (1 MiB)."""

_PREFIXES: Final = (
    "@prefix skm: <https://skimesh.dev/ontology#> .\n"
    "@prefix owl: <http://www.w3.org/2002/07/owl#> .\n"
    "@prefix rdf: <http://www.w3.org/1999/02/22-rdf-syntax-ns#> .\n"
    "@prefix rdfs: <http://www.w3.org/2000/01/rdf-schema#> .\n"
    "@prefix xsd: <http://www.w3.org/2001/XMLSchema#> .\n"
)

_XSD_OF_KIND: Final = {
    "float": "xsd:double",
    "int": "xsd:integer",
    "bool": "xsd:boolean",
    "string": "xsd:string",
}


def core_text(path: Path) -> str:
    """The core ontology file's text."""
    return path.read_text(encoding="utf-8")


def parse_terms(turtle: str, source: str = "") -> Graph:
    """Parse taught terms; OntologyError names the source and what rdflib found wrong."""
    where = f" from {source}" if source else ""
    if len(turtle.encode()) > MAX_TERMS_BYTES:
        raise OntologyError(
            f"the terms{where} are {len(turtle.encode())} bytes, over the limit of "
            f"{MAX_TERMS_BYTES}; teach them in several parts"
        )
    graph = Graph()
    try:
        graph.parse(data=turtle, format="turtle")
    except Exception as exc:  # rdflib raises many types; all mean "bad Turtle"
        raise OntologyError(f"cannot parse the terms{where} as Turtle: {exc}") from exc
    return graph


def _subtree(graph: Graph, node: BNode) -> Graph:
    out, todo, seen = Graph(), [node], set()
    while todo:
        current = todo.pop()
        if current in seen:
            continue
        seen.add(current)
        for triple in graph.triples((current, None, None)):
            out.add(triple)
            if isinstance(triple[2], BNode):
                todo.append(triple[2])
    return out


def without_known_blank_nodes(parsed: Graph, known: Graph) -> Graph:
    """``parsed`` less the blank-node structures ``known`` already states for the same subject
    and predicate (a union range, a restriction): re-teaching a file, or a copy of the core,
    must not state them twice, which OWL would read as an intersection."""
    drop: list[BNode] = []
    for s, p, o in list(parsed):
        if not isinstance(o, BNode) or isinstance(s, BNode):
            continue
        mine = _subtree(parsed, o)
        if any(
            isinstance(k, BNode) and isomorphic(_subtree(known, k), mine)
            for k in known.objects(s, p)
        ):
            drop.append(o)
            parsed.remove((s, p, o))
    for node in drop:
        for triple in _subtree(parsed, node):
            parsed.remove(triple)
    return parsed


def _check_name(name: str, what: str) -> None:
    if not NAME_RE.fullmatch(name) or CLASS_NAME_RE.fullmatch(name):
        raise OntologyError(
            f"cannot define {what} {name!r}: a {what} name starts with a lower-case letter and "
            "has only letters, digits and '_' (e.g. 'inspectedBy')"
        )


def _class_list(classes: Sequence[str]) -> str:
    if len(classes) == 1:
        return f"skm:{classes[0]}"
    members = " ".join(f"skm:{c}" for c in classes)
    return f"[ rdf:type owl:Class ; owl:unionOf ( {members} ) ]"


def _text(value: str) -> str:
    return '"' + value.replace("\\", "\\\\").replace('"', '\\"').replace("\n", "\\n") + '"@en'


def _statement(lines: list[str], label: str, comment: str) -> str:
    """One subject's Turtle: ``lines`` (predicate-object pairs) plus label and comment."""
    if label:
        lines.append(f"rdfs:label {_text(label)}")
    if comment:
        lines.append(f"rdfs:comment {_text(comment)}")
    return _PREFIXES + " ;\n    ".join(lines) + " .\n"


def relation_turtle(
    name: str,
    *,
    domain: Sequence[str] = (),
    range: Sequence[str] = (),
    parent: str = "",
    label: str = "",
    comment: str = "",
) -> str:
    """The Turtle of one relation (object property) between classes ``domain`` and ``range``
    (several: their union); ``parent``: a super-relation (``spatialRelation`` makes it
    spatial)."""
    _check_name(name, "relation")
    lines = [f"skm:{name} rdf:type owl:ObjectProperty"]
    if parent:
        lines.append(f"rdfs:subPropertyOf skm:{parent}")
    if domain:
        lines.append(f"rdfs:domain {_class_list(domain)}")
    if range:
        lines.append(f"rdfs:range {_class_list(range)}")
    return _statement(lines, label, comment)


def property_turtle(
    name: str,
    *,
    kind: str,
    domain: Sequence[str] = (),
    minimum: float | None = None,
    maximum: float | None = None,
    label: str = "",
    comment: str = "",
) -> str:
    """The Turtle of one data property of value ``kind`` (``float``, ``int``, ``bool``,
    ``string`` or a typed kind such as ``Pose``) on ``domain``, optionally bounded."""
    _check_name(name, "data property")
    if kind not in ALL_KINDS or kind == "list":
        known = ", ".join(sorted(k for k in ALL_KINDS if k != "list"))
        raise OntologyError(
            f"cannot define data property {name!r}: unknown kind {kind!r}; one of {known}"
        )
    bounded = minimum is not None or maximum is not None
    if bounded and kind not in ("float", "int"):
        raise OntologyError(
            f"cannot define data property {name!r}: bounds need kind float or int, not {kind}"
        )
    lines = [f"skm:{name} rdf:type owl:DatatypeProperty"]
    if domain:
        lines.append(f"rdfs:domain {_class_list(domain)}")
    xsd = _XSD_OF_KIND.get(kind, f"skm:{kind}")
    if bounded:
        facets = []
        if minimum is not None:
            facets.append(f'[ xsd:minInclusive "{float(minimum)!r}"^^xsd:double ]')
        if maximum is not None:
            facets.append(f'[ xsd:maxInclusive "{float(maximum)!r}"^^xsd:double ]')
        lines.append(
            f"rdfs:range [ rdf:type rdfs:Datatype ; owl:onDatatype {xsd} ; "
            f"owl:withRestrictions ( {' '.join(facets)} ) ]"
        )
    else:
        lines.append(f"rdfs:range {xsd}")
    lines.append(f'skm:valueKind "{kind}"')
    return _statement(lines, label, comment)
