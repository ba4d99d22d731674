"""The scene as RDF: an rdflib graph for SPARQL, Turtle export, Turtle import as ops, and
read-only SPARQL over ontology + scene (:class:`SparqlEngine`).

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
:func:`wm_store.scene.apply_transaction` or send them in a ``Transact`` request.
Everything but :class:`SparqlEngine` is pure and synchronous; cost is linear in the scene and
dominated by rdflib (see docs/benchmarks.md, section "World model").

Inside: ``_graph`` (the mapping and the export), ``_turtle_import``, ``_sparql`` (the engine:
graph cache and threads), ``_sparql_eval`` (one query: checks, bindings, rows) and ``_worker``
(:class:`SparqlWorker`: the store's queries in a child process, with limits on text, time,
rows and queue).
"""

from ._graph import METADATA_PREDICATES as METADATA_PREDICATES
from ._graph import SCENE as SCENE
from ._graph import SCENE_IRI as SCENE_IRI
from ._graph import export_turtle as export_turtle
from ._graph import scene_graph as scene_graph
from ._sparql import SparqlEngine as SparqlEngine
from ._sparql import build_graph as build_graph
from ._turtle_import import import_turtle as import_turtle
from ._worker import SparqlWorker as SparqlWorker

__all__ = [
    "METADATA_PREDICATES",
    "SCENE",
    "SCENE_IRI",
    "SparqlEngine",
    "SparqlWorker",
    "build_graph",
    "export_turtle",
    "import_turtle",
    "scene_graph",
]
