"""A test probe the example skills report to (injected through the skill factory; no globals).

Tests wait on what the skills did with :meth:`Probe.wait_calls` (event-driven, no polling) and
open gates a skill waits on with :meth:`Probe.open`.
"""

from __future__ import annotations

import time

import anyio
import msgspec

__all__ = ["Call", "Probe"]


class Call(msgspec.Struct, frozen=True):
    run_id: str
    method: str
    stamp: float


class Probe:
    """Records calls of skill methods, safe states reached, and holds named gates."""

    def __init__(self) -> None:
        self.calls: list[Call] = []
        self.safe_states: list[str] = []
        self._changed: anyio.Event | None = None
        self._gates: dict[str, anyio.Event] = {}

    def record(self, run_id: str, method: str) -> None:
        self.calls.append(Call(run_id, method, time.monotonic()))
        if self._changed is not None:
            self._changed.set()
            self._changed = None

    def count(self, method: str, run_id: str | None = None) -> int:
        return sum(1 for c in self.calls if c.method == method and run_id in (None, c.run_id))

    def methods(self, run_id: str) -> list[str]:
        return [c.method for c in self.calls if c.run_id == run_id]

    async def wait_calls(self, method: str, count: int = 1, *, run_id: str | None = None) -> None:
        """Block until ``method`` was recorded ``count`` times (for ``run_id`` if given)."""
        while self.count(method, run_id) < count:
            if self._changed is None:
                self._changed = anyio.Event()
            await self._changed.wait()

    def gate(self, name: str) -> anyio.Event:
        if name not in self._gates:
            self._gates[name] = anyio.Event()
        return self._gates[name]

    def open(self, name: str) -> None:
        self.gate(name).set()
