"""The test helpers catch what they are meant to catch."""

from __future__ import annotations

import socket
import time
from typing import TYPE_CHECKING

import anyio
import anyio.lowlevel
import pytest

from meshlink.testing import free_port, watch_loop

if TYPE_CHECKING:
    from tests.conftest import SlowSteps

pytestmark = pytest.mark.anyio


async def test_watch_loop_and_blocking_detector_see_a_blocked_loop(
    blocking_detector: SlowSteps,
) -> None:
    async with watch_loop(0.005) as watch:
        await anyio.sleep(0.02)
        time.sleep(0.08)  # noqa: ASYNC251 - the blocking call the heartbeat must see
        await anyio.sleep(0.02)
    assert watch.max_gap > 0.05
    assert not blocking_detector.reports  # a short wait uses no CPU: below the stall limit
    end = time.thread_time() + 0.06
    while time.thread_time() < end:  # a computation on the loop: 60 ms of CPU
        pass
    await anyio.lowlevel.checkpoint()  # the step ends here
    time.sleep(blocking_detector.stall + 0.02)  # noqa: ASYNC251 - a long blocking wait
    await anyio.lowlevel.checkpoint()
    busy, stalled = blocking_detector.reports
    assert " took " in busy and busy.endswith(" ms CPU)")
    assert int(busy.rsplit("(", 1)[1].split()[0]) >= 60
    assert int(stalled.rsplit(" took ", 1)[1].split()[0]) >= 1000


async def test_watch_loop_stays_quiet_on_a_free_loop() -> None:
    async with watch_loop(0.005) as watch:
        await anyio.sleep(0.1)
    assert watch.ticks >= 5
    assert watch.max_gap < 0.05


def test_free_port_is_bindable() -> None:
    port = free_port()
    with socket.socket() as s:
        s.bind(("127.0.0.1", port))
