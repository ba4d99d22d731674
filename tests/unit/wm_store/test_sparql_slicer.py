"""The store stops its SPARQL child while it serves other requests (:class:`wm_store.rdf._slicer
.Slicer`): stopped on a request, continued once idle, never stopped longer than the bound, the
time stopped added to the query's limit; the worker still answers under a steady stream of
requests; a stopped child is always continued, and dies with a killed store."""

from __future__ import annotations

import os
import signal
import subprocess
import sys
import textwrap
import time
from pathlib import Path

import anyio
import pytest

from wm_store.ontology import Ontology
from wm_store.protocol import Info, InfoReply, Sparql, SparqlReply
from wm_store.rdf._slicer import Slicer
from wm_store.server import StoreConfig, WmStore

from .stores import serving
from .test_sparql_worker import GEARS, RUNAWAY, add_gears

ROOT = Path(__file__).resolve().parents[3]

pytestmark = pytest.mark.skipif(not Path("/proc/self/stat").exists(), reason="needs /proc")


class Clock:
    def __init__(self) -> None:
        self.now = 100.0

    def __call__(self) -> float:
        return self.now


@pytest.mark.anyio
async def test_the_child_is_stopped_while_the_store_serves_and_continued_when_idle() -> None:
    clock, sent = Clock(), list[tuple[int, int]]()
    slicer = Slicer(
        max_pause=0.1, min_run=0.01, linger=0.005, clock=clock, send=lambda *a: sent.append(a)
    )
    with slicer.serving():
        pass  # no query runs: nothing to stop
    assert sent == []
    scope = anyio.CancelScope(deadline=110.0)
    slicer.attach(7, scope)
    with slicer.serving():
        assert sent == [(7, signal.SIGSTOP)]
        clock.now += 0.002
    assert slicer.tick() == pytest.approx(0.005)  # idle, but lingers for the next request
    with slicer.serving():  # the next request within the linger: still stopped, no new signal
        clock.now += 0.002
    clock.now += 0.005
    assert slicer.tick() == float("inf")
    assert sent == [(7, signal.SIGSTOP), (7, signal.SIGCONT)]
    assert scope.deadline == pytest.approx(110.009), "the time stopped added to the limit"


@pytest.mark.anyio
async def test_a_child_stopped_for_the_bound_runs_whatever_comes() -> None:
    clock, sent = Clock(), list[tuple[int, int]]()
    slicer = Slicer(max_pause=0.1, min_run=0.01, clock=clock, send=lambda *a: sent.append(a))
    slicer.attach(7, anyio.CancelScope(deadline=110.0))
    with slicer.serving():  # a request that lasts: the bound continues the child
        clock.now += 0.06
        assert slicer.tick() == pytest.approx(0.04)
        clock.now += 0.04
        assert slicer.tick() == float("inf")
        assert sent[-1] == (7, signal.SIGCONT)
        with slicer.serving():  # within min_run: not stopped again
            assert sent[-1] == (7, signal.SIGCONT)
        clock.now += 0.011
        with slicer.serving():  # after it: stopped again
            assert sent[-1] == (7, signal.SIGSTOP)
    slicer.detach()  # the query ended: the child runs
    assert sent[-1] == (7, signal.SIGCONT) and slicer.stopped_at is None


def _state(pid: int) -> str:
    """The process's state letter (``T``: stopped), or "" once it is gone."""
    try:
        stat = Path(f"/proc/{pid}/stat").read_text()
    except OSError:
        return ""
    return stat.rsplit(")", 1)[1].split()[0]


