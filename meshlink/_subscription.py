"""What ``subscribe`` and ``watch_liveliness`` yield: an async iterator over an inbox of
Zenoh samples, converted to plain values as they are received (on the loop, not on Zenoh's
thread)."""

from __future__ import annotations

from collections.abc import Callable
from typing import Generic, TypeVar

import anyio
import zenoh

from ._bridge import Inbox
from ._messages import Liveness, Sample, SubscriptionStatistics

__all__ = ["Subscription", "liveness_of", "sample_of"]

T = TypeVar("T")


class Subscription(Generic[T]):
    """Items delivered by Zenoh, in order, as an async iterator (``async for item in sub``).

    Items wait in an unbounded inbox until received; iteration ends when the subscription's
    context exits or the session closes.
    """

    def __init__(self, inbox: Inbox[zenoh.Sample], convert: Callable[[zenoh.Sample], T]):
        self._inbox = inbox
        self._convert = convert

    async def receive(self) -> T:
        """Wait for the next item. Raises ``anyio.EndOfStream`` once the subscription ended."""
        return self._convert(await self._inbox.receive())

    def receive_nowait(self) -> T:
        """The next item if one is waiting; else raises ``anyio.WouldBlock`` (or
        ``anyio.EndOfStream`` once ended)."""
        return self._convert(self._inbox.receive_nowait())

    def statistics(self) -> SubscriptionStatistics:
        """A frozen snapshot: received so far, largest backlog, pending now."""
        return self._inbox.statistics()

    def __aiter__(self) -> Subscription[T]:
        return self

    async def __anext__(self) -> T:
        try:
            return await self.receive()
        except anyio.EndOfStream:
            raise StopAsyncIteration from None


def sample_of(s: zenoh.Sample) -> Sample:
    """The plain-value view of a received publication."""
    ts = s.timestamp
    return Sample(
        key=str(s.key_expr),
        payload=s.payload.to_bytes(),
        kind="put" if s.kind == zenoh.SampleKind.PUT else "delete",
        timestamp=None if ts is None else str(ts),
    )


def liveness_of(s: zenoh.Sample) -> Liveness:
    """A liveliness sample: PUT is a token appearing, DELETE one disappearing."""
    return Liveness(key=str(s.key_expr), alive=s.kind == zenoh.SampleKind.PUT)
