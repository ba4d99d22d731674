"""The rdflib side of :class:`~wm_store.ontology.Ontology`: parsing its sources into one graph,
and the graph of what :meth:`~wm_store.ontology.Ontology.extend` added. Imported on first use,
so an ontology decoded from its compiled form (:meth:`Ontology.from_compiled`) runs without
rdflib."""

from __future__ import annotations

from collections.abc import Iterable, Mapping
from pathlib import Path
from typing import Final

from rdflib import OWL, RDF, RDFS, XSD, Graph, URIRef
from rdflib import Literal as RdfLiteral
from rdflib.util import guess_format

from wm_store._errors import OntologyError
from wm_store.ontology._literals import SKM, literal_from_value
from wm_store.ontology._terms import ClassInfo
from wm_store.protocol import ClassDef, TemplateDef

__all__ = ["bound_graph", "extension_graph", "parse_sources"]

_FILE_SUFFIXES: Final = (".ttl", ".owl", ".rdf", ".xml", ".nt", ".n3", ".jsonld")


def bound_graph(*graphs: Graph) -> Graph:
    """A new graph with the usual prefixes bound (those of the first of ``graphs`` when
    given), holding the triples of ``graphs``."""
    out = Graph()
    prefixes = graphs[0].namespaces() if graphs else ()
    for prefix, ns in (("skm", SKM), ("owl", OWL), ("rdfs", RDFS), ("xsd", XSD), *prefixes):
        out.bind(prefix, ns)
    for g in graphs:
        out += g
    return out


def _parse_into(graph: Graph, source: Path | str) -> None:
    if isinstance(source, str) and not (
        "\n" not in source and (source.endswith(_FILE_SUFFIXES) or Path(source).is_file())
    ):
        try:
            graph.parse(data=source, format="turtle")
        except Exception as exc:  # rdflib raises many types; all mean "bad Turtle"
            raise OntologyError(f"cannot parse the Turtle text: {exc}") from exc
        return
    path = Path(source)
    if not path.is_file():
        raise OntologyError(f"ontology file {path} does not exist")
    try:
        graph.parse(path, format=guess_format(str(path)) or "turtle")
    except Exception as exc:
        raise OntologyError(f"cannot parse {path}: {exc}") from exc


def _read(source: Path | str) -> str:
    """The text of a source (a Turtle text is itself); a file not in Turtle is marked by a
    leading NUL, so :meth:`Ontology.core_turtle` serializes its graph instead."""
    if isinstance(source, str) and ("\n" in source or not Path(source).is_file()):
        return source
    path = Path(source)
    text = path.read_text(encoding="utf-8", errors="replace")
    return text if (guess_format(str(path)) or "turtle") == "turtle" else "\0" + text


def parse_sources(sources: Iterable[Path | str]) -> tuple[Graph, tuple[str, ...]]:
    """Files (Turtle, RDF/XML ``.owl``, ...) and Turtle texts parsed into one graph, and the
    texts they were read from. Raises OntologyError saying what is wrong and where."""
    graph = bound_graph()
    texts = []
    for source in sources:
        _parse_into(graph, source)
        texts.append(_read(source))
    return graph, tuple(texts)


def extension_graph(
    ontology_iri: str,
    added_classes: Iterable[ClassDef],
    added_templates: Iterable[TemplateDef],
    classes: Mapping[str, ClassInfo],
    iris: Mapping[str, str],
) -> Graph:
    """The graph of classes and templates added at run time, an ontology importing
    ``ontology_iri``; ``classes`` and ``iris`` are the ontology's, to label and link them."""

    def iri_of(name: str) -> URIRef:
        return URIRef(iris.get(name, SKM[name]))

    g = Graph()
    g.bind("skm", SKM)
    g.bind("owl", OWL)
    head = URIRef(f"{ontology_iri}/runtime-extension")
    g.add((head, RDF.type, OWL.Ontology))
    g.add((head, OWL.imports, URIRef(ontology_iri)))
    for c in added_classes:
        iri, info = SKM[c.name], classes[c.name]
        g.add((iri, RDF.type, OWL.Class))
        g.add((iri, RDFS.subClassOf, iri_of(c.parent)))
        g.add((iri, RDFS.label, RdfLiteral(info.label, lang="en")))
        if c.comment:
            g.add((iri, RDFS.comment, RdfLiteral(c.comment, lang="en")))
    for t in added_templates:
        iri = SKM[t.name]
        g.add((iri, RDF.type, OWL.NamedIndividual))
        g.add((iri, RDF.type, iri_of(t.type)))
        g.add((iri, SKM.template, RdfLiteral(True)))
        if t.label:
            g.add((iri, RDFS.label, RdfLiteral(t.label, lang="en")))
        for key, value in t.properties.items():
            g.add((iri, iri_of(key), literal_from_value(value)))
    return g
