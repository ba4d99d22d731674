"""The monitor's ``sim_time``: the simulator's clock, read over the mesh, between its answers.

Device states carry no time; the simulator's ground truth (``sim/truth``) answers every
request with the simulated time. :class:`MeshClock` takes each such time
(:meth:`MeshClock.observe`) and, between two, advances by wall time at the pace measured
between the last two answers (a fast world runs several times real time). Without a
simulator on the mesh (real hardware) it is the wall seconds since the monitor started. It
never goes back: a recording's timeline only moves forward.
"""

from __future__ import annotations

import time
from collections.abc import Callable

__all__ = ["MeshClock"]

_MAX_PACE = 1000.0  # simulated seconds per wall second, at most (a pace measured over noise)


class MeshClock:
    """Simulated seconds now, from the answers seen (see the module doc). ``wall``: the wall
    clock (seconds, monotonic)."""

    def __init__(self, wall: Callable[[], float] = time.monotonic) -> None:
        self.wall = wall
        self._start = wall()
        self._seen: tuple[float, float] | None = None  # (sim time, wall time) of the last answer
        self.pace = 1.0
        """Simulated seconds per wall second, between the last two answers."""
        self._last = 0.0

    @property
    def simulated(self) -> bool:
        """A simulator answered at least once."""
        return self._seen is not None

    def observe(self, sim_time: float) -> None:
        """The simulator said it is ``sim_time`` now."""
        now = self.wall()
        if self._seen is not None:
            sim0, wall0 = self._seen
            if now > wall0 and sim_time >= sim0:
                self.pace = min((sim_time - sim0) / (now - wall0), _MAX_PACE)
        self._seen = (sim_time, now)

    def __call__(self) -> float:
        now = self.wall()
        if self._seen is None:
            t = now - self._start
        else:
            sim0, wall0 = self._seen
            t = sim0 + (now - wall0) * self.pace
        self._last = max(self._last, t)
        return self._last
