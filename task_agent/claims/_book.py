"""Claims of running tasks on robots and objects: :class:`ClaimBook`.

A task claims, before its first step runs, every agent its plan commands and every object its
steps act on; another task whose plan needs one of them waits until the first releases it
(at its end: success, failure, abort, partial), so two tasks never command one robot.

- **All at once, never hold and wait** (no deadlock): a task acquires its whole claim in one
  step, and a task that needs more (a replan that brings in another robot) gives its claim
  back and acquires the larger one in one step again, waiting like any other.
- **Priorities**: waiting tasks are served highest priority first, then in the order they
  started to wait; a waiting task is never overtaken by a lower-priority one whose claim
  overlaps its own (it could wait for ever), while one that needs nothing it needs may go
  ahead.
- :meth:`ClaimBook.busy` names what other tasks hold, so a task can plan around them (robots
  and objects that are free) instead of waiting.
"""

from __future__ import annotations

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

    def overlaps(self, other: Claim) -> bool:
        return bool(self.agents & other.agents or self.objects & other.objects)


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

    # ------------------------------------------------------------------ changing
    async def acquire(
        self,
        task_id: str,
        agents: Iterable[str],
        objects: Iterable[str] = (),
        *,
        priority: int = 0,
    ) -> Claim:
        """Hold ``agents`` and ``objects`` for ``task_id``, waiting until no other task holds
        any of them (see the module doc). What the task held before is given back first and
        included in the new claim's wait, all in one step. Cancelling the wait leaves the
        task holding nothing."""
        self._held.pop(task_id, None)
        claim = Claim(task_id, frozenset(agents), frozenset(objects), priority, self.clock())
        waiter = Waiting(claim, next(self._order))
        self._waiting.append(waiter)
        self._grant()
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
        """Give back what ``task_id`` holds (nothing if it holds nothing)."""
        if self._held.pop(task_id, None) is not None:
            self._grant()

    def _queue(self) -> list[Waiting]:
        return sorted(self._waiting, key=lambda w: (-w.claim.priority, w.order))

    def _grant(self) -> None:
        """Grant every waiting claim that overlaps no held claim and no claim queued before
        it (priority first, then arrival)."""
        ahead: list[Claim] = []
        for waiter in self._queue():
            claim = waiter.claim
            blocked = any(claim.overlaps(h) for h in self._held.values()) or any(
                claim.overlaps(a) for a in ahead
            )
            if blocked:
                ahead.append(claim)
                continue
            self._waiting.remove(waiter)
            self._held[claim.task_id] = claim
            waiter.granted.set()
