"""SPARQL in a worker process (:class:`wm_store.rdf.SparqlWorker`, what ``wm/query`` runs): the
store's loop never parses or evaluates a query, a runaway query is ended by killing its
process, and text size, rows and the queue are bounded."""

from __future__ import annotations

import anyio
import anyio.lowlevel
import pytest

from meshlink.rpc import ErrorReply
from wm_store.ontology import Ontology
from wm_store.protocol import AddElement, Info, InfoReply, Sparql, SparqlReply, Transact
from wm_store.server import StoreConfig, WmService, WmStore

from .stores import running

pytestmark = pytest.mark.anyio

GEARS = "SELECT ?g WHERE { ?g a skm:Gear ; skm:rev ?r } ORDER BY ?g"  # scene elements only
RUNAWAY = "SELECT (COUNT(*) AS ?n) WHERE { ?a ?b ?c . ?d ?e ?f . ?g ?h ?i }"


async def add_gears(store: WmStore, n: int) -> None:
    first = len(store.state.elements)  # labels are unique: number them after what is there
    ops = [AddElement(type="Gear", label=f"g{first + i}") for i in range(n)]
    await store.transact(Transact(ops=list(ops)))


async def test_queries_follow_the_revision() -> None:
    store = WmStore(Ontology.default())
    async with running(store) as s:
        service = WmService(s)
        try:
            await add_gears(s, 2)
            first = await service.handle(Sparql(query=GEARS))
            assert isinstance(first, SparqlReply) and [r[0] for r in first.rows] == [
                "Gear-1",
                "Gear-2",
            ]
            await add_gears(s, 1)
            again = await service.handle(Sparql(query=GEARS))
            assert isinstance(again, SparqlReply) and len(again.rows) == 3
            assert again.revision == s.revision
            bad = await service.handle(Sparql(query="SELECT ?x WHERE { ?x a }"))
            assert isinstance(bad, ErrorReply) and bad.code == "validation_error"
            assert "syntax error" in bad.message
        finally:
            await service.aclose()


async def test_a_runaway_query_is_ended_and_the_store_keeps_answering() -> None:
    store = WmStore(Ontology.default(), StoreConfig(sparql_timeout=1.5))
    async with running(store) as s:
        service = WmService(s)
        try:
            await service.handle(Sparql(query=GEARS))  # the child is up and holds the scene
            started = service._sparql.started
            results: list[object] = []

            async def runaway() -> None:
                results.append(await service.handle(Sparql(query=RUNAWAY)))

            async with anyio.create_task_group() as tg:
                tg.start_soon(runaway)
                await anyio.lowlevel.checkpoint()  # let the runaway reach the worker
                answered_while_it_ran = 0
                for _ in range(20):  # reads and writes are answered while it runs
                    info = await service.handle(Info())
                    assert isinstance(info, InfoReply)
                    await add_gears(s, 1)
                    answered_while_it_ran += not results
                # (a loaded machine may end the runaway before all 20: some is enough)
                assert answered_while_it_ran >= 5, "the store answered while the query ran"
            (reply,) = results
            assert isinstance(reply, ErrorReply) and reply.code == "query_limit"
            assert "longer than 1.5 s" in reply.message
            after = await service.handle(Sparql(query=GEARS))
            assert isinstance(after, SparqlReply) and len(after.rows) == 20
            assert service._sparql.started == started + 1, "a fresh child after the kill"
        finally:
            await service.aclose()


async def test_text_rows_and_queue_are_bounded() -> None:
    config = StoreConfig(sparql_max_text=64, sparql_max_rows=3)
    store = WmStore(Ontology.default(), config)
    async with running(store) as s:
        service = WmService(s)
        try:
            long = await service.handle(Sparql(query="SELECT * WHERE { ?s ?p ?o } " + "#" * 64))
            assert isinstance(long, ErrorReply) and long.code == "query_limit"
            assert service._sparql.started == 0, "refused before any process started"
            await add_gears(s, 5)
            many = await service.handle(Sparql(query=GEARS))
            assert isinstance(many, ErrorReply) and "more than 3 rows" in many.message
            service._sparql.max_waiting = 0
            busy = await service.handle(Sparql(query=GEARS))
            assert isinstance(busy, ErrorReply) and "busy" in busy.message
        finally:
            await service.aclose()
