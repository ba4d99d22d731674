"""Claims of running tasks on robots and objects: :class:`ClaimBook`.

A task claims, before its first step runs, every agent its plan commands and every object its
steps act on; another task whose plan needs one of them waits until the first releases it
(at its end: success, failure, abort, partial), so two tasks never command one robot.

- **All at once, never hold and wait** (no deadlock): a task acquires its whole claim in one
  step, and a task that needs more (a replan that brings in another robot) gives its claim
  back and acquires the larger one in one step again, waiting like any other.
- **Priorities**: waiting tasks are served highest priority first, then in the order they
  first asked (a task that gives its claim back and asks again keeps its place until it
  ends); a waiting task is never overtaken by a lower-priority one whose claim overlaps its
  own (it could wait for ever), while one that needs nothing it needs may go ahead.
- :meth:`ClaimBook.busy` names what other tasks hold, so a task can plan around them (robots
  and objects that are free) instead of waiting.
- **Preemption** (claims acquired ``preemptible``): when a waiting task is held up only by
  claims it may preempt, each of their holders is asked to give way
  (:meth:`ClaimBook.preempted` returns the waiting task's id). The holder gives its claim back
  at its next step boundary by asking for it again (:meth:`ClaimBook.acquire`): the higher
  priority goes first and the holder waits, keeping its place. The rule: task ``W`` may
  preempt the holder ``H`` when ``H`` is preemptible, ``W``'s priority is higher than
  ``H``'s, and higher than that of every task that preempted ``H`` before. So a preempted
  task is never preempted again by a task of equal or lower priority than the one before: a
  task is preempted at most once per priority level above its own (no livelock), and since a
  holder gives back everything before it waits, preemption adds no hold and wait (no
  deadlock). A waiting task also held up by a claim it may not preempt (or queued behind an
  overlapping one) asks nobody to give way: that would not let it start.
"""

from __future__ import annotations

import dataclasses
import itertools
import time
from collections.abc import Callable, Iterable
from dataclasses import dataclass, field

import anyio

__all__ = ["Claim", "ClaimBook", "Waiting"]


@dataclass(frozen=True)
class Claim:
    """What one task holds (or waits for)."""

    task_id: str
    agents: frozenset[str]
    objects: frozenset[str]
    priority: int = 0
    since: float = 0.0
    preemptible: bool = False
    """A task of higher priority may ask for it back (see the module doc)."""
    waited: bool = False
    """Granted after a wait (another task held or was queued for part of it)."""

    def overlaps(self, other: Claim) -> bool:
        return bool(self.agents & other.agents or self.objects & other.objects)

    def covers(self, other: Claim) -> bool:
        return self.agents >= other.agents and self.objects >= other.objects


@dataclass(eq=False)
class Waiting:
    claim: Claim
    order: int
    granted: anyio.Event = field(default_factory=anyio.Event)


class ClaimBook:
    """The claims of one task service (see the module doc); no global state."""

    def __init__(self, clock: Callable[[], float] = time.time) -> None:
        self.clock = clock
        self._held: dict[str, Claim] = {}
        self._waiting: list[Waiting] = []
        self._order = itertools.count()
        self._place: dict[str, int] = {}
        """Task id -> its place in the queue (its first request), kept until it releases."""
        self._shield: dict[str, int] = {}
        """Task id -> the priority of the last task that preempted it."""
        self._asked: dict[str, str] = {}
        """Holder's task id -> the task that asked it to give way (until it does)."""
        self._signals: dict[str, anyio.Event] = {}
        """Task id -> set when it is asked to give way (:meth:`preempted` waits on it)."""

    # ------------------------------------------------------------------ reading
    def held(self) -> list[Claim]:
        return list(self._held.values())

    def waiting(self) -> list[Claim]:
        return [w.claim for w in self._queue()]

    def claim_of(self, task_id: str) -> Claim | None:
        return self._held.get(task_id)

    def busy(self, task_id: str = "") -> tuple[frozenset[str], frozenset[str]]:
        """(agents, objects) held by tasks other than ``task_id``."""
        agents: set[str] = set()
        objects: set[str] = set()
        for claim in self._held.values():
            if claim.task_id != task_id:
                agents |= claim.agents
                objects |= claim.objects
        return frozenset(agents), frozenset(objects)

    def asked_by(self, task_id: str) -> str:
        """The task that asked ``task_id`` to give its claim back ("" if none did)."""
        return self._asked.get(task_id, "")

    async def preempted(self, task_id: str) -> str:
        """Wait until a task asks ``task_id`` to give its claim back; that task's id."""
        while task_id not in self._asked:
            await self._signals.setdefault(task_id, anyio.Event()).wait()
        return self._asked[task_id]

    # ------------------------------------------------------------------ changing
    async def acquire(
        self,
        task_id: str,
        agents: Iterable[str],
        objects: Iterable[str] = (),
        *,
        priority: int = 0,
        preemptible: bool = False,
    ) -> Claim:
        """Hold ``agents`` and ``objects`` for ``task_id``, waiting until no other task holds
        any of them (see the module doc). What the task held before is given back first and
        included in the new claim's wait, all in one step. Cancelling the wait leaves the
        task holding nothing."""
        self._held.pop(task_id, None)
        self._asked.pop(task_id, None)
        claim = Claim(
            task_id, frozenset(agents), frozenset(objects), priority, self.clock(), preemptible
        )
        order = self._place.setdefault(task_id, next(self._order))
        waiter = Waiting(claim, order)
        self._waiting.append(waiter)
        self._grant()
        if not waiter.granted.is_set():
            waiter.claim = dataclasses.replace(claim, waited=True)
        try:
            await waiter.granted.wait()
        except BaseException:
            if waiter in self._waiting:
                self._waiting.remove(waiter)
            else:  # granted in the same instant as the cancellation
                self._held.pop(task_id, None)
            self._grant()
            raise
        return self._held[task_id]

    def release(self, task_id: str) -> None:
        """Give back what ``task_id`` holds (nothing if it holds nothing); the task has
        ended: it loses its place in the queue and what it was asked."""
        for table in (self._place, self._shield, self._asked, self._signals):
            table.pop(task_id, None)
        if self._held.pop(task_id, None) is not None:
            self._grant()

    def _queue(self) -> list[Waiting]:
        return sorted(self._waiting, key=lambda w: (-w.claim.priority, w.order))

    def _grant(self) -> None:
        """Grant every waiting claim that overlaps no held claim and no claim queued before
        it (priority first, then place); ask the holders a waiting claim may preempt, when
        only they hold it up, to give way."""
        ahead: list[Claim] = []
        for waiter in self._queue():
            claim = waiter.claim
            if any(claim.overlaps(a) for a in ahead):
                ahead.append(claim)
                continue
            holders = [h for h in self._held.values() if claim.overlaps(h)]
            if not holders:
                self._waiting.remove(waiter)
                self._held[claim.task_id] = claim
                waiter.granted.set()
                continue
            ahead.append(claim)
            if all(self._may_preempt(claim, h) for h in holders):
                for holder in holders:
                    self._shield[holder.task_id] = claim.priority
                    if holder.task_id not in self._asked:
                        self._asked[holder.task_id] = claim.task_id
                        signal = self._signals.pop(holder.task_id, None)
                        if signal is not None:
                            signal.set()

    def _may_preempt(self, claim: Claim, holder: Claim) -> bool:
        """``claim`` may ask ``holder`` to give way (the rule of the module doc)."""
        shield = self._shield.get(holder.task_id)
        return (
            holder.preemptible
            and claim.priority > holder.priority
            and (shield is None or claim.priority > shield)
        )
