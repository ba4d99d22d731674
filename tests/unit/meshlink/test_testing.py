"""The test helpers catch what they are meant to catch."""

from __future__ import annotations

import socket
import time
from typing import TYPE_CHECKING

import anyio
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
        time.sleep(0.08)  # noqa: ASYNC251 - the blocking call this test must detect
        await anyio.sleep(0.02)
    assert watch.max_gap > 0.05
    assert any(" took " in report for report in blocking_detector.reports)


async def test_watch_loop_stays_quiet_on_a_free_loop() -> None:
    async with watch_loop(0.005) as watch:
        await anyio.sleep(0.1)
    assert watch.ticks >= 5
    assert watch.max_gap < 0.05


def test_free_port_is_bindable() -> None:
    port = free_port()
    with socket.socket() as s:
        s.bind(("127.0.0.1", port))
