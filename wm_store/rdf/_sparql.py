"""Read-only SPARQL over ontology + scene.

:class:`SparqlEngine` answers the ``Sparql`` request: SELECT, ASK, CONSTRUCT and DESCRIBE over
one rdflib graph holding the ontology and the scene (mapping in :mod:`wm_store.rdf`). The
prefixes ``skm:``, ``skms:``, ``rdf:``, ``rdfs:``, ``owl:`` and ``xsd:`` are predeclared.

Safety: queries are parsed with ``prepareQuery``, which knows no update forms; an update is
recognised and refused with a clear message, and so are ``SERVICE`` (rdflib would fetch a
remote endpoint) and ``FROM`` / ``FROM NAMED`` (rdflib would load files or URLs). Bindings
become ``initBindings`` terms — an existing element id binds the element's IRI, ``skm:Name`` of
a known ontology term binds that term, anything else a plain literal — so no text from a
request is ever spliced into a query (SkiROS2's string-built SPARQL).

Cost: building the graph is linear in the triples and slow (rdflib; see docs/benchmarks.md,
section "World model"), so it is done once per revision and cached until the revision or the
ontology changes (one graph is kept). :meth:`SparqlEngine.query_async` builds it in a worker
thread from a msgpack snapshot, which is all the loop pays. Queries run at rdflib's speed,
orders of magnitude slower than :func:`wm_store.scene.resolve` on the same question: hot paths
use ``resolve``, SPARQL is for ad-hoc questions.

Rows are strings: scene elements as their ids (``Box-1``), ontology and standard terms as
prefixed names (``skm:Box``), other IRIs in full, literals as their lexical form, blank nodes as
``_:id``, unbound variables as ``None``. ASK gives one column ``ask`` (``"true"``/``"false"``);
CONSTRUCT and DESCRIBE give ``subject``, ``predicate``, ``object`` rows, sorted.
"""

from __future__ import annotations

import weakref
from collections import OrderedDict
from collections.abc import Iterable, Mapping
from typing import Final

import anyio
import msgspec
from anyio import CapacityLimiter
from rdflib import Graph
from rdflib.plugins.sparql import prepareQuery
from rdflib.plugins.sparql.sparql import Query
from rdflib.term import Identifier

from meshlink.rpc import encode
from wm_store._errors import ValidationError
from wm_store.ontology import Ontology
from wm_store.protocol import Element, Relation, SparqlReply
from wm_store.rdf._graph import add_scene, new_graph
from wm_store.rdf._sparql_eval import (
    FIXED_PREFIXES,
    VARNAME,
    check_safe,
    evaluate,
    prefixes_for,
    prepare_error,
    query_variables,
    term_for,
)
from wm_store.scene import SceneState

__all__ = ["SparqlEngine", "build_graph"]


_Key = tuple[int, int, int]
"""(id of the state, its revision, id of the ontology) a cached graph was built for."""
_SceneData = tuple[list[Element], list[Relation]]
_scene_decoder: Final = msgspec.msgpack.Decoder(_SceneData)


def build_graph(
    ontology: Ontology, elements: Iterable[Element], relations: Iterable[Relation]
) -> Graph:
    """A new graph: the ontology's triples plus the scene's (with metadata). Pure; blocks for
    the whole build, linear in the triples (see docs/benchmarks.md, section "World model")."""
    graph = new_graph(ontology)
    graph += ontology.graph
    add_scene(graph, ontology, elements, relations)
    return graph


