"""The mesh's sender, without Zenoh: order, coalescing of latest-only samples, drain on close."""

from __future__ import annotations

import threading
from collections.abc import Callable

import pytest

from meshlink import SessionError
from meshlink._sender import Latest, Sender

pytestmark = pytest.mark.anyio


async def test_publications_go_out_in_order_and_latest_only_samples_coalesce() -> None:
    sender = Sender()
    gate = threading.Event()
    sent: list[object] = []
    sender.submit(lambda: gate.wait(5))  # holds the thread: the next ones queue up
    latest = Latest(lambda payload, encoding: sent.append((payload, encoding)))

    def append(i: int) -> Callable[[], None]:
        return lambda: sent.append(i)

    for i in range(5):
        sender.submit(append(i))
        sender.submit_latest(latest, b"%d" % i, "e")  # replaces the queued sample
    sender.submit(lambda: sent.append("last"))
    assert sender.pending == 8  # the held op, 5 reliable ones, 1 latest sample, "last"
    gate.set()
    await sender.aclose(timeout=5)
    assert sent == [0, (b"4", "e"), 1, 2, 3, 4, "last"]
    assert sender.pending == 0
    with pytest.raises(SessionError, match="closed"):
        sender.submit(lambda: None)
    with pytest.raises(SessionError, match="closed"):
        sender.submit_latest(latest, b"x")


async def test_a_failing_publication_does_not_stop_the_sender() -> None:
    sender = Sender()
    sent: list[int] = []

    def boom() -> None:
        raise RuntimeError("boom")

    sender.submit(boom)
    sender.submit(lambda: sent.append(1))
    await sender.aclose(timeout=5)
    assert sent == [1]


async def test_closing_an_unused_sender_starts_no_thread() -> None:
    sender = Sender()
    await sender.aclose()
    assert sender._thread is None
