"""Hardware locks: one run at a time per device.

A run locks the devices bound to its hardware parameters (device element ids) for its whole
life. Runs that share no device run in parallel; a run that needs a busy device is either
refused (:meth:`ResourceLocks.try_acquire` raises :class:`~skill_agent.ResourceBusyError`
naming the device and the run holding it) or queued (:meth:`ResourceLocks.acquire`).

Queueing is FIFO per device: a waiter is served only when every device it wants is free *and*
no earlier waiter wants one of them, so a late request never overtakes an earlier one on the
same device, while requests on disjoint devices do not wait for each other. A non-queued
request on a device somebody is queueing for is refused too (it would jump the queue).

Sub-runs of a composite skill *borrow* devices from their ancestors: a device held by an
ancestor is lent to the child and returns to the lender when the child releases it. Two
children of one parent cannot borrow the same device at once.

Locks are keyed by device element id; messages name a device by ``name`` (the agent gives
:func:`wm_store.display_name`, so ``r1-camera (Camera-2)``), the id alone by default.

Everything here is synchronous except :meth:`ResourceLocks.acquire`; no method blocks the loop.
"""

from __future__ import annotations

from collections import deque
from collections.abc import Callable, Collection, Iterable

import anyio
import msgspec

from skill_agent._errors import ResourceBusyError

__all__ = ["LockRequest", "LockStats", "ResourceLocks"]


class LockStats(msgspec.Struct, frozen=True):
    """A snapshot: device -> holding run, and the queued runs in order."""

    held: dict[str, str]
    waiting: list[str]


class _Waiter:
    __slots__ = ("granted", "ids", "run_id")

    def __init__(self, run_id: str, ids: frozenset[str]) -> None:
        self.run_id = run_id
        self.ids = ids
        self.granted = anyio.Event()


class LockRequest:
    """A place in the queue of :class:`ResourceLocks` (from :meth:`ResourceLocks.enqueue`)."""

    def __init__(self, locks: ResourceLocks, waiter: _Waiter) -> None:
        self._locks = locks
        self._waiter = waiter

    @property
    def granted(self) -> bool:
        return self._waiter.granted.is_set()

    async def wait(self) -> None:
        """Block until the devices are locked for the run; cancellation withdraws the
        request (and releases the devices if they were just granted)."""
        try:
            await self._waiter.granted.wait()
        except BaseException:
            self._locks._withdraw(self._waiter)
            raise


class ResourceLocks:
    """Per-device locks held by runs (see the module docstring). One instance per agent."""

    def __init__(self, name: Callable[[str], str] = str) -> None:
        """``name``: device id -> how messages name it."""
        self._name = name
        self._holders: dict[str, str] = {}
        self._lent: dict[str, dict[str, str]] = {}  # borrower run -> device -> lender run
        self._waiters: deque[_Waiter] = deque()

    # ------------------------------------------------------------------ queries

    def holder(self, device: str) -> str | None:
        """The run holding ``device``, or ``None``."""
        return self._holders.get(device)

    def held_by(self, run_id: str) -> frozenset[str]:
        return frozenset(d for d, r in self._holders.items() if r == run_id)

    def statistics(self) -> LockStats:
        return LockStats(dict(self._holders), [w.run_id for w in self._waiters])

    # ------------------------------------------------------------------ acquiring

    def try_acquire(
        self, run_id: str, ids: Iterable[str], *, borrow_from: Collection[str] = ()
    ) -> None:
        """Lock every device in ``ids`` for ``run_id`` at once, or none of them.

        A device held by one of ``borrow_from`` (the run's ancestors) is borrowed. Raises
        :class:`ResourceBusyError` naming the device and its holder (or the queued run)."""
        wanted = frozenset(ids)
        self._check_free(run_id, wanted, borrow_from, self._waiters)
        self._grant(run_id, wanted)

    async def acquire(self, run_id: str, ids: Iterable[str]) -> None:
        """Lock every device in ``ids``, waiting in FIFO order while any is busy.

        Blocks until granted; cancellation withdraws the request (nothing stays locked)."""
        await self.enqueue(run_id, ids).wait()

    def enqueue(self, run_id: str, ids: Iterable[str]) -> LockRequest:
        """Take a place in the queue now (or the devices, if free); ``await request.wait()``
        for them. Lets a caller fix its place in line before it starts waiting."""
        wanted = frozenset(ids)
        waiter = _Waiter(run_id, wanted)
        try:
            self.try_acquire(run_id, wanted)
            waiter.granted.set()
        except ResourceBusyError:
            self._waiters.append(waiter)
        return LockRequest(self, waiter)

    def _withdraw(self, waiter: _Waiter) -> None:
        if waiter.granted.is_set():
            self.release(waiter.run_id)
        elif waiter in self._waiters:
            self._waiters.remove(waiter)
            self._serve()

    def release(self, run_id: str) -> None:
        """Unlock everything ``run_id`` holds (borrowed devices go back to their lender), then
        serve the queue. Idempotent. (A queued request is withdrawn by cancelling its
        :meth:`acquire`.)"""
        lent = self._lent.pop(run_id, {})
        for device, holder in list(self._holders.items()):
            if holder != run_id:
                continue
            if device in lent:
                self._holders[device] = lent[device]
            else:
                del self._holders[device]
        self._serve()

    # ------------------------------------------------------------------ internals

    def _check_free(
        self,
        run_id: str,
        wanted: frozenset[str],
        borrow_from: Collection[str],
        ahead: Iterable[_Waiter],
    ) -> None:
        for device in sorted(wanted):
            holder = self._holders.get(device)
            if holder is not None and holder != run_id and holder not in borrow_from:
                raise ResourceBusyError(
                    f"device {self._name(device)} is busy: run {holder} holds it"
                    " (stop that run, or start with queue=True to wait for it)"
                )
        fresh = {d for d in wanted if d not in self._holders}  # borrowed ones skip the line
        for waiter in ahead:
            clash = fresh & waiter.ids
            if clash and waiter.run_id != run_id:
                device = min(clash)
                raise ResourceBusyError(
                    f"device {self._name(device)} is busy: run {waiter.run_id} is queued for it"
                    " (start with queue=True to wait in line)"
                )

    def _grant(self, run_id: str, wanted: frozenset[str]) -> None:
        for device in wanted:
            holder = self._holders.get(device)
            if holder is not None and holder != run_id:
                self._lent.setdefault(run_id, {})[device] = holder
            self._holders[device] = run_id

    def _serve(self) -> None:
        """Grant queued requests in order; an unserved waiter blocks later ones on its
        devices."""
        blocked: set[str] = set()
        for waiter in list(self._waiters):
            busy = any(d in self._holders for d in waiter.ids)
            if not busy and not (waiter.ids & blocked):
                self._waiters.remove(waiter)
                self._grant(waiter.run_id, waiter.ids)
                waiter.granted.set()
            else:
                blocked |= waiter.ids
