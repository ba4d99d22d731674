"""Helpers for tests of any skimesh package (no pytest import; ``tests/conftest.py`` wraps
them in fixtures): a free loopback port, an in-process Zenoh router, and a watchdog that
measures how long the event loop was blocked.
"""

from __future__ import annotations

import os
import socket
import time
from collections.abc import AsyncIterator, Iterator
from contextlib import asynccontextmanager, contextmanager

import anyio
import zenoh

from .bridge import call0
from .config import MeshConfig, to_zenoh_config
from .messages import Answer, IncomingQuery
from .router import router_config
from .session import open_mesh

__all__ = ["LoopWatch", "free_port", "remote_peer_main", "running_router", "watch_loop"]


def free_port() -> int:
    """A TCP port on 127.0.0.1 that was free a moment ago (another process may still take
    it: :func:`running_router` retries)."""
    with socket.socket(socket.AF_INET, socket.SOCK_STREAM) as s:
        s.bind(("127.0.0.1", 0))
        port: int = s.getsockname()[1]
        return port


@contextmanager
def running_router(*, attempts: int = 5) -> Iterator[str]:
    """Run a Zenoh router in this process on ``tcp/127.0.0.1:<free port>`` (multicast
    scouting off) and yield its endpoint; the router session is closed on exit.
    Synchronous: opening takes ~1 ms and does not need an event loop.

    Raises:
        zenoh.ZError: no free port could be bound in ``attempts`` tries.
    """
    for attempt in range(attempts):
        endpoint = f"tcp/127.0.0.1:{free_port()}"
        try:
            session = zenoh.open(to_zenoh_config(router_config([endpoint])))
        except zenoh.ZError:
            if attempt == attempts - 1:
                raise
            continue
        try:
            yield endpoint
        finally:
            call0(session.close)
        return


class LoopWatch:
    """Result of :func:`watch_loop`: ``max_gap`` is the longest time (seconds) the loop came
    back late to the heartbeat task, ``ticks`` how many heartbeats ran."""

    def __init__(self, interval: float) -> None:
        self.interval = interval
        self.max_gap = 0.0
        self.ticks = 0


@asynccontextmanager
async def watch_loop(interval: float = 0.005) -> AsyncIterator[LoopWatch]:
    """Run a heartbeat task that sleeps ``interval`` seconds in a loop and records how late
    each wake-up was: a blocked event loop shows up as a large ``max_gap``."""
    watch = LoopWatch(interval)

    async def heartbeat() -> None:
        last = time.perf_counter()
        while True:
            await anyio.sleep(interval)
            now = time.perf_counter()
            watch.max_gap = max(watch.max_gap, now - last - interval)
            watch.ticks += 1
            last = now

    async with anyio.create_task_group() as tg:
        tg.start_soon(heartbeat)
        try:
            yield watch
        finally:
            tg.cancel_scope.cancel()


def remote_peer_main(config: MeshConfig, token_key: str, serve_key: str) -> None:
    """Entry point of a child process (``multiprocessing`` *spawn* context: a forked child of
    a process with an open session breaks silently). Joins the mesh, serves ``serve_key``
    with ``b"<pid>|" + payload``, then declares ``token_key`` so a liveliness watcher knows it
    is ready; runs until killed."""

    async def echo(query: IncomingQuery) -> list[Answer]:
        return [Answer(serve_key, b"%d|%s" % (os.getpid(), query.payload or b""))]

    async def main() -> None:
        async with open_mesh(config) as mesh, anyio.create_task_group() as tg:
            await tg.start(mesh.serve, serve_key, echo)
            with mesh.declare_token(token_key):
                await anyio.sleep_forever()

    anyio.run(main)
