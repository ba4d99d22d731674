"""The coalescing inbox and the loop hand-off, without Zenoh."""

from __future__ import annotations

import threading
from collections.abc import Callable

import anyio
import anyio.lowlevel
import pytest

from meshlink import SubscriptionStatistics
from meshlink._bridge import Inbox, LoopPort

pytestmark = pytest.mark.anyio


class FakeLoop:
    """Records scheduled wake-ups; ``run()`` executes them as the loop would."""

    def __init__(self, alive: bool = True) -> None:
        self.pending: list[Callable[[], object]] = []
        self.scheduled = 0
        self.alive = alive

    def schedule(self, fn: Callable[[], object]) -> bool:
        if not self.alive:
            return False
        self.scheduled += 1
        self.pending.append(fn)
        return True

    def run(self) -> None:
        pending, self.pending = self.pending, []
        for fn in pending:
            fn()


def test_at_most_one_wake_up_until_the_consumer_drains() -> None:
    loop = FakeLoop()
    inbox: Inbox[int] = Inbox(loop.schedule)
    for i in range(1000):
        assert inbox.push(i)
    assert loop.scheduled == 1
    loop.run()
    for i in range(1000):  # items come out in order; pushes meanwhile still add no wake-up
        assert inbox.receive_nowait() == i
        inbox.push(1000 + i)
    assert loop.scheduled == 1
    for i in range(1000):
        assert inbox.receive_nowait() == 1000 + i
    with pytest.raises(anyio.WouldBlock):
        inbox.receive_nowait()  # drained: the next push arms a new wake-up
    inbox.push(7)
    assert loop.scheduled == 2
    assert inbox.statistics() == SubscriptionStatistics(received=2001, max_backlog=1000, pending=1)


def test_end_delivers_the_rest_then_end_of_stream() -> None:
    loop = FakeLoop()
    inbox: Inbox[str] = Inbox(loop.schedule)
    inbox.push("a")
    inbox.end()
    assert not inbox.push("late")  # no more items once ended
    assert inbox.receive_nowait() == "a"
    with pytest.raises(anyio.EndOfStream):
        inbox.receive_nowait()


def test_close_returns_undelivered_items_and_refuses_more() -> None:
    inbox: Inbox[str] = Inbox(FakeLoop().schedule)
    inbox.push("q1")
    inbox.push("q2")
    assert inbox.close() == ["q1", "q2"]
    assert not inbox.push("q3")
    with pytest.raises(anyio.EndOfStream):
        inbox.receive_nowait()


def test_push_after_the_loop_finished_is_refused_and_not_kept() -> None:
    inbox: Inbox[str] = Inbox(FakeLoop(alive=False).schedule)
    assert not inbox.push("x")
    assert inbox.statistics().pending == 0
    assert not inbox.push("y")


async def test_receive_waits_for_a_push_from_another_thread() -> None:
    inbox: Inbox[int] = Inbox(LoopPort().call_soon)
    async with anyio.create_task_group() as tg:
        tg.start_soon(anyio.to_thread.run_sync, inbox.push, 42)
        with anyio.fail_after(5):
            assert await inbox.receive() == 42


async def test_many_threads_deliver_everything_in_per_thread_order() -> None:
    port = LoopPort()
    wakeups = 0

    def schedule(fn: Callable[[], object]) -> bool:
        nonlocal wakeups
        wakeups += 1
        return port.call_soon(fn)

    inbox: Inbox[tuple[int, int]] = Inbox(schedule)
    threads, per_thread = 4, 20_000

    def produce(t: int) -> None:
        for i in range(per_thread):
            inbox.push((t, i))

    workers = [threading.Thread(target=produce, args=(t,)) for t in range(threads)]
    for w in workers:
        w.start()
    last = [-1] * threads
    with anyio.fail_after(20):
        for _ in range(threads * per_thread):
            t, i = await inbox.receive()
            assert i == last[t] + 1
            last[t] = i
    for w in workers:
        w.join()
    assert last == [per_thread - 1] * threads
    assert wakeups < threads * per_thread / 10  # coalesced, not one wake-up per item


async def test_a_busy_consumer_still_yields_to_the_loop() -> None:
    inbox: Inbox[int] = Inbox(LoopPort().call_soon)
    for i in range(1000):
        inbox.push(i)
    ticks = 0

    async def ticker() -> None:
        nonlocal ticks
        while True:
            ticks += 1
            await anyio.lowlevel.checkpoint()

    async with anyio.create_task_group() as tg:
        tg.start_soon(ticker)
        await anyio.lowlevel.checkpoint()
        before = ticks
        for _ in range(1000):
            await inbox.receive()
        assert ticks - before >= 1000 // 64 - 1
        tg.cancel_scope.cancel()


async def test_waiting_receive_is_cancellable() -> None:
    inbox: Inbox[int] = Inbox(LoopPort().call_soon)
    with anyio.move_on_after(0.05) as scope:
        await inbox.receive()
    assert scope.cancelled_caught


async def test_close_wakes_a_waiting_consumer() -> None:
    inbox: Inbox[int] = Inbox(LoopPort().call_soon)
    async with anyio.create_task_group() as tg:

        async def consume() -> None:
            with pytest.raises(anyio.EndOfStream):
                await inbox.receive()

        tg.start_soon(consume)
        await anyio.wait_all_tasks_blocked()
        inbox.close()


def test_loop_port_refuses_after_the_loop_finished() -> None:
    async def capture() -> LoopPort:
        return LoopPort()

    port = anyio.run(capture)
    assert port.call_soon(lambda: None) is False