@pytest.mark.anyio
async def test_the_worker_answers_under_a_steady_stream_of_requests() -> None:
    async with serving(WmStore(Ontology.default())) as (s, service):
        await add_gears(s, 30)
        await service.handle(Sparql(query=GEARS))  # the child is up
        slicer = service._sparql.slicer
        slicer.max_pause, slicer.min_run = 0.1, 0.01  # the bound, made quick to observe
        heavy = "SELECT (COUNT(*) AS ?n) WHERE { ?a ?b ?c . ?d a skm:Gear }"
        results: list[object] = []

        async def query() -> None:
            results.append(await service.handle(Sparql(query=heavy)))

        async with anyio.create_task_group() as tg:
            tg.start_soon(query)
            with service._sparql.serving():  # a request that never ends meanwhile
                with anyio.fail_after(60):
                    while not results:
                        info = await service.handle(Info())
                        assert isinstance(info, InfoReply)
                        await anyio.sleep(0.001)
        (reply,) = results
        assert isinstance(reply, SparqlReply) and reply.rows[0][0] != "0"
        assert slicer.pauses > 0, "the child was stopped while the store served"
        pid = service._sparql.pid
        assert pid is not None and _state(pid) not in ("T", "t", ""), "running after"


@pytest.mark.anyio
async def test_a_stopped_child_is_continued_however_its_query_ends() -> None:
    store = WmStore(Ontology.default(), StoreConfig(sparql_timeout=1.5))
    async with serving(store) as (s, service):
        await add_gears(s, 50)
        assert isinstance(await service.handle(Sparql(query=GEARS)), SparqlReply)
        first = service._sparql.pid
        assert first is not None
        with service._sparql.serving():
            began = time.monotonic()
            timed_out = await service.handle(Sparql(query=RUNAWAY))  # the limit passes
            took = time.monotonic() - began
            assert _state(first) == "", "the runaway's child was killed"
        assert getattr(timed_out, "code", "") == "query_limit"
        assert took > 1.5 + service._sparql.slicer.stopped_total - 0.05
        assert service._sparql.slicer.stopped_total > 0, "stopped time extended the limit"

        async def cancelled_query() -> None:
            with anyio.move_on_after(0.5):
                await service.handle(Sparql(query=RUNAWAY))

        with service._sparql.serving():  # the query is cancelled while its child is stopped
            await cancelled_query()
        pid = service._sparql.pid
        assert pid is not None and _state(pid) not in ("T", "t", ""), "continued"


KILLED_STORE = textwrap.dedent(
    """
    import sys, anyio
    from wm_store.ontology import Ontology
    from wm_store.protocol import AddElement, Sparql, Transact
    from wm_store.server import WmService, WmStore
    from tests.unit.wm_store.stores import running

    async def main():
        async with running(WmStore(Ontology.default())) as s:
            gears = [AddElement(type="Gear", label=f"g{i}") for i in range(50)]
            await s.transact(Transact(ops=gears))
            service = WmService(s)
            await service.handle(Sparql(query="ASK { ?s ?p ?o }"))
            async with anyio.create_task_group() as tg:
                tg.start_soon(service.handle, Sparql(query=sys.argv[1]))
                with service._sparql.serving():
                    while service._sparql.slicer.stopped_at is None:
                        await anyio.sleep(0.01)
                    print(service._sparql.pid, flush=True)
                    await anyio.sleep(60)

    anyio.run(main)
    """
)


def test_a_killed_store_leaves_no_stopped_child_behind() -> None:
    env = {**os.environ, "PYTHONPATH": str(ROOT)}
    store = subprocess.Popen(
        [sys.executable, "-c", KILLED_STORE, RUNAWAY], stdout=subprocess.PIPE, text=True, env=env
    )
    try:
        assert store.stdout is not None
        pid = int(store.stdout.readline())
        deadline = time.monotonic() + 10
        while _state(pid) not in ("T", "t"):  # the store stopped its child
            assert time.monotonic() < deadline, f"child {pid} never stopped: {_state(pid)!r}"
            time.sleep(0.01)
    finally:
        store.kill()
        store.wait(10)
        if store.stdout is not None:
            store.stdout.close()
    deadline = time.monotonic() + 10
    while _state(pid) not in ("", "Z"):  # gone (or a zombie of init's, reaped soon)
        assert time.monotonic() < deadline, f"child {pid} outlived the store: {_state(pid)!r}"
        time.sleep(0.01)
