"""Waiting for a peer that is not there yet (a router, the store, a device server): it gives no
event to wait on, so the waiter tries again after a pause that doubles up to a bound, and says
now and then that it still waits (:class:`Backoff`)."""

from __future__ import annotations

import math

import anyio

__all__ = ["Backoff"]


class Backoff:
    """The pauses between tries, from ``first`` seconds doubling up to ``most``; how long the
    waiter has waited since it was made (on the event loop); whether to say so again: at the
    first :meth:`due`, then once ``every`` seconds have passed since it last said."""

    def __init__(self, first: float, most: float, *, every: float = 30.0) -> None:
        self.pause, self.most, self.every = first, most, every
        self.began = anyio.current_time()
        self._said = -math.inf

    @property
    def waited(self) -> float:
        return anyio.current_time() - self.began

    @property
    def said(self) -> bool:
        """Whether :meth:`due` ever said yes (the waiter told someone it waits)."""
        return self._said > -math.inf

    def due(self) -> bool:
        """Whether to say (again) that the waiter waits; True once per ``every`` seconds."""
        waited = self.waited
        if waited - self._said < self.every:
            return False
        self._said = waited
        return True

    async def wait(self) -> None:
        """Sleep the pause, then double it (up to ``most``)."""
        await anyio.sleep(self.pause)
        self.pause = min(self.most, self.pause * 2)
