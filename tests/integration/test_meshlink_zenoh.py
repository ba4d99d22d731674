"""meshlink against real Zenoh: an in-process router on loopback, client sessions, multicast
scouting off. Every wait is on a condition with a deadline (``anyio.fail_after``)."""

from __future__ import annotations

import functools
import gc
import multiprocessing
import os
import signal
import time
from collections.abc import AsyncIterator, Sequence
from typing import TYPE_CHECKING

import anyio
import anyio.lowlevel
import pytest

from meshlink import (
    Answer,
    Handler,
    IncomingQuery,
    Liveness,
    Mesh,
    NoReplyError,
    RemoteError,
    SessionError,
    open_mesh,
    run_router,
)
from meshlink.testing import call0, remote_peer_main, watch_loop

pytestmark = [pytest.mark.zenoh, pytest.mark.anyio]

if TYPE_CHECKING:
    from tests.conftest import MeshConfigFactory as MakeConfig
    from tests.conftest import SlowSteps


@pytest.fixture
async def client(module_router: str, mesh_config: MakeConfig) -> AsyncIterator[Mesh]:
    async with open_mesh(mesh_config(module_router)) as mesh:
        yield mesh


@pytest.fixture
async def server(module_router: str, mesh_config: MakeConfig) -> AsyncIterator[Mesh]:
    async with open_mesh(mesh_config(module_router)) as mesh:
        yield mesh


async def echo(query: IncomingQuery) -> Sequence[Answer]:
    body = b"%s|%s|%s" % (query.key_expr.encode(), query.parameters.encode(), query.payload or b"")
    return [Answer(query.key_expr, body)]


# ---------------------------------------------------------------- query / reply
async def test_get_and_serve_in_one_session(client: Mesh) -> None:
    key = client.keys.wm_rpc()
    async with anyio.create_task_group() as tg:
        await tg.start(client.serve, key, echo)
        with anyio.fail_after(5):
            replies = await client.get(f"{key}?a=1;b=2", b"hello")
            assert [(r.key, r.payload, r.ok) for r in replies] == [
                (key, f"{key}|a=1;b=2|hello".encode(), True)
            ]
            assert await client.request(key, b"x") == f"{key}||x".encode()
        tg.cancel_scope.cancel()


def echo_on(key: str) -> Handler:
    """``echo``, answering on the served key (the query's may be a wildcard)."""

    async def handler(query: IncomingQuery) -> Sequence[Answer]:
        return [Answer(key, b"%s|%s" % (key.encode(), query.payload or b""))]

    return handler


async def test_get_collects_every_server_and_request_takes_one(client: Mesh, server: Mesh) -> None:
    keys = client.keys
    async with anyio.create_task_group() as tg:
        for name in ("robot_a", "robot_b"):
            key = keys.agent_skills(name)
            await tg.start(server.serve, key, echo_on(key))
        with anyio.fail_after(5):
            replies = await client.get(keys.agents_skills())
            assert sorted(r.key for r in replies) == [
                keys.agent_skills("robot_a"),
                keys.agent_skills("robot_b"),
            ]
            payload = await client.request(keys.agent_skills("robot_b"), b"p")
        assert payload == f"{keys.agent_skills('robot_b')}|p".encode()
        assert client.statistics().gets_in_flight == 0
        tg.cancel_scope.cancel()


async def test_handler_errors_become_remote_errors(client: Mesh, server: Mesh) -> None:
    async def handler(query: IncomingQuery) -> Sequence[Answer]:
        if query.payload == b"raise":
            raise ValueError("no such element 'Cup-3'")
        if query.payload == b"wrong-key":
            return [Answer("skimesh/elsewhere", b"x")]  # Zenoh refuses a disjoint reply key
        return [Answer("", b"refused: read-only", ok=False)]

    key = client.keys.wm_rpc()
    async with anyio.create_task_group() as tg:
        await tg.start(server.serve, key, handler)
        with anyio.fail_after(5):
            with pytest.raises(RemoteError) as info:
                await client.request(key, b"raise")
            assert info.value.payload == b"ValueError: no such element 'Cup-3'"
            with pytest.raises(RemoteError) as info:
                await client.request(key, b"answer-error")
            assert info.value.payload == b"refused: read-only"
            assert [r.ok for r in await client.get(key, b"answer-error")] == [False]
            with pytest.raises(RemoteError, match=r"ZError: .*skimesh/elsewhere"):
                await client.request(key, b"wrong-key")
        assert server.statistics().queries_being_served == 0
        tg.cancel_scope.cancel()


async def test_no_server_raises_no_reply_error_at_once(client: Mesh) -> None:
    start = time.monotonic()
    with pytest.raises(NoReplyError, match="tasks/rpc"):
        await client.request(client.keys.tasks_rpc(), b"x", timeout=3)
    assert time.monotonic() - start < 1.0  # nobody serves it: Zenoh finalizes at once
    assert await client.get(client.keys.tasks_rpc(), timeout=3) == []


