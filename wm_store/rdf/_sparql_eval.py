"""One SPARQL query of :class:`~wm_store.rdf.SparqlEngine`, apart from the engine's graph
cache and threads: why a text does not prepare (:func:`prepare_error`), the safety check (no
``SERVICE``, no ``FROM``), request bindings as terms, and evaluating a prepared query into a
:class:`~wm_store.protocol.SparqlReply` whose rows are rendered as strings."""

from __future__ import annotations

import re
from collections.abc import Mapping
from typing import Any

from rdflib import BNode, Graph, Literal, Variable
from rdflib.namespace import OWL, RDF, RDFS, XSD
from rdflib.plugins.sparql.algebra import traverse
from rdflib.plugins.sparql.parser import parseUpdate
from rdflib.plugins.sparql.parserutils import CompValue
from rdflib.plugins.sparql.sparql import Query
from rdflib.term import Identifier, Node

from wm_store._errors import ValidationError
from wm_store.ontology import Ontology
from wm_store.protocol import SparqlReply
from wm_store.rdf._graph import SCENE
from wm_store.scene import SceneState

__all__ = [
    "FIXED_PREFIXES",
    "VARNAME",
    "check_safe",
    "evaluate",
    "prefixes_for",
    "prepare_error",
    "query_variables",
    "term_for",
]

VARNAME = re.compile(r"[A-Za-z_][A-Za-z0-9_]*")
FIXED_PREFIXES = {"skms": SCENE, "rdf": RDF, "rdfs": RDFS, "owl": OWL, "xsd": XSD}


def prepare_error(text: str, exc: Exception) -> ValidationError:
    try:
        parseUpdate(text)
    except Exception:
        pass
    else:
        return ValidationError(
            "SPARQL updates are not allowed: the world model is read-only through SPARQL; "
            "change it with a transaction (Transact: AddElement, UpdateElement, SetRelation...)"
        )
    line, col = getattr(exc, "lineno", None), getattr(exc, "col", None)
    if isinstance(line, int) and isinstance(col, int):
        source = getattr(exc, "line", "")
        caret = " " * (col - 1) + "^"
        return ValidationError(
            f"SPARQL syntax error at line {line}, column {col}: {getattr(exc, 'msg', exc)}\n"
            f"  {source}\n  {caret}\n"
            "(only SELECT, ASK, CONSTRUCT and DESCRIBE are accepted)"
        )
    message = str(exc)
    if "Unknown namespace prefix" in message:
        message += "; predeclared prefixes: skm, skms, rdf, rdfs, owl, xsd (or add PREFIX)"
    return ValidationError(f"SPARQL query not understood: {message}")


def check_safe(prepared: Query) -> None:
    if prepared.algebra.get("datasetClause"):
        raise ValidationError(
            "FROM / FROM NAMED are not allowed: queries run over the world model's "
            "ontology + scene graph only"
        )
    found: list[str] = []

    def visit(node: Any) -> None:
        if isinstance(node, CompValue) and node.name == "ServiceGraphPattern":
            found.append(node.name)

    traverse(prepared.algebra, visitPre=visit)
    if found:
        raise ValidationError("SERVICE is not allowed: the world model answers from its own graph")


def query_variables(prepared: Query) -> set[str]:
    names: set[str] = set()

    def visit(node: Any) -> None:
        if isinstance(node, Variable):
            names.add(str(node))

    traverse(prepared.algebra, visitPre=visit)
    return names


def prefixes_for(ontology: Ontology) -> dict[str, str]:
    return {"skm": str(ontology.namespace), **{p: str(ns) for p, ns in FIXED_PREFIXES.items()}}


def term_for(state: SceneState, ontology: Ontology, value: str) -> Identifier:
    if value in state:
        return SCENE[value]
    prefix, sep, name = value.partition(":")
    if sep and prefix == "skm" and _is_term(ontology, name):
        return ontology.namespace[name]
    return Literal(value)


def _is_term(ontology: Ontology, name: str) -> bool:
    return (
        name in ontology.classes or name in ontology.relations or name in ontology.data_properties
    )


def _render(node: Node | None, prefixes: Mapping[str, str]) -> str | None:
    if node is None:
        return None
    if isinstance(node, Literal):
        return str(node)
    if isinstance(node, BNode):
        return f"_:{node}"
    text = str(node)
    if text.startswith(_SCENE_STR):
        return text[len(_SCENE_STR) :]
    for prefix, base in prefixes.items():
        if text.startswith(base) and VARNAME.fullmatch(text[len(base) :]):
            return f"{prefix}:{text[len(base) :]}"
    return text


_SCENE_STR = str(SCENE)


def evaluate(
    graph: Graph,
    prepared: Query,
    init: Mapping[str, Identifier],
    prefixes: Mapping[str, str],
    revision: int,
    max_rows: int,
) -> SparqlReply:
    """Run ``prepared`` on ``graph`` (thread-safe: reads only) and render the reply."""
    try:
        result = graph.query(prepared, initBindings=init)
        if result.type == "ASK":
            return SparqlReply(
                revision=revision,
                variables=["ask"],
                rows=[["true" if result.askAnswer else "false"]],
            )
        if result.type in ("CONSTRUCT", "DESCRIBE"):
            assert result.graph is not None
            triples = sorted(result.graph)
            _check_rows(len(triples), max_rows)
            rows = [[_render(t, prefixes) for t in triple] for triple in triples]
            return SparqlReply(
                revision=revision, variables=["subject", "predicate", "object"], rows=rows
            )
        variables = [str(v) for v in result.vars or ()]
        rows = []
        for row in result:
            rows.append([_render(term, prefixes) for term in row])  # type: ignore[union-attr]
            _check_rows(len(rows), max_rows)
    except ValidationError:
        raise
    except Exception as exc:  # rdflib raises plain exceptions for evaluation errors
        raise ValidationError(f"SPARQL evaluation failed: {type(exc).__name__}: {exc}") from None
    return SparqlReply(revision=revision, variables=variables, rows=rows)


def _check_rows(count: int, max_rows: int) -> None:
    if max_rows and count > max_rows:
        raise ValidationError(
            f"the query gives more than {max_rows} rows; add LIMIT or narrow the pattern"
        )
