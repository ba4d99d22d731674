"""Claims of tasks on robots and objects: a task waits for what another holds, all or nothing,
highest priority first, never overtaken by a lower-priority claim that overlaps its own, and a
task that grows its claim gives back and waits like any other (no deadlock)."""

from __future__ import annotations

import anyio
import pytest

from task_agent.claims import ClaimBook

pytestmark = pytest.mark.anyio


async def test_disjoint_claims_run_beside_each_other_and_overlapping_ones_wait() -> None:
    book = ClaimBook()
    await book.acquire("t1", {"r1"}, {"Gear-1"})
    await book.acquire("t2", {"r2"}, {"Gear-2"})  # nothing shared: at once
    assert {c.task_id for c in book.held()} == {"t1", "t2"}
    order: list[str] = []
    async with anyio.create_task_group() as tg:

        async def third() -> None:
            await book.acquire("t3", {"r1"}, ())
            order.append("t3 holds r1")

        tg.start_soon(third)
        await anyio.wait_all_tasks_blocked()
        assert [c.task_id for c in book.waiting()] == ["t3"] and order == []
        assert book.busy("t3") == (frozenset({"r1", "r2"}), frozenset({"Gear-1", "Gear-2"}))
        order.append("t1 done")
        book.release("t1")
    assert order == ["t1 done", "t3 holds r1"]


async def test_a_shared_object_makes_a_task_wait_too() -> None:
    book = ClaimBook()
    await book.acquire("t1", {"r1"}, {"KitBox-1"})
    with anyio.move_on_after(0.05) as waited:
        await book.acquire("t2", {"r2"}, {"KitBox-1"})
    assert waited.cancelled_caught and book.waiting() == [] and book.claim_of("t2") is None


async def test_higher_priority_first_and_never_overtaken_by_an_overlapping_lower_one() -> None:
    book = ClaimBook()
    await book.acquire("running", {"r1", "r2"})
    granted: list[str] = []
    async with anyio.create_task_group() as tg:

        async def want(task: str, agents: set[str], priority: int) -> None:
            await book.acquire(task, agents, priority=priority)
            granted.append(task)

        tg.start_soon(want, "low-r1", {"r1"}, 0)
        await anyio.wait_all_tasks_blocked()
        tg.start_soon(want, "high-r1-r2", {"r1", "r2"}, 5)
        await anyio.wait_all_tasks_blocked()
        tg.start_soon(want, "free-r3", {"r3"}, 0)  # needs nothing held or queued: goes ahead
        await anyio.wait_all_tasks_blocked()
        assert granted == ["free-r3"]
        assert [c.task_id for c in book.waiting()] == ["high-r1-r2", "low-r1"]
        book.release("running")
        await anyio.wait_all_tasks_blocked()
        assert granted == ["free-r3", "high-r1-r2"], "the high one first; low-r1 overlaps it"
        book.release("high-r1-r2")
    assert granted == ["free-r3", "high-r1-r2", "low-r1"]


async def test_growing_a_claim_gives_it_back_first_so_two_tasks_cannot_deadlock() -> None:
    book = ClaimBook()
    await book.acquire("t1", {"r1"})
    await book.acquire("t2", {"r2"})
    async with anyio.create_task_group() as tg:
        tg.start_soon(book.acquire, "t1", {"r1", "r2"})  # t1 replans onto r2 too
        await anyio.wait_all_tasks_blocked()
        assert book.claim_of("t1") is None, "t1 gave r1 back while it waits"
        tg.start_soon(book.acquire, "t2", {"r2", "r1"})  # t2 wants r1: it gives r2 back
        await anyio.wait_all_tasks_blocked()
        first = book.claim_of("t1")
        assert first is not None and first.agents == {"r1", "r2"}, "t1 waited first"
        assert [c.task_id for c in book.waiting()] == ["t2"]
        book.release("t1")
        await anyio.wait_all_tasks_blocked()
    second = book.claim_of("t2")
    assert second is not None and second.agents == {"r1", "r2"}


async def test_a_cancelled_wait_holds_nothing_and_unblocks_the_queue() -> None:
    book = ClaimBook()
    await book.acquire("t1", {"r1"})
    granted: list[str] = []
    scope = anyio.CancelScope()

    async def t2() -> None:
        with scope:
            await book.acquire("t2", {"r1", "r2"})

    async def t3() -> None:
        await book.acquire("t3", {"r2"})
        granted.append("t3")

    async with anyio.create_task_group() as tg:
        tg.start_soon(t2)
        await anyio.wait_all_tasks_blocked()
        tg.start_soon(t3)
        await anyio.wait_all_tasks_blocked()
        assert granted == [], "t3 overlaps t2 (queued before it)"
        scope.cancel()
        await anyio.wait_all_tasks_blocked()
        assert granted == ["t3"] and book.claim_of("t2") is None
