"""ResourceLocks: refusal naming device and holder, all-or-nothing, FIFO queueing without
overtaking, withdrawal on cancellation, borrowing by sub-runs."""

from __future__ import annotations

import anyio
import anyio.abc
import pytest

from skill_agent import ResourceBusyError
from skill_agent.runtime import LockStats, ResourceLocks

pytestmark = pytest.mark.anyio


async def test_try_acquire_refuses_naming_device_and_holder() -> None:
    locks = ResourceLocks()
    locks.try_acquire("run-a", ["Gripper-1", "Arm-1"])
    with pytest.raises(ResourceBusyError, match=r"device Gripper-1 is busy: run run-a holds it"):
        locks.try_acquire("run-b", ["Gripper-2", "Gripper-1"])
    # all or nothing: run-b got nothing, Gripper-2 is still free
    assert locks.holder("Gripper-2") is None
    locks.try_acquire("run-c", ["Gripper-2"])
    assert locks.held_by("run-a") == {"Gripper-1", "Arm-1"}
    assert locks.statistics() == LockStats(
        {"Gripper-1": "run-a", "Arm-1": "run-a", "Gripper-2": "run-c"}, []
    )
    locks.release("run-a")
    locks.release("run-a")  # idempotent
    assert locks.holder("Gripper-1") is None


async def test_empty_request_always_succeeds() -> None:
    locks = ResourceLocks()
    locks.try_acquire("a", [])
    await locks.acquire("b", [])
    assert locks.statistics().held == {}


async def _queue(
    locks: ResourceLocks, tg: anyio.abc.TaskGroup, run_id: str, ids: list[str], order: list[str]
) -> None:
    async def waiter() -> None:
        await locks.acquire(run_id, ids)
        order.append(run_id)

    tg.start_soon(waiter)
    await anyio.wait_all_tasks_blocked()


async def test_queue_is_fifo_per_device_and_disjoint_requests_do_not_wait() -> None:
    locks = ResourceLocks()
    order: list[str] = []
    locks.try_acquire("a", ["G1"])
    with anyio.fail_after(5):
        async with anyio.create_task_group() as tg:
            await _queue(locks, tg, "b", ["G1"], order)
            await _queue(locks, tg, "c", ["G1"], order)
            await _queue(locks, tg, "d", ["G2"], order)
            assert order == ["d"]  # disjoint: granted at once
            assert locks.statistics().waiting == ["b", "c"]
            locks.release("a")
            await anyio.wait_all_tasks_blocked()
            assert order == ["d", "b"]
            assert locks.holder("G1") == "b"
            locks.release("b")
    assert order == ["d", "b", "c"]


async def test_a_later_request_never_overtakes_a_queued_one() -> None:
    locks = ResourceLocks()
    order: list[str] = []
    locks.try_acquire("a", ["G1"])
    with anyio.fail_after(5):
        async with anyio.create_task_group() as tg:
            await _queue(locks, tg, "b", ["G1", "G2"], order)  # waits for G1, wants G2 too
            with pytest.raises(ResourceBusyError, match="run b is queued for it"):
                locks.try_acquire("c", ["G2"])
            await _queue(locks, tg, "c", ["G2"], order)  # queued behind b
            assert order == []
            locks.release("a")
            await anyio.wait_all_tasks_blocked()
            assert order == ["b"]
            locks.release("b")
    assert order == ["b", "c"]


async def test_cancelled_acquire_withdraws_and_serves_the_next() -> None:
    locks = ResourceLocks()
    order: list[str] = []
    locks.try_acquire("a", ["G1"])
    scope = anyio.CancelScope()

    async def b() -> None:
        with scope:
            await locks.acquire("b", ["G1", "G2"])

    with anyio.fail_after(5):
        async with anyio.create_task_group() as tg:
            tg.start_soon(b)
            await anyio.wait_all_tasks_blocked()
            await _queue(locks, tg, "c", ["G2"], order)
            assert order == []  # b, queued first, keeps G2 for itself
            scope.cancel()
            await anyio.wait_all_tasks_blocked()
            assert order == ["c"]
            assert locks.statistics() == LockStats({"G1": "a", "G2": "c"}, [])


async def test_sub_runs_borrow_from_ancestors_one_at_a_time() -> None:
    locks = ResourceLocks()
    locks.try_acquire("p", ["G1"])
    locks.try_acquire("p.1", ["G1", "G2"], borrow_from=["p"])
    assert locks.holder("G1") == "p.1"
    with pytest.raises(ResourceBusyError, match=r"run p\.1 holds it"):
        locks.try_acquire("p.2", ["G1"], borrow_from=["p"])
    locks.try_acquire("p.1.1", ["G1"], borrow_from=["p.1", "p"])  # grandchild
    locks.release("p.1.1")
    assert locks.holder("G1") == "p.1"
    locks.release("p.1")
    assert locks.holder("G1") == "p"  # returned to the lender
    assert locks.holder("G2") is None  # acquired outright, released
    with pytest.raises(ResourceBusyError):
        locks.try_acquire("q", ["G1"])