async def test_a_silent_server_raises_no_reply_error_after_the_timeout(
    client: Mesh, server: Mesh
) -> None:
    release = anyio.Event()

    async def stuck(query: IncomingQuery) -> Sequence[Answer]:
        await release.wait()
        return []

    key = client.keys.wm_rpc()
    async with anyio.create_task_group() as tg:
        await tg.start(server.serve, key, stuck)
        start = time.monotonic()
        with anyio.fail_after(5), pytest.raises(NoReplyError, match=r"within 0\.3 s"):
            await client.request(key, b"x", timeout=0.3)
        assert 0.25 < time.monotonic() - start < 2.0
        release.set()
        tg.cancel_scope.cancel()


async def test_cancelling_the_caller_cancels_the_zenoh_query(client: Mesh, server: Mesh) -> None:
    entered, release, answered = anyio.Event(), anyio.Event(), anyio.Event()

    async def slow(query: IncomingQuery) -> Sequence[Answer]:
        entered.set()
        await release.wait()
        answered.set()
        return [Answer(query.key_expr, b"too late")]

    key = client.keys.wm_rpc()
    async with anyio.create_task_group() as tg:
        await tg.start(server.serve, key, slow)
        with anyio.fail_after(5):
            async with anyio.create_task_group() as inner:

                async def cancel_once_served() -> None:
                    await entered.wait()
                    assert client.statistics().gets_in_flight == 1
                    assert server.statistics().queries_being_served == 1
                    inner.cancel_scope.cancel()

                inner.start_soon(cancel_once_served)
                start = time.monotonic()
                await client.get(key, timeout=30)
                pytest.fail("get returned although its scope was cancelled")
        # Returned promptly, not after Zenoh's 30 s timeout, and Zenoh had already finalized
        # the query: its drop callback ran before get() returned.
        assert time.monotonic() - start < 2.0
        assert client.statistics().gets_in_flight == 0
        # Zenoh sends no cancellation to the server: it still holds the query, and its late
        # answer reaches nobody (the next get sees only its own reply).
        assert server.statistics().queries_being_served == 1
        release.set()
        with anyio.fail_after(5):
            await answered.wait()
            assert [r.payload for r in await client.get(key)] == [b"too late"]
        assert client.statistics().gets_in_flight == 0
        tg.cancel_scope.cancel()


async def test_request_under_fail_after_raises_timeout_and_cancels(
    client: Mesh, server: Mesh
) -> None:
    async def never(query: IncomingQuery) -> Sequence[Answer]:
        await anyio.sleep_forever()
        return []

    key = client.keys.agent_rpc("r1")
    async with anyio.create_task_group() as tg:
        await tg.start(server.serve, key, never)
        with pytest.raises(TimeoutError), anyio.fail_after(0.2):
            await client.request(key, b"x", timeout=30)
        assert client.statistics().gets_in_flight == 0
        tg.cancel_scope.cancel()


async def test_stopping_a_server_answers_held_queries_and_undeclares(
    client: Mesh, server: Mesh
) -> None:
    entered = anyio.Event()

    async def held(query: IncomingQuery) -> Sequence[Answer]:
        entered.set()
        await anyio.sleep_forever()
        return []

    key = client.keys.wm_rpc()
    async with anyio.create_task_group() as tg:
        await tg.start(server.serve, key, held)

        async def stop_when_entered() -> None:
            await entered.wait()
            tg.cancel_scope.cancel()

        tg.start_soon(stop_when_entered)
        with anyio.fail_after(5), pytest.raises(RemoteError, match="Cancelled: the server stopped"):
            await client.request(key, b"x", timeout=30)
    assert server.statistics().queries_being_served == 0
    with anyio.fail_after(5), pytest.raises(NoReplyError):
        await client.request(key, b"x", timeout=30)  # undeclared: Zenoh finalizes at once


async def test_serve_runs_at_most_max_concurrency_handlers(client: Mesh, server: Mesh) -> None:
    running, peak = 0, 0
    two_running, release = anyio.Event(), anyio.Event()

    async def handler(query: IncomingQuery) -> Sequence[Answer]:
        nonlocal running, peak
        running += 1
        peak = max(peak, running)
        if running == 2:
            two_running.set()
        await release.wait()
        running -= 1
        return [Answer(query.key_expr, b"ok")]

    key = client.keys.wm_rpc()
    async with anyio.create_task_group() as tg:
        await tg.start(functools.partial(server.serve, key, handler, max_concurrency=2))
        results: list[bytes] = []

        async def call() -> None:
            results.append(await client.request(key, b"x"))

        with anyio.fail_after(5):
            async with anyio.create_task_group() as calls:
                for _ in range(6):
                    calls.start_soon(call)
                await two_running.wait()
                release.set()
        assert results == [b"ok"] * 6
        assert peak == 2
        tg.cancel_scope.cancel()