class SparqlEngine:
    """Prepared-query cache + the graph of the last (state, revision, ontology) queried.

    Call it from the task that owns the state (it is not thread-safe itself; the graphs it
    hands to worker threads are never mutated). ``max_rows`` bounds a reply (more raises
    ``ValidationError``; 0: no bound). The graph is rebuilt, lazily, whenever the state's
    revision or the ontology changed since the last query: the state must get a new revision
    with every change, as the store and the replica do.
    """

    def __init__(self, *, max_rows: int = 100_000, prepared_cache: int = 128) -> None:
        self.max_rows = max_rows
        self._prepared_cache = prepared_cache
        self._prepared: OrderedDict[tuple[str, str], Query] = OrderedDict()
        self._key: _Key | None = None
        self._graph: Graph | None = None
        self._state_ref: weakref.ref[SceneState] | None = None
        self._ontology: Ontology | None = None
        self._building: dict[_Key, anyio.Event] = {}
        self.builds = 0
        """How many graphs were built (statistics; tests use it to see the cache work)."""

    # ------------------------------------------------------------------ graph cache

    def _cache_key(self, state: SceneState, ontology: Ontology) -> _Key:
        return (id(state), state.revision, id(ontology))

    def _cached(self, key: _Key, state: SceneState, ontology: Ontology) -> Graph | None:
        alive = self._state_ref() if self._state_ref is not None else None
        if self._key == key and alive is state and self._ontology is ontology:
            return self._graph
        return None

    def _store(self, key: _Key, state: SceneState, ontology: Ontology, graph: Graph) -> None:
        self._key, self._graph = key, graph
        self._state_ref, self._ontology = weakref.ref(state), ontology
        self.builds += 1

    def graph(self, state: SceneState, ontology: Ontology) -> Graph:
        """Ontology + scene at ``state.revision``, built here (blocking) on a cache miss. The
        graph is never mutated afterwards, so it may be read from another thread."""
        key = self._cache_key(state, ontology)
        graph = self._cached(key, state, ontology)
        if graph is None:
            graph = build_graph(ontology, state.elements.values(), state.match_relations())
            self._store(key, state, ontology, graph)
        return graph

    async def graph_async(
        self, state: SceneState, ontology: Ontology, *, limiter: CapacityLimiter | None = None
    ) -> Graph:
        """Like :meth:`graph`, but a cache miss costs the loop only a msgpack snapshot of the
        scene; the graph is built from it in a worker thread.
        Concurrent callers at the same revision share one build."""
        key = self._cache_key(state, ontology)
        while (graph := self._cached(key, state, ontology)) is None:
            pending = self._building.get(key)
            if pending is not None:
                await pending.wait()
                continue
            done = self._building[key] = anyio.Event()
            try:
                ontology.graph  # noqa: B018 - an extended ontology merges its graph lazily: here
                data = encode((list(state.elements.values()), list(state.match_relations())))
                graph = await anyio.to_thread.run_sync(_build_from, ontology, data, limiter=limiter)
                if self._cache_key(state, ontology) == key:  # the state did not move meanwhile
                    self._store(key, state, ontology, graph)
                else:
                    return graph
            finally:
                del self._building[key]
                done.set()
        return graph

    # ------------------------------------------------------------------ preparing

    def prepare(self, text: str, ontology: Ontology) -> Query:
        """Parse and check a query (cached by text). Raises :class:`ValidationError` for an
        update, a syntax error (rdflib's message, line, column and a caret under the spot), an
        unknown prefix, ``SERVICE`` or ``FROM``."""
        key = (text, str(ontology.namespace))
        prepared = self._prepared.get(key)
        if prepared is not None:
            self._prepared.move_to_end(key)
            return prepared
        namespaces = {"skm": ontology.namespace, **FIXED_PREFIXES}
        try:
            prepared = prepareQuery(text, initNs=namespaces)
        except Exception as exc:
            raise prepare_error(text, exc) from None
        check_safe(prepared)
        self._prepared[key] = prepared
        if len(self._prepared) > self._prepared_cache:
            self._prepared.popitem(last=False)
        return prepared

    def _bindings(
        self, state: SceneState, ontology: Ontology, prepared: Query, bindings: Mapping[str, str]
    ) -> dict[str, Identifier]:
        names = query_variables(prepared)
        out: dict[str, Identifier] = {}
        for raw, value in bindings.items():
            name = raw[1:] if raw[:1] in ("?", "$") else raw
            if not VARNAME.fullmatch(name):
                raise ValidationError(f"binding name {raw!r} is not a SPARQL variable name")
            if name not in names:
                raise ValidationError(
                    f"binding ?{name} does not occur in the query; its variables are "
                    f"{', '.join('?' + v for v in sorted(names)) or 'none'}"
                )
            out[name] = term_for(state, ontology, value)
        return out

    # ------------------------------------------------------------------ running

    def query(
        self,
        state: SceneState,
        ontology: Ontology,
        text: str,
        bindings: Mapping[str, str] | None = None,
    ) -> SparqlReply:
        """Run a read-only query on the current state. Blocks for the (cached) graph build and
        the query: run it off the loop for big scenes (:meth:`query_async`). Raises
        :class:`ValidationError` for a refused or failing query."""
        prepared = self.prepare(text, ontology)
        init = self._bindings(state, ontology, prepared, bindings or {})
        graph = self.graph(state, ontology)
        prefixes = prefixes_for(ontology)
        return evaluate(graph, prepared, init, prefixes, state.revision, self.max_rows)

    async def query_async(
        self,
        state: SceneState,
        ontology: Ontology,
        text: str,
        bindings: Mapping[str, str] | None = None,
        *,
        limiter: CapacityLimiter | None = None,
    ) -> SparqlReply:
        """Like :meth:`query`, but only parsing, binding and (on a new revision) a msgpack
        snapshot of the scene run on the loop; the graph build and the query run in worker
        threads, on data that no other task touches: the state itself never leaves the loop.
        The reply is for the revision the state had when the call started."""
        prepared = self.prepare(text, ontology)
        init = self._bindings(state, ontology, prepared, bindings or {})
        prefixes, revision, max_rows = prefixes_for(ontology), state.revision, self.max_rows
        graph = await self.graph_async(state, ontology, limiter=limiter)
        return await anyio.to_thread.run_sync(
            evaluate, graph, prepared, init, prefixes, revision, max_rows, limiter=limiter
        )


# --------------------------------------------------------------------------- helpers


def _build_from(ontology: Ontology, data: bytes) -> Graph:
    elements, relations = _scene_decoder.decode(data)
    return build_graph(ontology, elements, relations)
