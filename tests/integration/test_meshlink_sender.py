"""Publications never block the event loop: a subscriber whose callback stalls congests the
link (the router holds BLOCK samples for it, then the publisher's send queue fills), and the
publishing process's loop keeps running while its samples wait in the mesh's sender queue.
Real Zenoh on loopback (an in-process router, multicast scouting off, a unique mesh name)."""

from __future__ import annotations

import threading
import time
from typing import TYPE_CHECKING

import anyio
import pytest
import zenoh

from meshlink import open_mesh, to_zenoh_config
from meshlink.testing import call0, undeclare, watch_loop

if TYPE_CHECKING:
    from tests.conftest import MeshConfigFactory as MakeConfig
    from tests.conftest import SlowSteps

pytestmark = [pytest.mark.zenoh, pytest.mark.anyio]

STALL = 1.5  # seconds the subscriber's callback blocks Zenoh's receive thread
PAYLOAD = 64 * 1024
LIMIT = 1500  # samples at most (~100 MB): bounded in size whatever the link does


async def test_a_stalled_subscriber_does_not_block_the_publishing_loop(
    module_router: str, mesh_config: MakeConfig, blocking_detector: SlowSteps
) -> None:
    release = threading.Event()
    received: list[int] = []

    def on_sample(sample: zenoh.Sample) -> None:  # Zenoh's receive thread: stalls it
        received.append(int.from_bytes(sample.payload.to_bytes()[:4], "big"))
        release.wait(STALL * 4)

    config = mesh_config(module_router)
    key = f"skimesh/{config.mesh}/tasks/events/stalled"
    raw = zenoh.open(to_zenoh_config(config))
    subscriber = raw.declare_subscriber(
        key, zenoh.handlers.Callback(on_sample, lambda: None, indirect=False)
    )
    timer = threading.Timer(STALL, release.set)
    try:
        async with open_mesh(config) as mesh:
            await mesh.get(key, timeout=1.0)  # one round trip: the router knows the subscriber
            sent, backlog, ticks = 0, 0, 0
            async with watch_loop(0.005) as watch:
                with mesh.publisher(key) as publisher:
                    timer.start()
                    started = time.perf_counter()
                    while not release.is_set() and time.perf_counter() - started < STALL * 2:
                        if sent < LIMIT:
                            publisher.put(sent.to_bytes(4, "big") + bytes(PAYLOAD))
                            sent += 1
                        pending = getattr(mesh.statistics(), "publications_pending", 0)
                        backlog = max(backlog, pending)
                        await anyio.sleep(0 if sent < LIMIT else 0.01)
                    await anyio.sleep(0.05)  # the heartbeat records the last gap
                    max_gap, ticks = watch.max_gap, watch.ticks
            # the loop kept running while the link was congested
            assert max_gap < 0.25, f"the loop was blocked for {max_gap * 1000:.0f} ms"
            assert blocking_detector.reports == []
            assert ticks > 50
            assert backlog > 0, "the link never congested: the test proves nothing"
            with anyio.fail_after(30):  # released: every sample arrives, in order
                while len(received) < sent:  # noqa: ASYNC110 - filled by a Zenoh thread
                    await anyio.sleep(0.01)
            assert received == list(range(sent))
    finally:
        release.set()
        timer.cancel()
        undeclare(subscriber)
        call0(raw.close)