# ---------------------------------------------------------------- the loop never blocks
async def test_the_event_loop_never_blocks(
    client: Mesh, server: Mesh, blocking_detector: SlowSteps
) -> None:
    keys = client.keys
    samples = 10_000
    async with anyio.create_task_group() as tg:
        await tg.start(server.serve, keys.wm_rpc(), echo)
        async with server.subscribe(keys.wm_changes()) as sub, watch_loop(0.005) as watch:

            async def consume() -> None:
                for _ in range(samples):
                    await sub.receive()

            async def query(worker: int) -> None:
                for i in range(100):
                    replies = await client.get(keys.wm_rpc(), b"%d" % i)
                    assert [r.ok for r in replies] == [True]

            with anyio.fail_after(30):
                async with anyio.create_task_group() as work:
                    work.start_soon(consume)
                    for worker in range(5):  # 500 gets, 5 in flight at a time
                        work.start_soon(query, worker)
                    with client.publisher(keys.wm_changes()) as pub:
                        for i in range(samples):
                            pub.put(i.to_bytes(4, "big"))
                            if i % 100 == 99:  # this producer yields like any well-behaved task
                                await anyio.lowlevel.checkpoint()
        tg.cancel_scope.cancel()
    assert watch.ticks > 10
    assert watch.max_gap < 0.1, f"the loop was blocked for {watch.max_gap * 1000:.0f} ms"
    assert blocking_detector.reports == []


# ---------------------------------------------------------------- publish / subscribe
async def test_subscribe_receives_every_block_published_sample_in_order(
    client: Mesh, server: Mesh
) -> None:
    n = 20_000
    key = client.keys.device_state("r1", "arm")
    async with server.subscribe(client.keys.devices()) as sub:
        with client.publisher(key) as pub:
            for i in range(n):
                pub.put(i.to_bytes(4, "big"), encoding="application/octet-stream")
                if i % 1000 == 999:
                    await anyio.lowlevel.checkpoint()
            pub.delete()
        client.put(key, b"one-shot")
        with anyio.fail_after(20):
            for i in range(n):
                sample = await sub.receive()
                assert (sample.key, sample.kind) == (key, "put")
                assert int.from_bytes(sample.payload, "big") == i
            deleted, one_shot = await sub.receive(), await sub.receive()
        assert (deleted.kind, deleted.payload) == ("delete", b"")
        assert (one_shot.kind, one_shot.payload) == ("put", b"one-shot")
        stats = sub.statistics()
        assert (stats.received, stats.pending) == (n + 2, 0)
        assert stats.max_backlog >= 1
        with pytest.raises(anyio.WouldBlock):
            sub.receive_nowait()


async def test_subscription_iteration_ends_when_the_session_closes(
    module_router: str, mesh_config: MakeConfig, client: Mesh
) -> None:
    received: list[bytes] = []
    async with (
        open_mesh(mesh_config(module_router)) as other,
        other.subscribe(other.keys.wm_changes()) as sub,
    ):
        client.put(client.keys.wm_changes(), b"a")
        with anyio.fail_after(5):
            received.append((await sub.receive()).payload)
            await anyio.to_thread.run_sync(call0, other.session.close)  # behind meshlink's back
            async for sample in sub:  # ends: Zenoh dropped the subscriber on close
                received.append(sample.payload)
    assert received == [b"a"]


# ---------------------------------------------------------------- liveliness
async def test_liveliness_history_appear_and_disappear(
    module_router: str, mesh_config: MakeConfig, client: Mesh, server: Mesh
) -> None:
    keys = client.keys
    early = server.declare_token(keys.agent("early"))
    async with client.watch_liveliness(keys.agents()) as events:
        with anyio.fail_after(5):
            assert await events.receive() == Liveness(keys.agent("early"), True)  # history
            with server.declare_token(keys.agent("late")) as late:
                assert late.declared
                assert await events.receive() == Liveness(keys.agent("late"), True)
            assert await events.receive() == Liveness(keys.agent("late"), False)
            async with open_mesh(mesh_config(module_router)) as third:
                third.declare_token(keys.agent("third"))
                assert await events.receive() == Liveness(keys.agent("third"), True)
            assert await events.receive() == Liveness(keys.agent("third"), False)  # closed
            early.undeclare()
            early.undeclare()  # idempotent
            assert await events.receive() == Liveness(keys.agent("early"), False)
    assert keys.name_of_agent_key(keys.agent("early")) == "early"


async def test_alive_lists_the_tokens_alive_now(client: Mesh, server: Mesh) -> None:
    keys = client.keys
    assert await client.alive(keys.agents(), timeout=5.0) == []
    async with client.watch_liveliness(keys.agents()) as events:
        with anyio.fail_after(5):
            with server.declare_token(keys.agent("a1")), server.declare_token(keys.agent("a2")):
                seen = {(await events.receive()).key, (await events.receive()).key}
                assert seen == {keys.agent("a1"), keys.agent("a2")}
                everyone = await client.alive(keys.agents(), timeout=5.0)
                assert everyone == [keys.agent("a1"), keys.agent("a2")]
                assert await client.alive(keys.agent("a2"), timeout=5.0) == [keys.agent("a2")]
            gone = {(await events.receive()), (await events.receive())}
            assert gone == {Liveness(keys.agent("a1"), False), Liveness(keys.agent("a2"), False)}
    assert await client.alive(keys.agents(), timeout=5.0) == []


async def test_a_token_whose_object_is_dropped_stays_alive(client: Mesh, server: Mesh) -> None:
    keys = client.keys
    async with client.watch_liveliness(keys.agents()) as events:
        server.declare_token(keys.agent("kept"))  # the returned object is not kept
        with anyio.fail_after(5):
            assert await events.receive() == Liveness(keys.agent("kept"), True)
            gc.collect()
            # Messages of one session reach the watcher in order: had the collection undeclared
            # the first token, its "not alive" would arrive before this marker.
            marker = server.declare_token(keys.agent("marker"))
            assert await events.receive() == Liveness(keys.agent("marker"), True)
            marker.undeclare()
            assert await events.receive() == Liveness(keys.agent("marker"), False)


async def test_a_killed_process_is_seen_gone(
    module_router: str, mesh_config: MakeConfig, client: Mesh
) -> None:
    keys = client.keys
    token, serve_key = keys.agent("child"), keys.agent_rpc("child")
    spawn = multiprocessing.get_context("spawn")  # fork after a Zenoh open breaks the child
    child = spawn.Process(
        target=remote_peer_main, args=(mesh_config(module_router), token, serve_key), daemon=True
    )
    async with client.watch_liveliness(keys.agents()) as events:
        child.start()
        try:
            with anyio.fail_after(20):
                assert await events.receive() == Liveness(token, True)  # serving by now
                assert child.pid is not None
                assert await client.request(serve_key, b"hi") == b"%d|hi" % child.pid
                os.kill(child.pid, signal.SIGKILL)
                assert await events.receive() == Liveness(token, False)
        finally:
            if child.is_alive() and child.pid is not None:
                os.kill(child.pid, signal.SIGKILL)
            await anyio.to_thread.run_sync(child.join, 10)


# ---------------------------------------------------------------- sessions and the router
async def test_run_router_starts_and_stops(free_tcp_port: int, mesh_config: MakeConfig) -> None:
    endpoint = f"tcp/127.0.0.1:{free_tcp_port}"
    with anyio.fail_after(10):
        async with anyio.create_task_group() as tg:
            zid = await tg.start(run_router, [endpoint])
            async with open_mesh(mesh_config(endpoint)) as mesh:
                assert [str(z) for z in mesh.session.info.routers_zid()] == [zid]
            tg.cancel_scope.cancel()  # run_router returns: the task group can exit
        with pytest.raises(SessionError, match=endpoint):  # the router is gone
            async with open_mesh(mesh_config(endpoint)):
                pass


async def test_a_router_on_a_taken_port_raises_session_error(module_router: str) -> None:
    with pytest.raises(SessionError, match="--listen") as info:
        await run_router([module_router])
    assert info.value.endpoints == (module_router,)


async def test_a_client_without_router_raises_session_error(
    free_tcp_port: int, mesh_config: MakeConfig
) -> None:
    endpoint = f"tcp/127.0.0.1:{free_tcp_port}"
    with anyio.fail_after(5), pytest.raises(SessionError, match="skimesh router") as info:
        async with open_mesh(mesh_config(endpoint)):
            pass
    assert endpoint in str(info.value)
    assert ".rs:" not in str(info.value)


async def test_the_session_is_closed_on_exception_and_cancellation(
    module_router: str, mesh_config: MakeConfig
) -> None:
    with pytest.raises(RuntimeError, match="boom"):
        async with open_mesh(mesh_config(module_router)) as failed:
            raise RuntimeError("boom")
    assert failed.session.is_closed()
    with anyio.CancelScope() as scope:
        async with open_mesh(mesh_config(module_router)) as cancelled:
            scope.cancel()
            await anyio.sleep_forever()
    assert cancelled.session.is_closed()
    with pytest.raises(SessionError, match="closed"):
        await cancelled.get(cancelled.keys.wm_rpc())
    with pytest.raises(SessionError, match="closed"):
        cancelled.put(cancelled.keys.wm_changes(), b"x")
